"""The deadline-monitored step scheduler: the timing budget of a hardware-in-the-loop box.

Each control step it hands the World to the controller with a deadline, measures the time the
controller takes, and, when the controller raises or overruns its budget, applies the
controller's safe fallback instead and records that it did. ``realtime`` paces the simulation to
the wall clock, as the HIL box runs. The budget is kept by the wall clock, or with
``work_clock_ms`` > 0 by the work clock of an emulated box that spends that many ms per QP solve
(:mod:`intersection_cosim.games.budget_clock`): then what a tight budget defers, and the whole
run, does not depend on the machine or its load.

Python's cyclic garbage collector is paused while the controller decides: a full collection
scans every tracked object of the process (in a 300 s run at 1800 veh/h, 45 000 at the first of
its three full collections, 100 000 at the last) and took 45-75 ms, each time a missed 20 ms
budget. The collections happen between the steps instead, outside the timed window.
"""

from __future__ import annotations

import gc
import logging
import time
from contextlib import contextmanager
from dataclasses import dataclass

from intersection_cosim.control.base import Controller, Decisions, World
from intersection_cosim.games import budget_clock

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class StepRecord:
    """One row of steps.csv."""

    time: float  # [s] simulation time of the control step
    compute_ms: float  # [ms] wall time the controller took
    games: int  # games played
    iterations: int  # equilibrium iterations, summed over games
    deadline_missed: bool  # the step exceeded the budget (compute_ms, or on the work clock its QPs' cost)
    fallback: bool  # the applied decisions are the fallback
    deferred: int = 0  # games / solo solves the controller left out to meet the budget
    qp_solves: int = 0  # QPs decide solved (its work; kept when the fallback replaces its decisions)
    junction: str = ""  # the managed junction whose controller this is (sim.network_scheduler)
    skipped: bool = False  # the junction had nothing to decide: its controller was not called

    def row(self) -> tuple:
        """The record as a steps.csv row (STEP_COLUMNS' order), without dataclasses.astuple's
        deep copy: one record per junction and step is written (208 junctions in a city)."""
        return tuple(self.__dict__.values())


@contextmanager
def collector_paused():
    """Python's cyclic garbage collector off for the block, then as it was before."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


class StepScheduler:
    def __init__(self, controller: Controller, budget_ms: float, realtime: bool = False,
                 work_clock_ms: float = 0.0):
        self.controller = controller
        self.budget_s = budget_ms / 1000.0  # [s]
        self.qp_s = work_clock_ms / 1000.0 or None  # [s] per QP solve on the work clock; None: wall
        self.realtime = realtime
        self._wall_start: float | None = None

    def step(self, world: World) -> tuple[Decisions, StepRecord]:
        failed = False
        with collector_paused(), budget_clock.work_clock(self.qp_s):
            # until the wall time is taken: a collection then is not the step's
            wall_start, start = time.perf_counter(), budget_clock.now()
            try:
                decisions = self.controller.decide(world, start + self.budget_s)
            except Exception as exc:  # a controller bug or solver crash must not stop the run
                log.warning("t=%.2f s: controller raised %s: %s; applying the fallback", world.time,
                            type(exc).__name__, exc)
                decisions, failed = None, True
            elapsed, used = time.perf_counter() - wall_start, budget_clock.now() - start  # [s]
        missed = used > self.budget_s + 1e-12  # [s] round-off of the work clock's sums
        if failed or missed:
            if missed:
                log.warning("t=%.2f s: controller took %.1f ms%s, budget %.1f ms; applying the fallback",
                            world.time, used * 1e3, "" if self.qp_s is None else " of work", self.budget_s * 1e3)
            played = decisions
            decisions = self.controller.fallback(world)
            decisions.fallback = True
            if played is not None:
                # decide has already forgotten the vehicles it released: hand them back to SUMO
                # all the same, or they would keep their last command with SUMO's checks off
                decisions.release = sorted(set(decisions.release) | set(played.release))
                decisions.games, decisions.iterations = played.games, played.iterations
                decisions.deferred = played.deferred
                decisions.qp_solves += played.qp_solves
                decisions.pairs = played.pairs
        record = StepRecord(time=world.time, compute_ms=elapsed * 1e3, games=decisions.games,
                            iterations=decisions.iterations, deadline_missed=missed,
                            fallback=decisions.fallback, deferred=decisions.deferred,
                            qp_solves=decisions.qp_solves)
        return decisions, record

    def pace(self, sim_time: float) -> None:
        """With ``realtime``, sleep until the wall clock has caught up with ``sim_time`` [s]."""
        if not self.realtime:
            return
        now = time.perf_counter()
        if self._wall_start is None:
            self._wall_start = now - sim_time
        ahead = sim_time - (now - self._wall_start)
        if ahead > 0:
            time.sleep(ahead)
