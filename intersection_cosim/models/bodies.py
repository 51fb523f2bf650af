"""Vehicle bodies as rectangles, and whether two of them overlap.

Each body is the rectangle ``length`` x ``width`` [m] behind the front-bumper position along the
heading (SUMO's position is the front bumper's middle). Two rectangles overlap unless one of their
edge normals separates them (the separating axis theorem). Both our collision check
(results/overlaps.py) and the safety filter's standing-obstacle rule use these.
"""

from __future__ import annotations

import numpy as np
from numba import njit


def body_corners(x: np.ndarray, y: np.ndarray, heading: np.ndarray, length: np.ndarray,
                 width: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(n, 4, 2) [m] the corners of each body, (n, 2) its driving direction, (n, 2) its left
    normal; ``heading`` [rad] counter-clockwise from east, ``length`` and ``width`` [m]."""
    heading = np.asarray(heading, float)
    d = np.stack([np.cos(heading), np.sin(heading)], axis=1)
    nrm = np.stack([-d[:, 1], d[:, 0]], axis=1)
    front = np.stack([np.asarray(x, float), np.asarray(y, float)], axis=1)
    rear = front - np.asarray(length, float)[:, None] * d
    half = (np.asarray(width, float)[:, None] / 2.0) * nrm
    return np.stack([front + half, front - half, rear - half, rear + half], axis=1), d, nrm


def bodies_overlap(a: tuple[np.ndarray, np.ndarray, np.ndarray],
                   b: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """(m,) bool: whether body ``a[k]`` overlaps body ``b[k]``; each argument is what
    :func:`body_corners` returns for m bodies (or broadcastable to them)."""
    (ca, da, na), (cb, db, nb) = a, b
    ca, cb = np.broadcast_arrays(ca, cb)
    separated = np.zeros(ca.shape[0], dtype=bool)
    for axes in (da, na, db, nb):
        axes = np.broadcast_to(axes, (ca.shape[0], 2))
        pa = np.einsum("mkc,mc->mk", ca, axes)
        pb = np.einsum("mkc,mc->mk", cb, axes)
        separated |= (pa.max(1) < pb.min(1)) | (pb.max(1) < pa.min(1))
    return ~separated


def near_pairs(cx: np.ndarray, cy: np.ndarray, radius: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def beside_occupied(x: np.ndarray, y: np.ndarray, heading: np.ndarray, length: np.ndarray, width: np.ndarray,
                    speed: np.ndarray, who: np.ndarray, shift: np.ndarray, margin: float, dt: float) -> np.ndarray:
    """(m,) bool: whether the place beside vehicle ``who[k]`` is taken, for each k.

    The place is its body moved sideways by ``shift[k]`` [m] (left of its heading positive),
    lengthened by ``margin`` [m] at both ends and forward by the distance it drives in ``dt`` [s];
    it is taken if it overlaps the body of any other vehicle, lengthened forward by the distance
    that one drives in ``dt``. A lane change moves a body sideways within one step, so this says
    whether it would land on or in front of another body (``x``, ``y`` front bumper [m],
    ``heading`` [rad], ``length``, ``width`` [m], ``speed`` [m/s], one entry per vehicle). It runs
    every SUMO step, so it is compiled: bounding circles first, the separating axes only for the
    pairs whose circles meet.
    """
    heading = np.asarray(heading, float)
    sweep = np.maximum(np.asarray(speed, float), 0.0) * dt  # [m] driven in dt
    return _beside_occupied(np.asarray(x, float), np.asarray(y, float), np.cos(heading), np.sin(heading),
                            np.asarray(length, float), np.asarray(width, float), sweep,
                            np.asarray(who, np.int64), np.asarray(shift, float), float(margin))


@njit(cache=True)
def _boxes_overlap(ax, ay, ac, as_, al, aw, bx, by, bc, bs, bl, bw):  # pragma: no cover - compiled
    """Whether two rectangles overlap (touching counts): centres (ax, ay), (bx, by) [m], headings
    by cosine and sine, half lengths ``al``, ``bl`` and half widths ``aw``, ``bw`` [m]."""
    dx, dy = bx - ax, by - ay
    for ux, uy in ((ac, as_), (-as_, ac), (bc, bs), (-bs, bc)):
        ra = al * abs(ac * ux + as_ * uy) + aw * abs(-as_ * ux + ac * uy)
        rb = bl * abs(bc * ux + bs * uy) + bw * abs(-bs * ux + bc * uy)
        if abs(dx * ux + dy * uy) > ra + rb:
            return False
    return True


@njit(cache=True)
def _beside_occupied(x, y, cos, sin, length, width, sweep, who, shift, margin):  # pragma: no cover - compiled
    n, m = x.size, who.size
    taken = np.zeros(m, np.bool_)
    # every body's centre, half length and bounding radius, lengthened forward by its sweep
    hl = 0.5 * (length + sweep)
    cx = x + sweep * cos - hl * cos
    cy = y + sweep * sin - hl * sin
    radius = np.sqrt(hl * hl + 0.25 * width * width)
    for k in range(m):
        i = who[k]
        pl = hl[i] + margin  # [m] the place's half length: the body's, swept, plus margin at both ends
        px = cx[i] - shift[k] * sin[i]
        py = cy[i] + shift[k] * cos[i]
        pr = np.sqrt(pl * pl + 0.25 * width[i] * width[i])
        for j in range(n):
            if j == i:
                continue
            dx, dy = cx[j] - px, cy[j] - py
            if dx * dx + dy * dy > (pr + radius[j]) ** 2:
                continue
            if _boxes_overlap(px, py, cos[i], sin[i], pl, 0.5 * width[i],
                              cx[j], cy[j], cos[j], sin[j], hl[j], 0.5 * width[j]):
                taken[k] = True
                break
    return taken
