"""The anytime schedule of a control step: will the next game or solo solve finish in time?

Games are played most urgent first, then solo vehicles nearest their stop line. Before each
solve the controller asks whether its estimated wall time, with room for a slow one, still fits
before the step's cutoff (the deadline less a reserve for the safety filter); work that does not
fit is deferred and its vehicles keep their last plan, shifted. The estimates are running means
of the measured solve times.
"""

from __future__ import annotations

import time

SLOW_SOLVE_FACTOR = 2.0  # [-] a solve is started only if twice its estimated time still fits
DEFER_DECAY = 0.95  # [-] a deferral shrinks the estimate, so one slow solve cannot defer all later work
SMOOTHING = 0.2  # [-] weight of the newest measurement in the running mean
GAME_COLD_S = 0.004  # [s] first estimate of one exit-lane combination of a game without warm start
GAME_WARM_S = 0.002  # [s] ... with a warm start
SOLO_S = 0.001  # [s] first estimate of one solo solve


class SolveTimeEstimate:
    """Running mean wall time of one kind of solve [s]."""

    def __init__(self, initial: float):
        self.seconds = initial

    def fits(self, units: int, cutoff: float) -> bool:
        """Whether ``units`` solves of this kind, at ``SLOW_SOLVE_FACTOR`` times the estimate,
        end before ``cutoff`` (a ``time.perf_counter`` value)."""
        return time.perf_counter() + SLOW_SOLVE_FACTOR * units * self.seconds <= cutoff

    def deferred(self) -> None:
        self.seconds *= DEFER_DECAY

    def measured(self, seconds: float) -> None:
        """Fold in one measured solve of ``seconds`` [s]."""
        self.seconds = (1.0 - SMOOTHING) * self.seconds + SMOOTHING * seconds


class AnytimeSchedule:
    """The estimates of a controller: games (cold and warm) and solo solves."""

    def __init__(self):
        self.game = {False: SolveTimeEstimate(GAME_COLD_S), True: SolveTimeEstimate(GAME_WARM_S)}
        self.solo = SolveTimeEstimate(SOLO_S)


def step_cutoff(deadline: float, reserve: float) -> float:
    """The ``time.perf_counter`` value after which no new solve starts: ``deadline`` less the
    share ``reserve`` [-] of the time left, kept for the safety filter."""
    start = time.perf_counter()
    return deadline - reserve * max(deadline - start, 0.0)
