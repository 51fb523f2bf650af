"""Our own collision check: which vehicle bodies overlap, independent of SUMO's collision output.

Each body is the rectangle ``length`` x ``width`` [m] behind the front-bumper position along the
heading (SUMO's position is the front bumper's middle). Two rectangles overlap unless one of their
edge normals separates them (separating axis theorem). Pairs whose bounding circles do not meet
are dropped first (sorted by x, so the check stays near linear in the number of vehicles).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def body_corners(x: np.ndarray, y: np.ndarray, heading: np.ndarray, length: np.ndarray,
                 width: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(n, 4, 2) [m] the corners of each body, (n, 2) its driving direction, (n, 2) its left
    normal; ``heading`` [rad] counter-clockwise from east, ``length`` and ``width`` [m]."""
    d = np.stack([np.cos(heading), np.sin(heading)], axis=1)
    nrm = np.stack([-d[:, 1], d[:, 0]], axis=1)
    front = np.stack([x, y], axis=1)
    rear = front - np.asarray(length, float)[:, None] * d
    half = (np.asarray(width, float)[:, None] / 2.0) * nrm
    return np.stack([front + half, front - half, rear - half, rear + half], axis=1), d, nrm


def _near_pairs(cx: np.ndarray, cy: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(i, j), i < j: the pairs whose circles (centre ``cx``, ``cy``, ``radius`` [m]) meet."""
    n = len(cx)
    if n < 2:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    order = np.argsort(cx, kind="stable")
    xs, reach = cx[order], 2.0 * float(radius.max())
    hi = np.searchsorted(xs, xs + reach, side="right")  # the first sorted index beyond reach of each
    count = hi - np.arange(n) - 1
    first = np.repeat(np.arange(n), count)
    second = first + 1 + (np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count))
    a, b = order[first], order[second]
    close = np.hypot(cx[a] - cx[b], cy[a] - cy[b]) <= radius[a] + radius[b]
    a, b = a[close], b[close]
    return np.minimum(a, b), np.maximum(a, b)


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
    i, j = _near_pairs(centre[:, 0], centre[:, 1], 0.5 * np.hypot(length, width))
    separated = np.zeros(len(i), dtype=bool)
    for axes in (d[i], nrm[i], d[j], nrm[j]):  # (m, 2) candidate separating axes
        pi = np.einsum("mkc,mc->mk", corners[i], axes)
        pj = np.einsum("mkc,mc->mk", corners[j], axes)
        separated |= (pi.max(1) < pj.min(1)) | (pj.max(1) < pi.min(1))
    keep = ~separated
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

    def check(self, time: float, ids, x, y, heading, length, width, lanes, commanded) -> None:
        """One check at ``time`` [s] of the bodies given (as :func:`overlapping_pairs`), with each
        vehicle's lane and whether a controller commands it (``commanded`` (n,) bool)."""
        i, j = overlapping_pairs(x, y, heading, length, width)
        now = set()
        for a, b in zip(i.tolist(), j.tolist()):
            pair = (ids[a], ids[b]) if ids[a] < ids[b] else (ids[b], ids[a])
            now.add(pair)
            if pair not in self._now:
                first, second = (a, b) if ids[a] < ids[b] else (b, a)
                self.rows.append((time, ids[first], ids[second], lanes[first], lanes[second],
                                  bool(commanded[first]), bool(commanded[second])))
        self._now = now
