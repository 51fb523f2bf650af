"""The anytime schedule's solve-time estimate and cutoff."""

import time

import pytest

from intersection_cosim.control.game.anytime import (DEFER_DECAY, SLOW_SOLVE_FACTOR, SMOOTHING, AnytimeSchedule,
                                                BatchTimeEstimate, GameTimeEstimate, SolveTimeEstimate,
                                                step_cutoff)


def test_a_solve_fits_only_if_its_slow_case_ends_before_the_cutoff():
    est = GameTimeEstimate(0.020, 0.010)  # [s] cold, warm per combination
    now = time.perf_counter()
    assert est.fits(1, 0, now + 1.0)
    assert not est.fits(1, 0, now + 0.5 * SLOW_SOLVE_FACTOR * 0.010)  # half the slow case: no
    assert not est.fits(4, 0, now + 3 * SLOW_SOLVE_FACTOR * 0.010)  # four combinations need 4x
    assert not est.fits(1, 0, now - 1.0)


def test_the_estimate_is_a_running_mean_and_shrinks_on_deferral():
    est = SolveTimeEstimate(0.004)
    est.measured(0.014)
    assert est.seconds == pytest.approx((1 - SMOOTHING) * 0.004 + SMOOTHING * 0.014)  # 6 ms
    est.deferred()
    assert est.seconds == pytest.approx(DEFER_DECAY * 0.006)
    sched = AnytimeSchedule()
    assert sched.game.cold.seconds > sched.game.warm.seconds > sched.solo.seconds(1)  # cold > warm > solo


def test_the_cutoff_keeps_the_reserve_of_the_time_left():
    deadline = time.perf_counter() + 1.0  # [s]
    cut = step_cutoff(deadline, 0.25)
    assert deadline - 0.25 <= cut <= deadline - 0.24
    assert step_cutoff(deadline - 2.0, 0.25) == deadline - 2.0  # past it: no time to keep


def test_the_cutoff_keeps_at_least_the_slow_case_of_the_filters_time():
    deadline = time.perf_counter() + 0.020  # [s] a 20 ms budget
    share = step_cutoff(deadline, 0.1, 0.0005)  # filter 0.5 ms: the share (2 ms) is larger
    assert deadline - 0.0021 <= share <= deadline - 0.0019
    slow = step_cutoff(deadline, 0.1, 0.004)  # filter 4 ms: twice that is kept, not 2 ms
    assert slow == pytest.approx(deadline - SLOW_SOLVE_FACTOR * 0.004, abs=1e-12)
    assert AnytimeSchedule().filter.seconds > 0.0  # a first guess before any measurement


def test_a_batch_estimate_learns_its_fixed_and_per_solve_parts():
    est = BatchTimeEstimate(0.0005, 0.001)
    for k in range(60):  # batches of 1..12 solves costing 0.3 ms + 0.2 ms per solve
        units = 1 + (7 * k) % 12
        est.measured(units, 0.0003 + 0.0002 * units)
    assert est.fixed == pytest.approx(0.0003, rel=1e-6) and est.per_unit == pytest.approx(0.0002, rel=1e-6)
    # a running mean per solve, fed the same batches, overestimates a batch of 30 by a fifth or more
    mean = SolveTimeEstimate(0.001)
    for k in range(60):
        units = 1 + (7 * k) % 12
        mean.measured((0.0003 + 0.0002 * units) / units)
    assert 30 * mean.seconds > 1.2 * est.seconds(30)
    now = time.perf_counter()
    assert est.fits(30, now + SLOW_SOLVE_FACTOR * 0.0063 + 0.001) and not est.fits(30, now + 0.0063)


def test_a_batch_estimate_of_one_size_and_after_a_deferral():
    est = BatchTimeEstimate(0.0005, 0.001)
    for _ in range(30):
        est.measured(4, 0.0025)  # always 4 solves: the fixed part stays, the rest is per solve
    assert est.seconds(4) == pytest.approx(0.0025, rel=1e-3) and est.fixed == pytest.approx(0.0005)
    before = est.seconds(4)
    est.deferred()
    assert est.seconds(4) == pytest.approx(DEFER_DECAY * before)
    est.measured(4, 0.0025 * DEFER_DECAY)  # the shrunk estimate is not undone by the fit
    assert est.seconds(4) == pytest.approx(DEFER_DECAY * before, rel=1e-3)


def test_a_game_is_estimated_by_its_warm_and_cold_combinations():
    est = GameTimeEstimate(0.004, 0.001)  # [s] cold, warm per combination
    assert est.seconds(1, 1) == pytest.approx(0.005) and est.seconds(2, 0) == pytest.approx(0.002)
    now = time.perf_counter()
    assert est.fits(2, 0, now + SLOW_SOLVE_FACTOR * 0.002 + 0.001)  # two warm combinations fit
    assert not est.fits(1, 1, now + SLOW_SOLVE_FACTOR * 0.002 + 0.001)  # one of them cold: not
    est.measured(2, 0, 0.003)  # warm games update the warm mean per combination
    assert est.warm.seconds == pytest.approx((1 - SMOOTHING) * 0.001 + SMOOTHING * 0.0015)
    assert est.cold.seconds == 0.004
    warm = est.warm.seconds
    est.measured(1, 1, 0.010)  # a mixed game: the cold mean gets what the warm one does not explain
    assert est.cold.seconds == pytest.approx((1 - SMOOTHING) * 0.004 + SMOOTHING * (0.010 - warm))
    prior = est.cold.seconds
    est.measured(1, 1, 0.0)  # a mixed game faster than its warm part: counted as the warm estimate
    assert est.cold.seconds == pytest.approx((1 - SMOOTHING) * prior + SMOOTHING * warm)
    before = (est.cold.seconds, est.warm.seconds)
    est.deferred(0, 2)  # only the kind that was deferred shrinks
    assert est.cold.seconds == pytest.approx(DEFER_DECAY * before[0]) and est.warm.seconds == before[1]
