"""games.solo_batch: many solo best responses in one pass, against solo_response one by one."""

import dataclasses

import numpy as np
import pytest

from intersection_cosim.games.objective import PlayerObjective
from intersection_cosim.games.problem import Plan, Player, Problem
from intersection_cosim.games.qp import reset_workspaces
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.games.nash import solo_response, warm_list
from intersection_cosim.games.solo_batch import SMALL_BATCH, SoloBatch, batchable, solo_responses
from intersection_cosim.games.sqp import initial_accelerations
from intersection_cosim.models.settings import ModelSettings

MS = ModelSettings()


def _settings(max_iter: int, hessian_reuse_tol: float | None = None) -> GameSettings:
    gs = GameSettings()
    tol = gs.solver.hessian_reuse_tol if hessian_reuse_tol is None else hessian_reuse_tol
    return dataclasses.replace(gs, solver=dataclasses.replace(gs.solver, nash_max_iter=max_iter,
                                                              hessian_reuse_tol=tol))


def _problems(count: int, seed: int = 3):
    """Solo vehicles at random states, most behind a leader at constant speed, most warm-started
    from a random plan."""
    gs = GameSettings()
    n, dt = gs.problem.steps, gs.problem.dt
    rng = np.random.default_rng(seed)
    problems, warms = [], []
    for i in range(count):
        s0, v0, kappa = rng.uniform(-60.0, 0.0), rng.uniform(0.0, 12.0), rng.uniform(0.1, 0.9)  # [m], [m/s], [-]
        leader = None
        if rng.random() < 0.7:
            v_l = np.full(n, rng.uniform(0.0, 10.0))  # [m/s]
            leader = (s0 + rng.uniform(3.0, 40.0) + np.cumsum(v_l) * dt, v_l)  # [m] front, 3-40 m ahead
        problems.append(Problem((Player(s0, v0, kappa, v_max=[None, 8.0][i % 2], leader=leader, name=f"v{i}"),)))
        warm = Plan.from_accelerations(s0, v0, rng.uniform(-2.0, 2.0, n), dt)
        warms.append(None if rng.random() < 0.2 else (warm,))
    return problems, warms


@pytest.mark.parametrize("max_iter", [1, 3])
def test_a_batch_of_one_is_solo_response_with_its_own_hessian(max_iter):
    """Alone in the batch and from the same fresh workspace, each problem gets the plan, cost,
    status and QP count of solo_response with ``own_hessian`` (the same QPs in the same order,
    each installing its own model Hessian, a fresh one every iteration), to rounding."""
    gs = _settings(max_iter)
    problems, warms = _problems(40)
    worst = 0.0
    for problem, warm in zip(problems, warms):
        reset_workspaces()
        one = solo_response(problem, gs, MS, warm_start=warm, own_hessian=True)
        reset_workspaces()
        ((plan, cost, residuals, qps, failure),) = SoloBatch([problem.players[0]], gs, MS).solve([warm_list(warm, 1)[0]])
        assert failure is None and qps == one.qp_count and len(residuals) == one.iterations
        assert cost == pytest.approx(one.costs[0], rel=1e-9, abs=1e-12)
        worst = max(worst, float(np.abs(plan.accelerations - one.plans[0].accelerations).max()))
    assert worst < 1e-9  # [m/s^2]


def test_small_batches_go_one_by_one_and_agree_with_the_batch():
    """Fewer than SMALL_BATCH problems are solved by solo_response (own Hessian): 12 problems in
    batches of three get the answers of one batch of twelve, within OSQP's tolerance (a QP
    without duals of its own warm-starts from the slot's last one, solved in another order)."""
    gs = _settings(1)
    problems, warms = _problems(12, seed=13)
    assert 3 < SMALL_BATCH <= 12
    reset_workspaces()
    whole = solo_responses(problems, gs, MS, warms)
    reset_workspaces()
    parts = [r for i in range(0, 12, 3) for r in solo_responses(problems[i:i + 3], gs, MS, warms[i:i + 3])]
    for a, b in zip(whole, parts):
        assert a.status == b.status and a.qp_count == b.qp_count
        np.testing.assert_allclose(a.plans[0].accelerations, b.plans[0].accelerations, atol=1e-3)  # [m/s^2]
        assert a.costs[0] == pytest.approx(b.costs[0], rel=1e-4, abs=1e-9)


def test_every_plan_of_a_batch_is_feasible_and_no_worse_than_its_start():
    """Each plan keeps its player's bounds (a in [a_min, a_max] m/s^2, 0 <= v <= v_cap m/s), starts
    at its state, and its true cost is at most that of its (projected) warm start."""
    gs = _settings(1)
    problems, warms = _problems(60, seed=5)
    reset_workspaces()
    results = solo_responses(problems, gs, MS, warms)
    assert all(r.status in ("converged", "iteration cap") for r in results)
    for problem, warm, result in zip(problems, warms, results):
        p, plan = problem.players[0], result.plans[0]
        v_cap = max(p.v_max or MS.v_max, p.v0)
        assert plan.positions[0] == p.s0 and plan.speeds[0] == p.v0
        assert gs.problem.a_min - 1e-9 <= plan.accelerations.min() and plan.accelerations.max() <= gs.problem.a_max + 1e-9
        assert plan.speeds.min() >= -1e-9 and plan.speeds.max() <= v_cap + 1e-9
        if warm is not None and p.leader is None:  # the exact QP: its optimum is no worse than the start
            obj = PlayerObjective(problem, 0, gs, MS)
            start = float(obj.cost(initial_accelerations(obj, warm[0], gs)))
            assert result.costs[0] <= start + 1e-9


def test_a_bad_problem_fails_alone_and_other_kinds_go_one_by_one():
    """A player with a non-finite leader prediction gets the comfortable-braking plan with status
    'solver failure'; its neighbours in the batch are solved as if it were not there. A problem
    with an interaction is not batchable and gets nash_equilibrium's answer."""
    gs = _settings(1)
    problems, warms = _problems(6, seed=7)
    n = gs.problem.steps
    bad = Problem((Player(-30.0, 5.0, 0.5, leader=(np.full(n, np.nan), np.zeros(n)), name="bad"),))
    pair = Problem((Player(-20.0, 5.0, 0.5), Player(-18.0, 5.0, 0.5)), ())
    assert not batchable(pair) and batchable(problems[0])
    reset_workspaces()
    alone = solo_responses(problems, gs, MS, warms)
    reset_workspaces()
    mixed = solo_responses(problems[:3] + [bad] + problems[3:], gs, MS, warms[:3] + [None] + warms[3:])
    assert mixed[3].status == "solver failure"
    assert np.all(np.diff(mixed[3].plans[0].speeds) <= 1e-12)  # it brakes
    others = mixed[:3] + mixed[4:]
    for a, b in zip(alone, others):
        np.testing.assert_allclose(a.plans[0].accelerations, b.plans[0].accelerations, atol=1e-12)
    (res,) = solo_responses([pair], gs, MS)
    assert res.status in ("converged", "iteration cap") and len(res.plans) == 2



def test_batches_of_other_sizes_and_horizons_in_between_change_no_answer():
    """The batch's work arrays are kept between calls (per thread): a batch solved after larger
    ones and after one of another horizon (N = 20 instead of 40) gets bit for bit the answers it
    got first, and its plans are its own (arrays no later batch writes into)."""
    gs = _settings(1)
    problems, warms = _problems(12, seed=11)
    reset_workspaces()
    first = solo_responses(problems, gs, MS, warms)
    kept = [r.plans[0].accelerations.copy() for r in first]
    big, big_warms = _problems(50, seed=12)
    solo_responses(big, gs, MS, big_warms)
    short = dataclasses.replace(gs, problem=dataclasses.replace(gs.problem, horizon=2.0))
    n_short = short.problem.steps
    assert n_short == 20
    shorts = [Problem((Player(-30.0 + i, 4.0, 0.5, leader=(np.linspace(-20.0, 0.0, n_short) + i, np.full(n_short, 3.0)),
                              name=f"s{i}"),)) for i in range(8)]
    assert all(r.status in ("converged", "iteration cap") for r in solo_responses(shorts, short, MS))
    reset_workspaces()
    again = solo_responses(problems, gs, MS, warms)
    for a, b, k in zip(first, again, kept):
        assert np.array_equal(a.plans[0].accelerations, b.plans[0].accelerations)
        assert np.array_equal(a.plans[0].accelerations, k)
        assert a.costs[0] == b.costs[0]
