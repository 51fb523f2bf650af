"""Deadlock detection of a closed-loop run: every vehicle in the network standing still too long.

A run whose vehicles all stand still can never clear (SUMO's teleports are off, so a gridlock
stays one), and SUMO's SSM device, which traces every pair of vehicles within its range at every
step, grows its memory with it without bound: a locked 600 s run once took 24 GB. The closed loop
therefore ends a run once every vehicle in the network has been below ``speed`` for
``deadlock_time`` seconds of simulated time; the vehicles still in the network count as not
arrived (late or stuck) and summary.json says when and how many.

A vehicle at a planned stop of the user's route file stands still too, and so do vehicles that
all wait at a red light: the default (120 s) is longer than the reds of most real signal programmes;
with longer stops set ``deadlock_time`` longer than the longest one, or 0 to never end a run early.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

STANDSTILL_SPEED = 0.1  # [m/s] below this a vehicle counts as standing still


class Deadlock(NamedTuple):
    """A detected deadlock: the run ended at ``time`` [s]; every vehicle had stood still since
    ``since`` [s]; ``vehicles`` were in the network."""

    time: float
    since: float
    vehicles: int
    reason: str = "deadlock"

    def message(self) -> str:
        return (f"t={self.time:.1f} s: every one of the {self.vehicles} vehicles in the network has stood "
                f"still since t={self.since:.1f} s: a deadlock; the run ends here (scenario.deadlock_time)")


class StandstillWatch:
    """Watches the vehicles' speeds, control step by control step, for a deadlock (module
    docstring). ``limit`` [s]: how long everyone must stand still; 0 never detects one."""

    def __init__(self, limit: float, speed: float = STANDSTILL_SPEED):
        self.limit, self.speed = float(limit), float(speed)  # [s], [m/s]
        self._since: float | None = None  # [s] since when everyone stands still

    def check(self, time: float, sim) -> Deadlock | None:
        """:meth:`update` with the speeds of every vehicle of ``sim`` (sim.sumo.SumoSimulation)."""
        return self.update(time, sim.speeds())

    def update(self, time: float, speeds) -> Deadlock | None:
        """The deadlock, if the vehicles with ``speeds`` [m/s] at ``time`` [s] have all stood
        still for ``limit``; None otherwise (also with no vehicle in the network)."""
        v = np.asarray(speeds, dtype=float)
        if self.limit <= 0.0 or v.size == 0 or float(np.abs(v).max()) >= self.speed:
            self._since = None
            return None
        if self._since is None:
            self._since = float(time)
        if time - self._since >= self.limit - 1e-9:
            return Deadlock(float(time), self._since, int(v.size))
        return None
