"""Vehicle bodies as rectangles, and whether two of them overlap.

Each body is the rectangle ``length`` x ``width`` [m] behind the front-bumper position along the
heading (SUMO's position is the front bumper's middle). Two rectangles overlap unless one of their
edge normals separates them (the separating axis theorem). Both our collision check
(results/overlaps.py) and the safety filter's standing-obstacle rule use these.
"""

from __future__ import annotations

import numpy as np


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
    ``heading`` [rad], ``length``, ``width`` [m], ``speed`` [m/s], one entry per vehicle).
    """
    x, y, heading = (np.asarray(v, float) for v in (x, y, heading))
    length, width = np.asarray(length, float), np.asarray(width, float)
    who, shift = np.asarray(who, np.intp), np.asarray(shift, float)
    n, m = len(x), len(who)
    if m == 0 or n < 2:
        return np.zeros(m, dtype=bool)
    sweep = np.maximum(np.asarray(speed, float), 0.0) * dt  # [m] driven in dt
    cos, sin = np.cos(heading), np.sin(heading)
    fx = np.concatenate([x + sweep * cos, x[who] + (sweep[who] + margin) * cos[who] - shift * sin[who]])
    fy = np.concatenate([y + sweep * sin, y[who] + (sweep[who] + margin) * sin[who] + shift * cos[who]])
    ln = np.concatenate([length + sweep, length[who] + sweep[who] + 2.0 * margin])
    wd = np.concatenate([width, width[who]])
    hd = np.concatenate([heading, heading[who]])
    corners, d, nrm = body_corners(fx, fy, hd, ln, wd)
    centre = corners.mean(axis=1)
    i, j = near_pairs(centre[:, 0], centre[:, 1], 0.5 * np.hypot(ln, wd))
    cross = (i < n) & (j >= n)  # a vehicle's body (i) against a place beside (j); i < j always
    i, j = i[cross], j[cross]
    i, j = i[i != who[j - n]], j[i != who[j - n]]  # not against its own body
    hit = bodies_overlap((corners[i], d[i], nrm[i]), (corners[j], d[j], nrm[j]))
    taken = np.zeros(m, dtype=bool)
    taken[j[hit] - n] = True
    return taken
