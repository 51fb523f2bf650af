"""solo_response: nash_equilibrium of a one-player problem, bit for bit, with less overhead."""

import dataclasses

import numpy as np
import pytest

from intersection_cosim.games.nash import nash_equilibrium, solo_response
from intersection_cosim.games.problem import Player, Problem, shift_plan
from intersection_cosim.games.qp import reset_workspaces
from intersection_cosim.games.settings import GameSettings


def _problems(n: int, seed: int = 7):
    """Random solo problems: free road, a slow leader ahead, a stopped leader close ahead."""
    rng = np.random.default_rng(seed)
    t = np.arange(1, 31) * 0.1  # [s]
    out = []
    for m in range(n):
        v0, kappa = float(rng.uniform(0.0, 12.0)), float(rng.uniform(0.1, 0.9))  # [m/s], [-]
        leader = None
        if m % 3 == 1:
            v_l = float(rng.uniform(0.0, 8.0))  # [m/s]
            leader = (float(rng.uniform(8.0, 40.0)) + v_l * t, np.full(30, v_l))
        elif m % 3 == 2:
            leader = (np.full(30, float(rng.uniform(6.0, 15.0))), np.zeros(30))
        out.append(Problem((Player(float(rng.uniform(-50.0, 0.0)), v0, kappa, leader=leader),)))
    return out


def _run(solver, problems, gs, warm: bool):
    """Each problem solved cold, then (with ``warm``) once more from its shifted result, in one
    sequence of workspaces (OSQP keeps its duals and P between solves, as in a closed loop)."""
    reset_workspaces()
    results = []
    for problem in problems:
        res = solver(problem, gs, warm_start=None)
        results.append(res)
        if warm:
            results.append(solver(problem, gs, warm_start=(shift_plan(res.plans[0]),)))
    return results


@pytest.mark.parametrize("scheme,max_iter", [("gauss-seidel", 1), ("gauss-seidel", 4), ("jacobi", 3)])
def test_solo_response_is_nash_equilibrium_bit_for_bit(scheme, max_iter):
    gs = GameSettings()
    gs = dataclasses.replace(gs, solver=dataclasses.replace(gs.solver, scheme=scheme, nash_max_iter=max_iter))
    problems = _problems(24)
    ref, lean = _run(nash_equilibrium, problems, gs, True), _run(solo_response, problems, gs, True)
    assert len(ref) == len(lean) == 48
    statuses = set()
    for r, s in zip(ref, lean):
        assert (r.status, r.iterations, r.qp_count, r.residuals) == (s.status, s.iterations, s.qp_count, s.residuals)
        assert np.array_equal(r.costs, s.costs)
        assert np.array_equal(r.plans[0].accelerations, s.plans[0].accelerations)
        assert np.array_equal(r.plans[0].positions, s.plans[0].positions)
        assert (r.plans[0].duals is None) == (s.plans[0].duals is None)
        if r.plans[0].duals is not None:
            assert np.array_equal(r.plans[0].duals, s.plans[0].duals)
        statuses.add(r.status)
    assert "converged" in statuses  # the battery reaches both ends of the iteration
    if max_iter == 1:
        assert "iteration cap" in statuses


def test_solo_response_failure_is_the_comfortable_brake_plan():
    bad = Problem((Player(0.0, 8.0, 0.5, leader=(np.zeros(5), np.zeros(5))),))
    res = solo_response(bad, GameSettings())
    assert res.status == "solver failure" and res.qp_count == 0
    assert res.plans[0].speeds[-1] < 8.0
