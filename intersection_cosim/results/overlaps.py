"""Our own collision check: which vehicle bodies overlap, independent of SUMO's collision output.

Bodies, their overlap test and the pre-selection of pairs whose bounding circles meet (sorted by
x, so the check stays near linear in the number of vehicles) are models/bodies.py's. A body
longer than ``PIECE`` (a bus, a truck with its trailer) is checked as a chain of rectangles along
the path its front drove, as SUMO places a vehicle along its lanes: one rigid rectangle at the
front's heading would swing its rear out across the next lane in every turn.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from intersection_cosim.models.bodies import bodies_overlap, body_corners, near_pairs


def overlapping_pairs(x: np.ndarray, y: np.ndarray, heading: np.ndarray, length: np.ndarray,
                      width: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(i, j), i < j: the indices of every pair of overlapping bodies (front-bumper positions
    ``x``, ``y`` [m], ``heading`` [rad], ``length``, ``width`` [m], one entry per vehicle)."""
    x, y, heading = (np.asarray(v, float) for v in (x, y, heading))
    length, width = np.asarray(length, float), np.asarray(width, float)
    if len(x) < 2:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    corners, d, nrm = body_corners(x, y, heading, length, width)
    centre = corners.mean(axis=1)
    i, j = near_pairs(centre[:, 0], centre[:, 1], 0.5 * np.hypot(length, width))
    keep = bodies_overlap((corners[i], d[i], nrm[i]), (corners[j], d[j], nrm[j]))
    order = np.lexsort((j[keep], i[keep]))
    return i[keep][order], j[keep][order]


PIECE = 6.0  # [m] a body longer than this is checked in pieces of at most this length along its path


def _point_behind(trail: list[tuple[float, float]], back: float, heading: float) -> tuple[float, float]:
    """[m] the point ``back`` [m] behind the front along ``trail`` (the front's past positions,
    newest last; straight on back along the oldest stretch, or ``heading`` [rad], beyond it)."""
    x, y = trail[-1]
    dx, dy = -math.cos(heading), -math.sin(heading)
    for px, py in reversed(trail[:-1]):
        step = math.hypot(px - x, py - y)
        if step < 1e-9:
            continue
        dx, dy = (px - x) / step, (py - y) / step
        if step >= back:
            return x + dx * back, y + dy * back
        back -= step
        x, y = px, py
    return x + dx * back, y + dy * back


def body_pieces(trails: dict, ids, x, y, heading, length, width):
    """The rectangles to check, (owner index, x, y, heading, length, width) arrays: one per body of
    at most PIECE, else ceil(length / PIECE) pieces along its trail (``trails``: vehicle ->
    past front positions, newest last)."""
    if not trails:  # no long body: each vehicle is one rectangle
        return np.arange(len(ids), dtype=np.intp), x, y, heading, length, width
    rows = []
    for i, vid in enumerate(ids):
        if length[i] <= PIECE or vid not in trails:
            rows.append((i, x[i], y[i], heading[i], length[i], width[i]))
            continue
        k = math.ceil(length[i] / PIECE)
        points = [_point_behind(trails[vid], length[i] * j / k, heading[i]) for j in range(k + 1)]
        for (fx, fy), (rx, ry) in zip(points[:-1], points[1:]):
            rows.append((i, fx, fy, math.atan2(fy - ry, fx - rx), length[i] / k, width[i]))
    owner, *rest = (np.array(c) for c in zip(*rows)) if rows else [np.zeros(0)] * 6
    return owner.astype(np.intp), *rest


# time [s] an overlap began, the two vehicles (sorted), their lanes, whether a controller commanded each
OVERLAP_COLUMNS = ("time", "vehicle_a", "vehicle_b", "lane_a", "lane_b", "a_commanded", "b_commanded")


@dataclass
class OverlapLog:
    """The overlap events of a run: a pair's event starts at the first check that finds the two
    bodies overlapping after a check that did not (one row of overlaps.csv each)."""

    rows: list[tuple] = field(default_factory=list)  # OVERLAP_COLUMNS
    _now: set[tuple[str, str]] = field(default_factory=set)  # the pairs overlapping at the last check
    _trails: dict = field(default_factory=dict)  # long vehicle -> its front's past positions [m], newest last

    def _follow(self, ids, x, y, length) -> None:
        """Extend the trails of the long bodies by this check's front positions (each kept to
        its body's length and a piece more); drop those of vehicles not seen now."""
        trails = {}
        for i, vid in enumerate(ids):
            if length[i] <= PIECE:
                continue
            trail = self._trails.get(vid, [])
            if not trail or math.hypot(x[i] - trail[-1][0], y[i] - trail[-1][1]) > 0.05:
                trail = trail + [(float(x[i]), float(y[i]))]
            run, keep = 0.0, len(trail) - 1
            while keep > 0 and run < length[i] + PIECE:
                run += math.hypot(trail[keep][0] - trail[keep - 1][0], trail[keep][1] - trail[keep - 1][1])
                keep -= 1
            trails[vid] = trail[keep:]
        self._trails = trails

    def check(self, time: float, ids, x, y, heading, length, width, lanes, commanded,
              junctions: Mapping[str, frozenset[str]] | None = None) -> None:
        """One check at ``time`` [s] of the bodies given (as :func:`overlapping_pairs`), with each
        vehicle's lane and whether a controller commands it (``commanded`` (n,) bool). With
        ``junctions`` (lane -> the junctions its edge starts and ends at) a pair on lanes with no
        junction in common is not an overlap: the two roads cross at different levels."""
        self._follow(ids, x, y, length)
        owner, px, py, ph, pl, pw = body_pieces(self._trails, ids, x, y, heading, length, width)
        pi, pj = overlapping_pairs(px, py, ph, pl, pw)
        pairs = {(min(a, b), max(a, b)) for a, b in zip(owner[pi].tolist(), owner[pj].tolist()) if a != b}
        now = set()
        for a, b in sorted(pairs):
            if junctions is not None and not junctions.get(lanes[a], frozenset()) & junctions.get(lanes[b], frozenset()):
                continue
            pair = (ids[a], ids[b]) if ids[a] < ids[b] else (ids[b], ids[a])
            now.add(pair)
            if pair not in self._now:
                first, second = (a, b) if ids[a] < ids[b] else (b, a)
                self.rows.append((time, ids[first], ids[second], lanes[first], lanes[second],
                                  bool(commanded[first]), bool(commanded[second])))
        self._now = now
