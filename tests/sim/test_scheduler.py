"""The step scheduler alone, with stand-in controllers (no SUMO needed)."""

import gc
import time

import numpy as np
import pytest

from intersection_cosim.control.base import Decisions, World
from intersection_cosim.games import budget_clock, nash_equilibrium
from intersection_cosim.games.problem import Player, Problem
from intersection_cosim.games.qp import solve_count
from intersection_cosim.sim.scheduler import StepScheduler


def _world(t=1.0):
    return World(time=t, ids=["V1"], path_ids=["p"], s=np.zeros(1), v=np.ones(1), a=np.zeros(1),
                 x=np.zeros(1), y=np.zeros(1), heading=np.zeros(1), kappa=np.full(1, 0.5), role=["ready"])


class _Controller:
    junction_type = "priority"
    controls_vehicles = True

    def __init__(self, sleep_s=0.0, fail=False):
        self.sleep_s, self.fail = sleep_s, fail

    def decide(self, world, deadline):
        time.sleep(self.sleep_s)
        if self.fail:
            raise RuntimeError("solver crashed")
        return Decisions(accel={"V1": 1.0}, games=2, iterations=5, pairs=[("V1", "V2")], release=["V0"])

    def fallback(self, world):
        return Decisions(accel={"V1": -2.0})


def test_within_budget_the_decisions_stand():
    d, rec = StepScheduler(_Controller(), budget_ms=200.0).step(_world())
    assert d.accel == {"V1": 1.0} and not rec.fallback and not rec.deadline_missed
    assert rec.games == 2 and rec.iterations == 5 and 0.0 <= rec.compute_ms < 200.0


def test_overrun_applies_the_fallback_and_keeps_the_counts():
    d, rec = StepScheduler(_Controller(sleep_s=0.03), budget_ms=10.0).step(_world())
    assert d.accel == {"V1": -2.0} and d.fallback
    assert rec.deadline_missed and rec.fallback and rec.compute_ms >= 30.0
    assert rec.games == 2 and d.pairs == [("V1", "V2")]  # what the overrunning step played


def test_a_controller_error_is_a_logged_fallback_not_a_crash(caplog):
    d, rec = StepScheduler(_Controller(fail=True), budget_ms=100.0).step(_world())
    assert d.accel == {"V1": -2.0} and rec.fallback and not rec.deadline_missed
    assert "solver crashed" in caplog.text


def test_realtime_paces_to_the_wall_clock():
    sched = StepScheduler(_Controller(), budget_ms=100.0, realtime=True)
    start = time.perf_counter()
    sched.pace(0.0)
    sched.pace(0.25)  # 0.25 s of simulated time must take 0.25 s of wall time
    assert time.perf_counter() - start == pytest.approx(0.25, abs=0.05)
    fast = StepScheduler(_Controller(), budget_ms=100.0, realtime=False)
    start = time.perf_counter()
    fast.pace(0.0)
    fast.pace(5.0)
    assert time.perf_counter() - start < 0.05


def test_an_overrun_step_still_releases_the_vehicles_decide_let_go():
    """decide forgets the vehicles it releases; the fallback that replaces its decisions must
    still hand them to SUMO, or they keep their last command with SUMO's checks off (a rear-end
    collision on the grid under load, between two junctions)."""
    d, rec = StepScheduler(_Controller(sleep_s=0.01), budget_ms=1.0).step(_world())
    assert rec.fallback and d.release == ["V0"] and d.accel == {"V1": -2.0}


class _Cycles(_Controller):
    """Makes enough cyclic garbage to start several collections, and records when it started and
    ended and whether the collector was on while it decided."""

    def decide(self, world, deadline):
        self.started, self.enabled = time.perf_counter(), gc.isenabled()
        for _ in range(5000):
            a, b = [], []
            a.append(b)
            b.append(a)
        decisions = super().decide(world, deadline)
        self.ended = time.perf_counter()
        return decisions


def test_the_garbage_collector_waits_until_the_step_is_timed():
    starts = []  # [s] perf_counter at the start of each collection
    def callback(phase, info):
        if phase == "start":
            starts.append(time.perf_counter())
    ctrl = _Cycles()
    sched = StepScheduler(ctrl, budget_ms=500.0)
    gc.callbacks.append(callback)
    try:
        _, rec = sched.step(_world())
        garbage = [[] for _ in range(3000)]  # allocations after the step: the collector runs again
        del garbage
    finally:
        gc.callbacks.remove(callback)
    timed = (ctrl.started, ctrl.ended)  # [s] while the controller decided (the scheduler's timed
    #                                     window starts before and ends after it)
    assert not ctrl.enabled and gc.isenabled() and rec.compute_ms / 1e3 >= timed[1] - timed[0]
    assert starts and not any(timed[0] <= t <= timed[1] for t in starts)  # 5000 cycles, collected after
    gc.disable()
    try:  # a collector the caller had switched off stays off
        sched.step(_world())
        assert not gc.isenabled()
    finally:
        gc.enable()


class _Solver(_Controller):
    """Sleeps, then solves solo problems until it has solved ``qps`` QPs; records the time left
    to its deadline on the budget clock."""

    def __init__(self, sleep_s=0.0, qps=0):
        super().__init__(sleep_s)
        self.qps = qps

    def decide(self, world, deadline):
        self.left = deadline - budget_clock.now()  # [s]
        start = solve_count()
        while solve_count() - start < self.qps:
            nash_equilibrium(Problem((Player(0.0, 5.0, 0.5),)))
        return super().decide(world, deadline)


def test_on_the_work_clock_the_budget_counts_qps_not_wall_time():
    # 30 ms of wall time and 3 QPs at 2 ms each: within a 10 ms budget of work
    slow = _Solver(sleep_s=0.03, qps=3)
    d, rec = StepScheduler(slow, budget_ms=10.0, work_clock_ms=2.0).step(_world())
    assert slow.left == pytest.approx(0.010) and not rec.deadline_missed and d.accel == {"V1": 1.0}
    assert rec.compute_ms >= 30.0  # compute_ms stays the wall time
    # no wall time to speak of, but 6 or more QPs (12 ms of work): over the budget, the fallback
    busy = _Solver(qps=6)
    d, rec = StepScheduler(busy, budget_ms=10.0, work_clock_ms=2.0).step(_world())
    assert rec.deadline_missed and rec.fallback and d.accel == {"V1": -2.0}
    # on the wall clock the sleeper misses the 10 ms, and the solver's QPs are only their wall time
    assert StepScheduler(_Solver(sleep_s=0.03, qps=3), budget_ms=10.0).step(_world())[1].deadline_missed
    assert not StepScheduler(_Solver(qps=6), budget_ms=200.0).step(_world())[1].deadline_missed
    assert abs(budget_clock.now() - time.perf_counter()) < 1.0  # the wall clock again after a step
