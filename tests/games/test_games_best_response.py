"""Best response, cost model, QP workspace, plans and the failure fallback."""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
import pytest

from intersection_cosim.games import (GameSettings, Interaction, Plan, Player, Problem,
                                      best_response, nash_equilibrium, safe_plan, shift_plan,
                                      stackelberg_equilibrium)
from intersection_cosim.games.settings import ProblemSettings, SolverSettings
from intersection_cosim.games.sqp import sqp_best_response
from intersection_cosim.games.dynamics import rollout
from intersection_cosim.games.objective import PlayerObjective
from intersection_cosim.games.weights import comfort_weight
from intersection_cosim.games.problem import project_accelerations
from intersection_cosim.games.qp import QPWorkspace, workspace
from intersection_cosim.models.cost import (efficiency_cost, lateral_safety_cost, running_cost,
                                            time_to_conflict_point)


def test_settings_defaults_check_clean(gs):
    assert gs.problem.check() == [] and gs.solver.check() == []
    assert gs.problem.steps == 30
    bad = ProblemSettings(horizon=3.05, a_min=1.0, comfort_brake=5.0)
    assert {f for f, _ in bad.check()} == {"horizon", "a_min", "comfort_brake"}
    assert {f for f, _ in SolverSettings(scheme="newton", trust_region=9.0).check()} == {"scheme", "trust_region"}


def test_rollout_is_exact_discretisation(gs):
    a = np.linspace(-2.0, 2.0, gs.problem.steps)
    v, s = rollout(3.0, 5.0, a, gs.problem.dt)
    v_ref, s_ref, vk, sk = [], [], 5.0, 3.0
    for ak in a:
        sk += vk * gs.problem.dt + 0.5 * ak * gs.problem.dt**2
        vk += ak * gs.problem.dt
        v_ref.append(vk)
        s_ref.append(sk)
    assert v == pytest.approx(v_ref, abs=1e-12)
    assert s == pytest.approx(s_ref, abs=1e-12)
    plan = Plan.from_accelerations(3.0, 5.0, a, gs.problem.dt)
    assert plan.speeds[0] == 5.0 and plan.positions[0] == 3.0
    assert plan.speeds[1:] == pytest.approx(v_ref)


def _cross_objective(gs, ms, kappa=0.5, other_a=None, other_kappa=0.5):
    problem = Problem((Player(0.0, 6.0, kappa), Player(2.0, 5.0, other_kappa)),
                      (Interaction.cross(0, 1, 14.0, 12.0),))
    obj = PlayerObjective(problem, 0, gs, ms)
    other = Plan.from_accelerations(2.0, 5.0, np.zeros(gs.problem.steps) if other_a is None else other_a, gs.problem.dt)
    obj.set_others([None, other])
    return problem, obj, other


def test_true_cost_is_the_paper_running_cost(gs, ms):
    """C = dt * sum_k J(x_k) + comfort, J from models.cost (Eqs. 13-24)."""
    problem, obj, other = _cross_objective(gs, ms)
    a = np.linspace(1.0, -1.0, gs.problem.steps)
    v, s = rollout(0.0, 6.0, a, gs.problem.dt)
    tcp0 = time_to_conflict_point(14.0 - s, v, ms.tcp_speed_floor)
    tcp1 = time_to_conflict_point(12.0 - other.positions[1:], other.speeds[1:], ms.tcp_speed_floor)
    active = (s - 14.0 <= ms.conflict_clearance) & (other.positions[1:] - 12.0 <= ms.conflict_clearance)
    j = running_cost(0.5, 0.0, lateral_safety_cost(tcp0, tcp1, ms.eps, active), 0.0,
                     efficiency_cost(v, ms.v_max, ms.k_e), ms)
    comfort = gs.problem.w_accel * np.sum(a**2) + gs.problem.w_jerk / gs.problem.dt**2 * np.sum(np.diff(a) ** 2)
    assert obj.cost(a) == pytest.approx(gs.problem.dt * (np.sum(j) + comfort), rel=1e-12)
    # batched evaluation agrees
    assert obj.cost(np.stack([a, 0 * a]))[0] == pytest.approx(obj.cost(a), rel=1e-12)
    # a partner at kappa 0.8 weighs its J_lat term by exp(k_lat_partner * 0.3) = 2.86 (Eq. 7's form)
    _, bold, _ = _cross_objective(gs, ms, other_kappa=0.8)
    j_lat = lateral_safety_cost(tcp0, tcp1, ms.eps, active)
    extra = gs.problem.dt * 0.5 * ms.k_lat * (np.exp(ms.k_lat_partner * 0.3) - 1.0) * np.sum(j_lat)
    assert np.exp(ms.k_lat_partner * 0.3) == pytest.approx(2.858, abs=1e-3)
    assert bold.cost(a) - obj.cost(a) == pytest.approx(extra, rel=1e-9)
    assert extra > 0.01
    # a player at kappa 0.2 itself: (1 - kappa) J_lat, weighted by exp(k_lat_own * 0.3) = 1.35;
    # one at 0.8 would discount it to 0.74 and is held at 1 (never less than Eq. 19)
    for kappa, factor in ((0.2, 1.350), (0.8, 1.0)):
        _, own, _ = _cross_objective(gs, ms, kappa=kappa)
        j_e = efficiency_cost(v, ms.v_max, ms.k_e)
        exact = max(1.0, np.exp(-ms.k_lat_own * (kappa - 0.5)))
        assert exact == pytest.approx(factor, abs=1e-3)
        j_own = (1 - kappa) * ms.k_lat * exact * lateral_safety_cost(tcp0, tcp1, ms.eps, active) + kappa * j_e
        comfort_own = (comfort_weight(gs.problem, kappa) * np.sum(a**2)
                       + gs.problem.w_jerk / gs.problem.dt**2 * np.sum(np.diff(a) ** 2))
        assert own.cost(a) == pytest.approx(gs.problem.dt * (np.sum(j_own) + comfort_own), rel=1e-12)


def test_set_others_keeps_the_installed_plan_and_takes_a_new_one(gs, ms):
    """set_others skips the work for the partner Plan it installed last, never for a new Plan:
    the cost always answers the partner's latest plan (a stale cache would keep the old one)."""
    _, obj, other = _cross_objective(gs, ms)
    a = np.full(gs.problem.steps, 0.5)
    slow = Plan.from_accelerations(2.0, 5.0, np.full(gs.problem.steps, -1.5), gs.problem.dt)
    c_same = obj.cost(a)
    obj.set_others([None, other])  # the same Plan object: kept
    assert obj.cost(a) == c_same
    obj.set_others([None, slow])  # a new Plan: its trajectory enters J_lat
    _, fresh, _ = _cross_objective(gs, ms, other_a=np.full(gs.problem.steps, -1.5))
    assert obj.cost(a) == fresh.cost(a)
    assert abs(obj.cost(a) - c_same) > 0.01  # the partner braking at 1.5 m/s^2 moves the cost
    # an equal but new Plan object is installed again, with the same result
    obj.set_others([None, Plan.from_accelerations(2.0, 5.0, np.zeros(gs.problem.steps), gs.problem.dt)])
    assert obj.cost(a) == c_same


@pytest.mark.parametrize("kind", ["cross", "cross with an aggressive partner", "cross by a cautious player",
                                  "following"])
def test_gradient_matches_finite_differences(gs, ms, kind):
    """The convex model's slope is the true cost's (central differences), for both players' plans;
    with a partner at kappa 0.85 its J_lat term carries the partner's risk weight (2.9), by a
    player at kappa 0.25 its own (1.28)."""
    rng = np.random.default_rng(3)
    if kind.startswith("cross"):
        problem, obj, other = _cross_objective(gs, ms, kappa=0.25 if "cautious" in kind else 0.5,
                                               other_a=rng.uniform(-1, 1, gs.problem.steps),
                                               other_kappa=0.85 if "aggressive" in kind else 0.5)
    else:
        problem = Problem((Player(0.0, 7.0, 0.4), Player(25.0, 4.0, 0.5)), (Interaction.following(0, 1),))
        obj = PlayerObjective(problem, 0, gs, ms)
        other = Plan.from_accelerations(25.0, 4.0, rng.uniform(-1, 1, gs.problem.steps), gs.problem.dt)
        obj.set_others([None, other])
    a = rng.uniform(-1, 1, gs.problem.steps)
    c, g, H = obj.cost_and_model(a)
    fd = np.array([(obj.cost(a + 1e-6 * e) - obj.cost(a - 1e-6 * e)) / 2e-6 for e in np.eye(gs.problem.steps)])
    assert g == pytest.approx(fd, abs=1e-7)
    assert obj.gradient(a) == pytest.approx(g, abs=1e-12)
    assert np.linalg.eigvalsh(H).min() > 0.0  # the convex model
    # gradient with respect to the other player's plan (Stackelberg pair model)
    gp, gq, Hpp, Hpq, Hqq = obj.pair_model(a, 1, other)
    assert gp == pytest.approx(g, abs=1e-12)
    # the compiled model (games.convex_model) is the numpy pair model's own block, exactly symmetric
    assert np.abs(H - Hpp).max() <= 1e-12 * np.abs(Hpp).max() and np.abs(H - obj.Q).max() > 1e-4
    assert np.array_equal(H, H.T)

    def cost_for_other(b):
        obj.set_others([None, Plan.from_accelerations(other.positions[0], other.speeds[0], b, gs.problem.dt)])
        return obj.cost(a)

    b = other.accelerations
    fdq = np.array([(cost_for_other(b + 1e-6 * e) - cost_for_other(b - 1e-6 * e)) / 2e-6
                    for e in np.eye(gs.problem.steps)])
    assert gq == pytest.approx(fdq, abs=1e-7)
    joint = np.block([[Hpp, Hpq], [Hpq.T, Hqq]])
    assert np.linalg.eigvalsh(joint).min() > -1e-12


def test_best_response_decreases_true_cost_every_step(gs, ms):
    problem, obj, other = _cross_objective(gs, ms)
    a = project_accelerations(np.zeros(gs.problem.steps), obj.v0, obj.v_cap, gs)
    ws = workspace(gs.problem.steps, gs, "test-monotone")
    costs = [obj.cost(a)]
    for _ in range(8):
        out = sqp_best_response(obj, a, ws, gs, 1)
        assert out.cost <= costs[-1]
        costs.append(out.cost)
        a = out.a
    assert costs[-1] < costs[0]
    res = best_response(problem, 0, [None, other], gs, ms)
    assert res.status == "converged"
    assert res.cost == pytest.approx(costs[-1], rel=1e-3)
    # feasibility
    assert np.all(res.plan.accelerations >= gs.problem.a_min - 1e-6)
    assert np.all(res.plan.accelerations <= gs.problem.a_max + 1e-6)
    assert np.all(res.plan.speeds >= -1e-6) and np.all(res.plan.speeds <= ms.v_max + 1e-6)


def test_best_response_alone_without_game(gs, ms):
    """A vehicle with no game: k_lat = 0, only J_log to its leader and J_e."""
    import dataclasses

    no_lat = dataclasses.replace(ms, k_lat=0.0)
    problem = Problem((Player(0.0, 8.0, 0.3), Player(12.0, 3.0, 0.5), Player(0.0, 5.0, 0.5)),
                      (Interaction.following(0, 1), Interaction.cross(0, 2, 20.0, 20.0)))
    leader = Plan.from_accelerations(12.0, 3.0, np.zeros(gs.problem.steps), gs.problem.dt)
    res = best_response(problem, 0, {1: leader}, gs, no_lat)
    assert res.status == "converged"
    gap = leader.positions - res.plan.positions - ms.vehicle_length
    assert gap.min() > 0.0  # it brakes behind the slow leader
    assert res.plan.speeds[-1] < 8.0
    # without the leader it would accelerate
    free = best_response(Problem(problem.players[:1]), 0, None, gs, no_lat)
    assert free.plan.speeds[-1] > res.plan.speeds[-1] + 1.0


def test_qp_workspace_is_set_up_once_and_reused(gs):
    ws1 = workspace(gs.problem.steps, gs, "test-reuse")
    ws2 = workspace(gs.problem.steps, gs, "test-reuse")
    assert ws1 is ws2
    solver = ws1.solver
    H = np.eye(gs.problem.steps)
    g = -np.ones(gs.problem.steps)
    l, u = np.empty(2 * gs.problem.steps), np.empty(2 * gs.problem.steps)
    l[gs.problem.steps:], u[gs.problem.steps:] = ws1.speed_rows(5.0, 10.0, gs.problem.dt)
    l[:gs.problem.steps], u[:gs.problem.steps] = gs.problem.a_min, gs.problem.a_max
    sol = ws1.solve(H, g, np.zeros(gs.problem.steps), l, u)
    assert sol.ok
    assert sol.x == pytest.approx(np.ones(gs.problem.steps), abs=1e-3)  # unconstrained optimum a = 1
    sol2 = ws1.solve(H, 2 * g, np.zeros(gs.problem.steps), l, u)
    assert ws1.solver is solver and sol2.ok
    # speed cap binds: v0 = 5, v_cap = 10 -> sum a dt <= 5 over the first steps
    assert np.cumsum(sol2.x)[-1] * gs.problem.dt <= 5.0 + 1e-3


def _coupled_qp(gs, seed: int):
    """A coupled positive definite H, an iterate a [m/s^2] and g such that the unconstrained
    minimiser is x_star = a + U(-0.3, 0.3); box rows a_min, a_max, speed rows for v0 = 8 m/s and a
    cap of 20 m/s (never reached)."""
    n, dt = gs.problem.steps, gs.problem.dt
    ws = QPWorkspace(n, gs)
    rng = np.random.default_rng(seed)
    G = rng.normal(size=(n, n))
    H = G @ G.T / n + 0.5 * np.eye(n)
    a = np.full(n, 0.2)
    x_star = a + rng.uniform(-0.3, 0.3, n)
    g = H @ (a - x_star)
    l, u = np.empty(2 * n), np.empty(2 * n)
    l[n:], u[n:] = ws.speed_rows(8.0, 20.0, dt)
    l[:n], u[:n] = gs.problem.a_min, gs.problem.a_max
    return ws, H, g, a, x_star, l, u


def test_qp_with_no_active_bound_is_solved_exactly(gs):
    """An interior QP's answer is the exact minimiser a - H^-1 g (no ADMM iteration, zero
    multipliers)."""
    ws, H, g, a, x_star, l, u = _coupled_qp(gs, 4)
    sol = ws.solve(H, g, a, l, u)
    assert sol.ok and sol.iterations == 0
    assert np.abs(sol.x - x_star).max() < 1e-12
    assert np.all(sol.y == 0.0)


@pytest.mark.parametrize("seed", [4, 5, 6])
def test_qp_with_active_box_rows_is_solved_exactly_and_agrees_with_osqp(gs, seed):
    """A trust region of 0.1 m/s^2 around a cuts the minimiser off: the box active set answers
    without OSQP, meets the KKT conditions to rounding and agrees with OSQP's answer (qp_box_iter
    0) within OSQP's tolerance, at a model value no higher than OSQP's put back in the box."""
    ws, H, g, a, x_star, l, u = _coupled_qp(gs, seed)
    n = len(a)
    l[:n], u[:n] = a - 0.1, a + 0.1
    boxed = ws.solve(H, g, a, l, u)
    assert boxed.ok and boxed.iterations == 0
    assert np.all(boxed.x >= a - 0.1 - 1e-12) and np.all(boxed.x <= a + 0.1 + 1e-12)
    y = boxed.y
    assert np.all(y[n:] == 0.0) and np.abs(y[:n]).max() > 1e-3  # only box rows carry multipliers
    grad = H @ (boxed.x - a) + g
    assert np.abs(grad + y[:n]).max() < 1e-10  # stationarity: H x + c + y = 0
    at_hi, at_lo = np.isclose(boxed.x, a + 0.1, atol=1e-12), np.isclose(boxed.x, a - 0.1, atol=1e-12)
    assert np.all(y[:n][at_hi] >= 0.0) and np.all(y[:n][at_lo] <= 0.0)  # signs of the active bounds
    assert np.all(y[:n][~(at_hi | at_lo)] == 0.0)
    gs_osqp = dataclasses.replace(gs, solver=dataclasses.replace(gs.solver, qp_box_iter=0))
    ref = QPWorkspace(n, gs_osqp).solve(H, g, a, l, u)
    assert ref.ok and ref.iterations > 0
    assert np.abs(boxed.x - ref.x).max() < 5e-3

    def model(x):
        return 0.5 * x @ H @ x + (g - H @ a) @ x
    # OSQP's answer breaks the box by up to its tolerance; put back in it, it is no better
    assert model(boxed.x) <= model(np.clip(ref.x, a - 0.1, a + 0.1)) + 1e-12
    assert model(boxed.x) < model(np.clip(x_star, a - 0.1, a + 0.1)) - 1e-6  # not just clipping


def test_qp_with_an_active_speed_row_goes_to_osqp(gs):
    """A vehicle at 1 m/s whose minimiser brakes at 3 m/s^2 for the whole horizon would go
    backwards: the speed rows v >= 0 bind, which the box active set does not cover, so OSQP
    solves it (ADMM iterations > 0) and the plan stops at v = 0."""
    n, dt = gs.problem.steps, gs.problem.dt
    ws = QPWorkspace(n, gs)
    l, u = np.empty(2 * n), np.empty(2 * n)
    l[n:], u[n:] = ws.speed_rows(1.0, 20.0, dt)
    l[:n], u[:n] = gs.problem.a_min, gs.problem.a_max
    sol = ws.solve(np.eye(n), np.full(n, 3.0), np.zeros(n), l, u)  # minimiser a = -3 m/s^2
    assert sol.ok and sol.iterations > 0
    v = 1.0 + dt * np.cumsum(sol.x)
    assert v.min() >= -1e-3 and v[-1] < 1e-2
    assert sol.y[n:].min() < -1e-3  # a lower speed row carries a multiplier


def test_qp_reports_infeasible_and_bad_data(gs):
    ws = QPWorkspace(gs.problem.steps, gs)
    n = gs.problem.steps
    l, u = np.empty(2 * n), np.empty(2 * n)
    l[n:], u[n:] = ws.speed_rows(0.0, 10.0, gs.problem.dt)
    l[:n], u[:n] = -4.0, -3.0  # must brake from standstill while v >= 0: infeasible
    sol = ws.solve(np.eye(n), np.zeros(n), np.zeros(n), l, u)
    assert not sol.ok and "infeasible" in sol.status
    sol = ws.solve(np.full((n, n), np.nan), np.zeros(n), np.zeros(n), l, u)
    assert not sol.ok


def test_safe_plan_brakes_comfortably_to_stop(gs):
    plan = safe_plan(Player(10.0, 5.0, 0.5), gs)
    assert plan.accelerations.min() >= -gs.problem.comfort_brake - 1e-12
    assert plan.accelerations[0] == pytest.approx(-gs.problem.comfort_brake)
    assert plan.speeds.min() == pytest.approx(0.0, abs=1e-12)
    assert plan.speeds[-1] == 0.0  # 5 m/s at 2 m/s^2 stops after 2.5 s < 3 s
    assert np.all(np.diff(plan.positions) >= -1e-9)
    nan_plan = safe_plan(Player(math.nan, math.nan, 0.5), gs)
    assert np.all(np.isfinite(nan_plan.positions)) and np.all(nan_plan.speeds == 0.0)


@pytest.mark.parametrize("solver", ["nash", "stackelberg", "best_response"])
def test_nan_input_gives_solver_failure_and_safe_plan(gs, ms, solver):
    problem = Problem((Player(0.0, math.nan, 0.5), Player(0.0, 6.0, 0.5)),
                      (Interaction.cross(0, 1, 20.0, 18.0),))
    if solver == "nash":
        result = nash_equilibrium(problem, gs, ms)
        plans = result.plans
    elif solver == "stackelberg":
        result = stackelberg_equilibrium(problem, gs, ms)
        plans = result.plans
    else:
        result = best_response(problem, 1, None, gs, ms)
        plans = [None, result.plan]
    assert result.status == "solver failure"
    braking = plans[1]
    assert braking.accelerations[0] == pytest.approx(-gs.problem.comfort_brake)
    assert braking.speeds[-1] == pytest.approx(0.0) and braking.speeds.min() >= 0.0


def test_infeasible_input_gives_solver_failure(ms):
    """a_max < 0: v >= 0 cannot hold over the horizon from 2 m/s; OSQP reports infeasibility."""
    gs = GameSettings(ProblemSettings(a_max=-1.0))
    problem = Problem((Player(0.0, 2.0, 0.5), Player(0.0, 6.0, 0.5)), (Interaction.cross(0, 1, 20.0, 18.0),))
    for result in (nash_equilibrium(problem, gs, ms), stackelberg_equilibrium(problem, gs, ms)):
        assert result.status == "solver failure"
        assert "infeasible" in result.message
        assert result.plans[0].speeds[-1] == pytest.approx(0.0)
        assert all(np.all(np.isfinite(p.positions)) for p in result.plans)
    negative = Problem((Player(0.0, -3.0, 0.5), Player(0.0, 6.0, 0.5)))
    assert nash_equilibrium(negative, GameSettings(), ms).status == "solver failure"


def test_nan_in_other_plan_gives_failure(gs, ms):
    problem, obj, other = _cross_objective(gs, ms)
    bad = Plan(other.accelerations, other.speeds * np.nan, other.positions, gs.problem.dt)
    assert best_response(problem, 0, [None, bad], gs, ms).status == "solver failure"


def test_shift_plan_drops_first_step(gs):
    a = np.linspace(2.0, -1.0, gs.problem.steps)
    plan = Plan.from_accelerations(0.0, 5.0, a, gs.problem.dt, duals=np.arange(2.0 * gs.problem.steps))
    shifted = shift_plan(plan)
    assert shifted.accelerations[:-1] == pytest.approx(a[1:])
    assert shifted.accelerations[-1] == pytest.approx(a[-1])
    assert shifted.speeds[0] == pytest.approx(plan.speeds[1])
    assert shifted.positions[0] == pytest.approx(plan.positions[1])
    assert shifted.positions[:-1] == pytest.approx(plan.positions[1:])
    assert shifted.duals[0] == 1.0 and shifted.duals[gs.problem.steps] == gs.problem.steps + 1.0
    # the appended step never makes the speed negative
    stop = Plan.from_accelerations(0.0, 0.3, np.full(gs.problem.steps, -0.01), gs.problem.dt)
    assert shift_plan(stop).speeds.min() >= 0.0


def test_project_accelerations_feasible(gs):
    a = project_accelerations(np.full(gs.problem.steps, 5.0), 9.0, 10.0, gs)
    v = 9.0 + gs.problem.dt * np.cumsum(a)
    assert a.max() <= gs.problem.a_max and v.max() <= 10.0 + 1e-12
    a = project_accelerations(np.full(gs.problem.steps, -9.0), 1.0, 10.0, gs)
    assert (1.0 + gs.problem.dt * np.cumsum(a)).min() >= -1e-12
    assert np.all(project_accelerations([np.nan] * gs.problem.steps, 5.0, 10.0, gs) == 0.0)


def test_deadline_anytime_mode(pair_battery, gs, ms, monkeypatch):
    problem = pair_battery[1]
    past = nash_equilibrium(problem, gs, ms, deadline=time.perf_counter() - 1.0)
    assert past.status == "deadline" and past.iterations == 0
    assert all(np.all(np.isfinite(p.positions)) for p in past.plans)
    # every best response takes >= 4 ms: a 20 ms budget fits a few iterations, not 1000
    from intersection_cosim.games import nash as nash_module

    respond = nash_module.EquilibriumSolve.respond

    def slow_respond(self, *args, **kwargs):
        time.sleep(0.004)
        return respond(self, *args, **kwargs)

    monkeypatch.setattr(nash_module.EquilibriumSolve, "respond", slow_respond)
    endless = GameSettings(solver=SolverSettings(nash_tol=1e-12, nash_cost_rtol=0.0, nash_max_iter=1000))
    start = time.perf_counter()
    soon = nash_equilibrium(problem, endless, ms, deadline=start + 0.02)
    assert soon.status == "deadline"
    assert 1 <= soon.iterations < 1000
    assert time.perf_counter() - start < 0.02 + 0.02  # stops before starting a late iteration
    assert all(np.all(np.isfinite(p.positions)) for p in soon.plans)


def test_a_stackelberg_game_past_its_deadline_solves_no_qp(pair_battery, gs, ms):
    """As Nash's: past the deadline no QP is solved, not the warm follower's answer and not the
    final polish of the follower (up to br_max_sqp SQP steps: 4-11 QPs here before)."""
    n = gs.problem.steps
    for problem in pair_battery[:10]:
        warm = [np.zeros(n), np.full(n, 1.5)]  # [m/s^2] a follower far from its best response
        late = stackelberg_equilibrium(problem, gs, ms, warm_start=warm, deadline=time.perf_counter() - 1.0)
        assert late.status == "deadline" and late.iterations == 0 and late.qp_count == 0
        assert all(np.all(np.isfinite(p.positions)) for p in late.plans)
        cold = stackelberg_equilibrium(problem, gs, ms, deadline=time.perf_counter() - 1.0)
        assert cold.status == "deadline" and cold.qp_count == 0
        free = stackelberg_equilibrium(problem, gs, ms, warm_start=warm)  # no deadline: it works
        assert free.status != "deadline" and free.qp_count > 0


def test_record_costs_gives_convergence_history(pair_battery, gs, ms):
    result = nash_equilibrium(pair_battery[2], gs, ms, record_costs=True)
    assert result.cost_history.shape == (result.iterations, 2)
    assert result.cost_history[-1] == pytest.approx(result.costs)
    assert len(result.residuals) == result.iterations
    assert result.residuals[-1] < gs.solver.nash_cost_guard
    assert result.payoffs == pytest.approx(-result.costs)
