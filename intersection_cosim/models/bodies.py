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
