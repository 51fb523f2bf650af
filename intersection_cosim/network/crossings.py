"""Pedestrian crossings of the managed junctions, and where each movement path runs over them.

SUMO models a zebra crossing as a junction-internal edge of function ``crossing`` (one lane,
``:J_c0_0``) between two walking areas (``:J_w0``). Its lane's shape is the crossing's axis, from
one kerb to the other, and its width the crossing's. A vehicle on a movement path runs over a
crossing where its body overlaps the crossing's area: the crossing over its approach road just
after the stop line, the one over its exit road just before it leaves the junction.

:func:`junction_crossings` reads the crossings of a net's junctions (sumolib), :func:`path_junctions`
names the junctions whose crossings matter (the managed ones and those the approaches pass);
:func:`crossing_zones` maps them onto the movement paths: per path, the front arc lengths over
which the body overlaps each crossing (the zone the safety filter keeps a vehicle out of while a
pedestrian is in its way) and the stretch of the crossing's axis that the vehicle's body covers.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np
import sumolib
from scipy.spatial import cKDTree

from intersection_cosim.network.conflict_zones import area_zone
from intersection_cosim.network.movements import Movements
from intersection_cosim.network.paths import MovementPath

AREA_STEP = 0.25  # [m] spacing of the grid of points over a crossing's area


@dataclass(frozen=True)
class PedestrianCrossing:
    """One crossing: its lane, its axis and width, and the walking areas at its two ends."""

    lane: str  # SUMO lane id of the crossing, e.g. ":38_c0_0"
    edge: str  # its edge id, e.g. ":38_c0" (what a person's next edge names)
    junction: str  # the junction it belongs to
    start: tuple[float, float]  # [m] net frame: the axis' first point (lane position 0)
    end: tuple[float, float]  # [m] the axis' last point (lane position = length)
    width: float  # [m]
    walking_areas: tuple[str, ...]  # SUMO lane ids of the walking areas at its ends

    @property
    def length(self) -> float:
        """[m] along the axis."""
        return math.dist(self.start, self.end)

    @property
    def direction(self) -> tuple[float, float]:
        """Unit vector along the axis, start to end."""
        n = max(self.length, 1e-9)
        return ((self.end[0] - self.start[0]) / n, (self.end[1] - self.start[1]) / n)

    def along(self, x: float, y: float) -> float:
        """[m] the axis coordinate (lane position) of the point (x, y) [m]."""
        d = self.direction
        return (x - self.start[0]) * d[0] + (y - self.start[1]) * d[1]


@dataclass(frozen=True)
class CrossingZone:
    """Where a movement path runs over one crossing."""

    lane: str  # the crossing's lane id
    zone_in: float  # [m] front arc length on the path where the body starts to overlap the crossing
    zone_out: float  # [m] ... where it stops (the rear has left it)
    span: tuple[float, float]  # [m] the stretch of the crossing's axis the body covers meanwhile


def junction_crossings(net_file: str, junctions: tuple[str, ...]) -> dict[str, PedestrianCrossing]:
    """The crossings of ``junctions`` of ``net_file``, by lane id (none in a net without
    pedestrian crossings)."""
    return dict(_crossings(str(net_file), tuple(junctions)))


def _crossings(net_file: str, junctions: tuple[str, ...]) -> tuple[tuple[str, PedestrianCrossing], ...]:
    """The crossings of ``junctions``, in the net's edge order (a filter of :func:`_net_crossings`)."""
    wanted = set(junctions)
    return tuple((lane, c) for lane, c in _net_crossings(net_file) if c.junction in wanted)


@functools.lru_cache(maxsize=4)
def _net_crossings(net_file: str) -> tuple[tuple[str, PedestrianCrossing], ...]:
    """Every crossing of ``net_file`` by lane id, in the net's edge order: the net is read once
    per file, not once per junction (a city of 208 managed junctions read it 208 times)."""
    net = sumolib.net.readNet(net_file, withInternal=True, withPedestrianConnections=True)
    out = []
    for edge in net.getEdges(withInternal=True):
        if edge.getFunction() != "crossing":
            continue
        junction = edge.getID()[1:].rsplit("_", 1)[0]
        lane = edge.getLanes()[0]
        shape = lane.getShape()
        areas = sorted({e.getLanes()[0].getID() for e in (*edge.getIncoming(), *edge.getOutgoing())
                        if e.getFunction() == "walkingarea"})
        out.append((lane.getID(), PedestrianCrossing(lane.getID(), edge.getID(), junction, tuple(shape[0]),
                                                     tuple(shape[-1]), float(lane.getWidth()), tuple(areas))))
    return tuple(out)


def crossing_area(crossing: PedestrianCrossing) -> cKDTree:
    """KD-tree of a grid of points ``AREA_STEP`` apart over the crossing's rectangle (its axis,
    its width)."""
    d = np.array(crossing.direction)
    normal = np.array([-d[1], d[0]])
    u = np.linspace(0.0, crossing.length, max(2, int(np.ceil(crossing.length / AREA_STEP)) + 1))
    w = np.linspace(-crossing.width / 2, crossing.width / 2, max(2, int(np.ceil(crossing.width / AREA_STEP)) + 1))
    uu, ww = np.meshgrid(u, w, indexing="ij")
    pts = np.array(crossing.start) + uu.ravel()[:, None] * d + ww.ravel()[:, None] * normal
    return cKDTree(pts)


def path_crossing_zone(path: MovementPath, crossing: PedestrianCrossing, length: float, width: float,
                       area: cKDTree | None = None) -> CrossingZone | None:
    """Where a body ``length`` x ``width`` [m] on ``path`` overlaps ``crossing`` (its body
    outline within a grid step of the crossing's area), or None where it never does."""
    middle = (np.array(crossing.start) + np.array(crossing.end)) / 2
    reach = math.hypot(crossing.length, crossing.width) / 2 + length + width  # [m] farthest a touching front can be
    near = path.s[np.hypot(*(path.xy - middle).T) <= reach]
    if not len(near):
        return None
    zone = area_zone(path, area if area is not None else crossing_area(crossing), length, width,
                     (float(near.min()) - 1.0, float(near.max()) + 1.0))
    if zone is None:
        return None
    s = np.linspace(max(zone[0] - length, 0.0), zone[1], 50)  # [m] the body's stretch of centre line
    xy = path.point_at(s)
    d = np.array(crossing.direction)
    along = (xy - np.array(crossing.start)) @ d  # [m] on the crossing's axis
    lo, hi = float(along.min()) - width / 2, float(along.max()) + width / 2
    return CrossingZone(crossing.lane, zone[0], zone[1], (lo, hi))


def path_junctions(movements: Movements) -> tuple[str, ...]:
    """The junctions the movement paths run through: the managed ones and those upstream on the
    approaches within the control range (their internal lanes are on the paths)."""
    inside = {lane[1:].rsplit("_", 2)[0] for path in movements.paths.values() for lane in path.lanes
              if lane.startswith(":")}
    return tuple(sorted(inside | set(movements.junctions)))


def movement_crossings(movements: Movements) -> dict[str, PedestrianCrossing]:
    """The crossings that the movement paths may run over (of :func:`path_junctions`), by lane id."""
    return junction_crossings(movements.net_file, path_junctions(movements))


def crossing_zones(movements: Movements, crossings: Mapping[str, PedestrianCrossing], length: float,
                   width: float) -> dict[str, tuple[CrossingZone, ...]]:
    """Per movement path id, the crossings it runs over (in path order; only paths that run over
    one), for a body ``length`` x ``width`` [m]: those of its managed junction and of any junction
    its approach passes on the way."""
    areas = {lane: crossing_area(c) for lane, c in crossings.items()}
    out = {}
    for pid, path in movements.paths.items():
        junctions = {lane[1:].rsplit("_", 2)[0] for lane in path.lanes if lane.startswith(":")} | {path.junction}
        zones = [z for lane, c in crossings.items()
                 if c.junction in junctions and (z := path_crossing_zone(path, c, length, width, areas[lane]))]
        if zones:
            out[pid] = tuple(sorted(zones, key=lambda z: z.zone_in))
    return out
