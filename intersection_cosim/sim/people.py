"""The persons at a managed junction's pedestrian crossings, as the controller sees them."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import ModuleType
from typing import Mapping

from intersection_cosim.control.base import Walker
from intersection_cosim.network.crossings import PedestrianCrossing


@dataclass
class CrossingPeople:
    """Reads the persons on or walking onto ``crossings`` (by lane id) through ``api`` (libsumo's)."""

    api: ModuleType
    crossings: Mapping[str, PedestrianCrossing]
    _walking_areas: dict[str, list[PedestrianCrossing]] = field(default_factory=dict)  # lane -> crossings at it
    _impatient_types: set[str] = field(default_factory=set)  # person vTypes set to impatience 1

    def __post_init__(self) -> None:
        for crossing in self.crossings.values():
            for area in crossing.walking_areas:
                self._walking_areas.setdefault(area, []).append(crossing)

    def people_first(self) -> None:
        """Impatience 1 for the vType of each person that departed this step (set on its type:
        libsumo's person.setImpatience addresses vehicles), once per type."""
        for pid in self.api.simulation.getDepartedPersonIDList():
            vtype = self.api.person.getTypeID(pid)
            if vtype not in self._impatient_types:
                self.api.vehicletype.setImpatience(vtype, 1.0)
                self._impatient_types.add(vtype)

    def walkers(self) -> tuple[Walker, ...]:
        """The persons on a managed junction's crossing, and those on a walking area at one with
        that crossing as their next edge, walking or waiting at the kerb (SUMO's person steps out
        when its own gap model, blind to the controller's plans, says so); () without
        crossings. A person's axis position is its position projected onto the crossing's axis
        (in the axis' own metres, as the paths' crossing stretches are, whatever SUMO's length of
        the crossing lane), so on a walking area it lies before the axis' start or past its end."""
        if not self.crossings:
            return ()
        person, out = self.api.person, []
        for pid in person.getIDList():
            lane = person.getLaneID(pid)
            crossing = self.crossings.get(lane)
            if crossing is not None:
                angle = math.radians(person.getAngle(pid))  # navigational: 0 north, clockwise
                d = crossing.direction
                sign = 1 if math.sin(angle) * d[0] + math.cos(angle) * d[1] >= 0.0 else -1
                x, y = person.getPosition(pid)
                out.append(Walker(pid, lane, crossing.along(x, y), sign, person.getSpeed(pid), x, y))
                continue
            near = self._walking_areas.get(lane)
            if not near:
                continue
            nxt = person.getNextEdge(pid)
            for crossing in near:
                if crossing.edge == nxt:
                    x, y = person.getPosition(pid)
                    pos = crossing.along(x, y)
                    sign = 1 if pos < crossing.length / 2 else -1
                    out.append(Walker(pid, crossing.lane, pos, sign, person.getSpeed(pid), x, y))
        return tuple(out)
