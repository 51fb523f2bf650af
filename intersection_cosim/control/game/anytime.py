"""The anytime schedule of a control step: will the next game or solo solve finish in time?

Games are played most urgent first, then solo vehicles nearest their stop line. Before each
solve the controller asks whether its estimated wall time, with room for a slow one, still fits
before the step's cutoff (the deadline less a reserve for the safety filter); work that does not
fit is deferred and its vehicles keep their last plan, shifted. The estimates of games are running
means of the measured solve times per exit-lane combination, one for combinations with a warm
start and one for those without; the solo vehicles are solved in one batch
(games.solo_batch), whose time is a fixed part (one pass of array work) plus a part per problem,
estimated by a running least-squares fit of the measured batches. The reserve kept for the safety
filter is a share of the time left, but never less than the slow case of the filter's own
running mean time (on a large net the filter alone can take more than the share).
"""

from __future__ import annotations

from intersection_cosim.games import budget_clock

SLOW_SOLVE_FACTOR = 2.0  # [-] a solve is started only if twice its estimated time still fits
DEFER_DECAY = 0.95  # [-] a deferral shrinks the estimate, so one slow solve cannot defer all later work
SMOOTHING = 0.2  # [-] weight of the newest measurement in the running mean
GAME_COLD_S = 0.004  # [s] first estimate of one exit-lane combination of a game without warm start
GAME_WARM_S = 0.002  # [s] ... with a warm start
SOLO_S = 0.001  # [s] first estimate of one solo solve in a batch
SOLO_FIXED_S = 0.0005  # [s] first estimate of a solo batch's fixed part
FILTER_S = 0.001  # [s] first estimate of the safety filter's time


class SolveTimeEstimate:
    """Running mean wall time of one kind of solve [s]."""

    def __init__(self, initial: float):
        self.seconds = initial

    def deferred(self) -> None:
        self.seconds *= DEFER_DECAY

    def measured(self, seconds: float) -> None:
        """Fold in one measured solve of ``seconds`` [s]."""
        self.seconds = (1.0 - SMOOTHING) * self.seconds + SMOOTHING * seconds


class BatchTimeEstimate:
    """Wall time of a batch of ``units`` solves [s] as ``fixed + per_unit * units``, fitted by
    least squares over the measured batches, each older batch weighing (1 - SMOOTHING) times
    less. A running mean per solve would be set by the many small batches, whose fixed part it
    spreads over few solves, and overestimate the large ones."""

    def __init__(self, fixed: float, per_unit: float):
        self.fixed, self.per_unit = fixed, per_unit  # [s], [s]
        self._moments = [0.0] * 5  # weighted sums of 1, u, t, u^2, u t

    def seconds(self, units: int) -> float:
        """[s] estimated wall time of ``units`` solves in one batch."""
        return self.fixed + self.per_unit * units

    def fits(self, units: int, cutoff: float) -> bool:
        """Whether a batch of ``units``, at ``SLOW_SOLVE_FACTOR`` times its estimate, ends before
        ``cutoff`` (a :func:`budget_clock.now` value)."""
        return budget_clock.now() + SLOW_SOLVE_FACTOR * self.seconds(units) <= cutoff

    def deferred(self) -> None:
        """A deferral shrinks the estimate (DEFER_DECAY), as SolveTimeEstimate's."""
        self.fixed *= DEFER_DECAY
        self.per_unit *= DEFER_DECAY
        self._moments[2] *= DEFER_DECAY
        self._moments[4] *= DEFER_DECAY

    def measured(self, units: int, seconds: float) -> None:
        """Fold in one batch of ``units`` solves that took ``seconds`` [s]."""
        keep = 1.0 - SMOOTHING
        new = (1.0, float(units), seconds, float(units) ** 2, units * seconds)
        self._moments = [keep * m + x for m, x in zip(self._moments, new)]
        w, su, st, suu, sut = self._moments
        mu, mt = su / w, st / w
        var = suu / w - mu * mu
        slope = (sut / w - mu * mt) / var if var > 1e-9 * max(mu * mu, 1.0) else (mt - self.fixed) / max(mu, 1.0)
        self.per_unit = max(slope, 0.0)
        self.fixed = mt - self.per_unit * mu
        if self.fixed < 0.0:  # no fixed part the data can show: all of it per solve
            self.fixed, self.per_unit = 0.0, mt / max(mu, 1.0)


class GameTimeEstimate:
    """Wall time of one pair's game [s]: each exit-lane combination solved from a warm start costs
    the warm estimate, each without one (a cold start from the decoupled plans; for Stackelberg a
    Nash solve first) the cold estimate. A lane choice often mixes the two (the combination the
    pair drives is warm, the other cold) and costs 3-4 times a warm game, not twice."""

    def __init__(self, cold: float, warm: float):
        self.cold, self.warm = SolveTimeEstimate(cold), SolveTimeEstimate(warm)

    def seconds(self, n_warm: int, n_cold: int) -> float:
        """[s] estimated time of a game with ``n_warm`` warm and ``n_cold`` cold combinations."""
        return n_warm * self.warm.seconds + n_cold * self.cold.seconds

    def fits(self, n_warm: int, n_cold: int, cutoff: float) -> bool:
        """Whether the game, at ``SLOW_SOLVE_FACTOR`` times its estimate, ends before ``cutoff``."""
        return budget_clock.now() + SLOW_SOLVE_FACTOR * self.seconds(n_warm, n_cold) <= cutoff

    def deferred(self, n_warm: int, n_cold: int) -> None:
        for n, est in ((n_warm, self.warm), (n_cold, self.cold)):
            if n:
                est.deferred()

    def measured(self, n_warm: int, n_cold: int, seconds: float) -> None:
        """Fold in a game of ``seconds`` [s]: a game of one kind updates that kind's mean per
        combination; a mixed one updates the cold mean with what is left after the warm
        combinations' estimate (at least the warm estimate: a cold start is never cheaper)."""
        if not n_cold:
            self.warm.measured(seconds / n_warm)
        elif not n_warm:
            self.cold.measured(seconds / n_cold)
        else:
            self.cold.measured(max((seconds - n_warm * self.warm.seconds) / n_cold, self.warm.seconds))


class AnytimeSchedule:
    """The estimates of a controller: games (cold and warm), the solo batch and the safety filter."""

    def __init__(self):
        self.game = GameTimeEstimate(GAME_COLD_S, GAME_WARM_S)
        self.solo = BatchTimeEstimate(SOLO_FIXED_S, SOLO_S)
        self.filter = SolveTimeEstimate(FILTER_S)


def step_cutoff(deadline: float, reserve: float, filter_seconds: float = 0.0) -> float:
    """The :func:`budget_clock.now` value after which no new solve starts: ``deadline`` less what is
    kept for the safety filter, the share ``reserve`` [-] of the time left or, if larger,
    ``SLOW_SOLVE_FACTOR`` times the filter's estimated time ``filter_seconds`` [s]."""
    start = budget_clock.now()
    return deadline - max(reserve * max(deadline - start, 0.0), SLOW_SOLVE_FACTOR * filter_seconds)
