"""The working state of one filter step and the step's frozen result.

Rules write into a :class:`FilterStep`: caps on accelerations (each under the rule's name, so the
step knows which rule bound), vehicles that must drive out of a crossing, the entry times ranks are
read by, the braking each vehicle is counted on for, and the events the controller reads at the
next step. It never leaves :meth:`~intersection_cosim.control.safety.filter.SafetyFilter.apply`,
which turns it into a :class:`SafetyResult`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

from intersection_cosim.games.problem import Plan


@dataclass(frozen=True)
class Wait:
    """A vehicle made to stay out of a crossing for another (``box_clear`` reads these)."""

    waiting: int  # World index of the vehicle that waits
    other: int  # World index of the vehicle it waits for
    other_enter: float  # [m] where the other's crossing zone starts on its own path


@dataclass
class FilterStep:
    """What the rules of one step have decided so far."""

    plans: dict[str, Plan]  # the plans the crossing rules check (braked and clearing ones replaced)
    brakes: dict[str, float]  # [m/s^2] (< 0) the hardest braking counted on per vehicle (a_min if absent)
    queue: dict[str, float]  # [s] the entry times the vehicles in the junction rank by
    caps: dict[str, dict[str, float]] = field(default_factory=dict)  # vehicle -> rule -> [m/s^2] cap
    clear: dict[str, str] = field(default_factory=dict)  # vehicle -> the rule that makes it drive out
    waits: list[Wait] = field(default_factory=list)  # who stays out for whom, this look
    events: set[tuple[str, str]] = field(default_factory=set)  # sorted AV pairs whose crossing was guarded
    stall_held: set[str] = field(default_factory=set)  # vehicles held at their stop lines for a stalled box
    pedestrian_holds: int = 0  # [-] vehicles held back for a pedestrian this step

    def lower(self, vid: str, accel: float, rule: str) -> None:
        """Cap vehicle ``vid``'s acceleration at ``accel`` [m/s^2] by ``rule`` (the lowest cap of a
        rule holds)."""
        mine = self.caps.setdefault(vid, {})
        mine[rule] = min(mine.get(rule, math.inf), accel)

    def cap(self, vid: str) -> float:
        """[m/s^2] the lowest cap on ``vid`` so far (inf: none)."""
        return min(self.caps.get(vid, {}).values(), default=math.inf)

    def binding(self, vid: str) -> str:
        """The rule whose cap on ``vid`` is the lowest (the first such rule on a tie)."""
        mine = self.caps[vid]
        return min(mine, key=mine.get)

    def drive_out(self, vid: str, rule: str) -> None:
        """``vid`` drives out of the crossing it stands in (at least ``clear_accel``), by ``rule``."""
        self.clear.setdefault(vid, rule)


@dataclass(frozen=True)
class SafetyResult:
    """What the filter decided in one step."""

    accel: Mapping[str, float]  # [m/s^2] every decided vehicle's acceleration after the rules
    lowered: Mapping[str, str]  # vehicle -> the rule whose cap lowered its acceleration
    raised: Mapping[str, str]  # vehicle -> the rule that raised it (to drive out of a crossing)
    held: frozenset[str]  # vehicles held back at a crossing or by a hold (not only behind a leader)
    events: frozenset[tuple[str, str]]  # sorted pairs of AVs whose crossing a rule had to guard
    stall_held: frozenset[str]  # vehicles held at their stop lines for a stalled box
    pedestrian_holds: int  # [-] vehicles held back for a pedestrian
    guest_caps: Mapping[str, float]  # [m/s^2] caps on guests (World.guest), for their owners to obey
