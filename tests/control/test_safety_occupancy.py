"""occupancy(): when a planned front reaches and passes a crossing's zone."""

import math

import numpy as np
import pytest

from intersection_cosim.control.safety.kinematics import braking_plan, occupancy, occupancy_times, reach_times
from intersection_cosim.games.problem import Plan


def test_occupancy_interpolates_the_plan_in_time():
    rng = np.random.default_rng(3)
    for _ in range(50):
        a = rng.uniform(-1.0, 2.0, 30)  # [m/s^2]
        plan = Plan.from_accelerations(100.0, 6.0, a, 0.1)
        pos = plan.positions
        t = np.arange(len(pos)) * 0.1  # [s]
        enter, leave = sorted(rng.uniform(pos[1], pos[-2], 2))
        t_in, t_out = occupancy(plan, enter, leave)
        assert t_in == pytest.approx(np.interp(enter, pos, t), abs=1e-9)
        assert t_out == pytest.approx(np.interp(leave, pos, t), abs=1e-9)
        assert 0.0 < t_in <= t_out < 3.0


def test_occupancy_edges_already_in_and_beyond_the_horizon():
    plan = Plan.from_accelerations(50.0, 5.0, np.zeros(30), 0.1)  # 5 m/s: 15 m in 3 s
    assert occupancy(plan, 40.0, 55.0) == (0.0, pytest.approx(1.0))  # in the zone now, out after 1 s
    t_in, t_out = occupancy(plan, 60.0, 70.0)
    assert t_in == pytest.approx(2.0) and t_out == math.inf  # passes it after the horizon
    stopped = braking_plan(plan, -4.0)  # stops after 3.1 m
    assert occupancy(stopped, 54.0, 60.0) == (math.inf, math.inf)


def test_occupancy_times_equal_occupancy_bit_for_bit():
    """The vectorised occupancy of the filter's first look equals occupancy() exactly: plans of
    different lengths (padded with inf), standing stretches, targets behind, inside and beyond."""
    rng = np.random.default_rng(7)
    plans = []
    for _ in range(40):
        n = int(rng.choice([20, 30, 40]))
        a = rng.uniform(-3.0, 2.0, n)  # [m/s^2]
        plans.append(braking_plan(Plan.from_accelerations(100.0, 2.0, a, 0.1), -2.0) if rng.random() < 0.3
                     else Plan.from_accelerations(100.0, float(rng.uniform(0.0, 10.0)), np.clip(a, 0.0, None), 0.1))
    width = max(len(p.positions) for p in plans)
    pos = np.full((len(plans), width), math.inf)
    for n, p in enumerate(plans):
        pos[n, :len(p.positions)] = p.positions
    lengths = np.array([len(p.positions) for p in plans])
    dt = np.array([p.dt for p in plans])
    row = rng.integers(0, len(plans), 500)
    target = rng.uniform(95.0, 140.0, 500)  # [m]
    target[:20] = pos[row[:20], 3]  # exactly on a sample
    got = occupancy_times(pos, lengths, dt, row, target)
    want = [occupancy(plans[r], t, t)[0] for r, t in zip(row, target)]
    assert got.tolist() == want
    assert (got == 0.0).any() and np.isinf(got).any() and ((got > 0.0) & np.isfinite(got)).any()


def test_reach_times_flag_exactly_where_a_wobbling_plan_agrees_with_occupancy():
    """A standing plan whose positions wobble by 1e-15 (as rounding leaves them): away from the
    wobble the vectorised time is occupancy()'s bit for bit and flagged exact; inside it the
    flag is off (the filter then asks the per-pair guard)."""
    pos = np.concatenate((100.0 + np.arange(10) * 0.5, np.full(21, 104.5)))  # [m] drives 4.5 m, stands
    pos[12], pos[15] = 104.5 - 1e-14, 104.5 + 1e-14  # backwards by 2e-14 at sample 13
    plan = Plan(np.zeros(30), np.zeros(31), pos, 0.1)
    targets = np.array([99.0, 101.3, 104.2, 104.5, 104.5 + 5e-15, 110.0])  # [m]
    got, exact = reach_times(pos[None, :].copy(), np.array([31]), np.array([0.1]), np.zeros(6, np.intp), targets)
    want = [occupancy(plan, x, x)[0] for x in targets]
    assert exact.tolist() == [True, True, True, False, False, True]
    assert got[exact].tolist() == [w for w, e in zip(want, exact) if e]
    assert got[0] == 0.0 and got[-1] == math.inf and 0.0 < got[2] < 1.0


@pytest.mark.parametrize("seed", range(3))
def test_the_vectorised_first_look_changes_no_decision(paths, net_file, seed, monkeypatch):
    """A dense random world decided with the filter's vectorised first look at every pair and
    with the per-pair guard alone: the same accelerations, bit for bit."""
    import time

    from intersection_cosim.control.safety.rules import crossing_order as safety
    from intersection_cosim.control.base import ControlContext
    from intersection_cosim.control.game.controller import GameController
    from intersection_cosim.models.settings import ModelSettings
    from intersection_cosim.network.movements import paper_movements
    from tests.control.test_relations_vectorised import _random_world

    def decide(min_pairs):
        monkeypatch.setattr(safety, "VECTOR_MIN_PAIRS", min_pairs)
        c = GameController("nash")
        c.setup(ControlContext(movements=paper_movements(net_file), model=ModelSettings(), control_period=0.1,
                               settings=None, etm=True))
        world = _random_world(paths, np.random.default_rng(seed), 40)
        return c.decide(world, time.perf_counter() + 60.0), c.safety

    vec, f_vec = decide(0)
    loop, f_loop = decide(10 ** 9)
    assert vec.accel == loop.accel and len(vec.accel) == 40
    assert (f_vec.filtered, f_vec.cleared) == (f_loop.filtered, f_loop.cleared)
    assert f_vec.filtered > 0  # the filter had crossings to guard
