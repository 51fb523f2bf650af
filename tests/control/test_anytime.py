"""The anytime schedule's solve-time estimate and cutoff."""

import time

import pytest

from intersection_cosim.control.anytime import (DEFER_DECAY, SLOW_SOLVE_FACTOR, SMOOTHING, AnytimeSchedule,
                                                SolveTimeEstimate, step_cutoff)


def test_a_solve_fits_only_if_its_slow_case_ends_before_the_cutoff():
    est = SolveTimeEstimate(0.010)  # [s]
    now = time.perf_counter()
    assert est.fits(1, now + 1.0)
    assert not est.fits(1, now + 0.5 * SLOW_SOLVE_FACTOR * 0.010)  # half the slow case: no
    assert not est.fits(4, now + 3 * SLOW_SOLVE_FACTOR * 0.010)  # four combinations need 4x
    assert not est.fits(1, now - 1.0)


def test_the_estimate_is_a_running_mean_and_shrinks_on_deferral():
    est = SolveTimeEstimate(0.004)
    est.measured(0.014)
    assert est.seconds == pytest.approx((1 - SMOOTHING) * 0.004 + SMOOTHING * 0.014)  # 6 ms
    est.deferred()
    assert est.seconds == pytest.approx(DEFER_DECAY * 0.006)
    sched = AnytimeSchedule()
    assert sched.game[False].seconds > sched.game[True].seconds > sched.solo.seconds  # cold > warm > solo


def test_the_cutoff_keeps_the_reserve_of_the_time_left():
    deadline = time.perf_counter() + 1.0  # [s]
    cut = step_cutoff(deadline, 0.25)
    assert deadline - 0.25 <= cut <= deadline - 0.24
    assert step_cutoff(deadline - 2.0, 0.25) == deadline - 2.0  # past it: no time to keep
