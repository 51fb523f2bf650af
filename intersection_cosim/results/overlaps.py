"""Our own collision check: which vehicle bodies overlap, independent of SUMO's collision output.

Bodies, their overlap test and the pre-selection of pairs whose bounding circles meet (sorted by
x, so the check stays near linear in the number of vehicles) are models/bodies.py's.
"""

from __future__ import annotations

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


# time [s] an overlap began, the two vehicles (sorted), their lanes, whether a controller commanded each
OVERLAP_COLUMNS = ("time", "vehicle_a", "vehicle_b", "lane_a", "lane_b", "a_commanded", "b_commanded")


@dataclass
class OverlapLog:
    """The overlap events of a run: a pair's event starts at the first check that finds the two
    bodies overlapping after a check that did not (one row of overlaps.csv each)."""

    rows: list[tuple] = field(default_factory=list)  # OVERLAP_COLUMNS
    _now: set[tuple[str, str]] = field(default_factory=set)  # the pairs overlapping at the last check

    def check(self, time: float, ids, x, y, heading, length, width, lanes, commanded,
              junctions: Mapping[str, frozenset[str]] | None = None) -> None:
        """One check at ``time`` [s] of the bodies given (as :func:`overlapping_pairs`), with each
        vehicle's lane and whether a controller commands it (``commanded`` (n,) bool). With
        ``junctions`` (lane -> the junctions its edge starts and ends at) a pair on lanes with no
        junction in common is not an overlap: the two roads cross at different levels."""
        i, j = overlapping_pairs(x, y, heading, length, width)
        now = set()
        for a, b in zip(i.tolist(), j.tolist()):
            if junctions is not None and not junctions.get(lanes[a], frozenset()) & junctions.get(lanes[b], frozenset()):
                continue
            pair = (ids[a], ids[b]) if ids[a] < ids[b] else (ids[b], ids[a])
            now.add(pair)
            if pair not in self._now:
                first, second = (a, b) if ids[a] < ids[b] else (b, a)
                self.rows.append((time, ids[first], ids[second], lanes[first], lanes[second],
                                  bool(commanded[first]), bool(commanded[second])))
        self._now = now
