"""The stretch of a path over which two bodies meet (paper Section II's conflict points given a
size): the area the bodies on a path sweep through the junction (:func:`swept_area`) and the front
arc lengths ``[zone_in, zone_out]`` over which a body on another path overlaps it
(:func:`conflict_zone`, found coarse to fine by :func:`coarse_zone`; against any area such as a
zebra crossing by :func:`area_zone`). network/conflicts.py holds the points and the table.

Bodies are rigid rectangles headed as SUMO heads them. Pure geometry on
:class:`~intersection_cosim.network.paths.MovementPath`.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from intersection_cosim.network.paths import MovementPath

_ZONE_STEP = 0.25  # [m] spacing of the front positions and body-outline samples of conflict_zone
_ZONE_MARGIN = 0.2  # [m] an outline point this close to a swept-area grid point overlaps it
ZONE_MERGE = 0.05  # [m] swept-area points of other bodies than a table's own are merged on this grid
# [m] how far past the true first touch a zone may start: its fronts are sampled _ZONE_STEP apart,
# and the first sample that overlaps may lie up to one step past the touch (a vehicle held at a
# zone's edge keeps this much more back)
ZONE_RESOLUTION = _ZONE_STEP


def _body_points(path: MovementPath, s_front: np.ndarray, length: float, width: float,
                 outline: bool) -> np.ndarray:
    """[m] (S, B, 2) points of the body rectangle (``length`` x ``width``) for each front arc
    length in ``s_front``: its outline, or a grid over its whole area, ``_ZONE_STEP`` apart. The
    body is headed like SUMO's (its angle and its collision check): along the chord from the
    centre-line point ``length`` behind the front to the front, not the tangent at the front (on
    a turn the two differ by up to ~10 degrees, which moves the rear ~0.8 m sideways)."""
    along = np.linspace(-length, 0.0, int(np.ceil(length / _ZONE_STEP)) + 1)
    across = np.linspace(-width / 2, width / 2, int(np.ceil(width / _ZONE_STEP)) + 1)
    if outline:
        local = np.concatenate([
            np.stack([along, np.full_like(along, -width / 2)], 1),
            np.stack([along, np.full_like(along, width / 2)], 1),
            np.stack([np.zeros_like(across), across], 1),
            np.stack([np.full_like(across, -length), across], 1),
        ])
    else:
        u, w = np.meshgrid(along, across, indexing="ij")
        local = np.stack([u.ravel(), w.ravel()], 1)
    front = path.point_at(s_front)
    h = path.heading_at(s_front)
    tangent = np.stack([np.cos(h), np.sin(h)], -1)  # (S, 2)
    chord = front - path.point_at(s_front - length)  # [m] rear to front along the centre line, as SUMO
    norm = np.hypot(chord[:, 0], chord[:, 1])  # [m]
    d = np.where(norm[:, None] > 1e-6, chord / np.maximum(norm, 1e-6)[:, None], tangent)
    n = np.stack([-d[:, 1], d[:, 0]], -1)
    return front[:, None, :] + local[None, :, 0:1] * d[:, None, :] + local[None, :, 1:2] * n[:, None, :]


def _fronts(path: MovementPath, length: float) -> np.ndarray:
    """[m] front arc lengths from just before the stop line until the rear has left the junction."""
    return np.arange(path.s_stop - _ZONE_STEP, min(path.s_exit + length + _ZONE_STEP, path.length), _ZONE_STEP)


def swept_area(path: MovementPath, length: float, width: float, merge: float | None = None) -> cKDTree:
    """KD-tree of a grid of points over the bodies on ``path`` at every front position through
    the junction (``_ZONE_STEP`` apart): the area its vehicles sweep. ``merge`` [m]: points are
    snapped to a grid this fine and duplicates dropped (consecutive bodies overlap almost
    wholly, so a 12 m body's area has ~50 times fewer distinct points; None: every point)."""
    pts = _body_points(path, _fronts(path, length), length, width, outline=False).reshape(-1, 2)
    if merge is not None:
        cells = np.round(pts / merge).astype(np.int64)
        cells -= cells.min(axis=0)
        span = int(cells[:, 1].max()) + 1
        keys = np.unique(cells[:, 0] * span + cells[:, 1])  # one integer per occupied cell
        pts = (np.stack([keys // span, keys % span], 1) + np.round(pts.min(axis=0) / merge)) * merge
    return cKDTree(pts)


def point_zone(s_cp: float, length: float, width: float) -> tuple[float, float]:
    """[m] front arc lengths over which a body occupies a conflict point at ``s_cp``: from the
    front half a width before it until the rear is half a width past it."""
    return s_cp - width / 2, s_cp + width / 2 + length


def conflict_zone(a: MovementPath, b: MovementPath, length: float = 4.5, width: float = 1.8,
                  swept_b: cKDTree | None = None) -> tuple[float, float] | None:
    """[m] ``(zone_in, zone_out)``: the front arc lengths on ``a`` between which a body on ``a``
    overlaps the area that bodies on ``b`` sweep through the junction, or None if it never does.

    Bodies are rigid rectangles headed as SUMO heads them (its angle and its junction collision
    check): along the chord from the centre-line point ``length`` behind the front to the front
    (see :func:`_body_points`; on a turn the rear stays on the inside of the curve, not swung
    out along the tangent at the front bumper, which ended a left turn's zone ~2.5 m early). The area
    ``b`` sweeps is a grid of points over its bodies at every front 0.25 m apart; a body on ``a``
    overlaps it where a point of its outline comes within ``_ZONE_MARGIN`` of one (the grid's
    spacing, so the zone errs a little on the long side). ``swept_b``: that grid's KD-tree, if
    already built."""
    if swept_b is None:
        swept_b = swept_area(b, length, width)
    s_front = _fronts(a, length)
    hit = _hits(a, s_front, length, width, swept_b)  # the search bounded by the margin: the same hits
    if not hit.any():
        return None
    k = np.flatnonzero(hit)
    return float(s_front[k[0]]), float(s_front[k[-1]])


def area_zone(path: MovementPath, area: cKDTree, length: float, width: float,
              span: tuple[float, float] | None = None) -> tuple[float, float] | None:
    """[m] ``(zone_in, zone_out)``: the front arc lengths over ``span`` [m] of ``path`` (default
    all of it, approach included, not only the junction) between which a body ``length`` x
    ``width`` [m] on it comes within ``_ZONE_MARGIN`` of a point of ``area`` (e.g. a zebra
    crossing's grid, network/crossings.py), or None if it never does."""
    lo, hi = span if span is not None else (0.0, path.length)
    s_front = np.arange(max(lo, min(length, path.length)), min(hi, path.length), _ZONE_STEP)
    if not len(s_front):
        return None
    hit = _hits(path, s_front, length, width, area)
    if not hit.any():
        return None
    k = np.flatnonzero(hit)
    return float(s_front[k[0]]), float(s_front[k[-1]])


def _hits(a: MovementPath, s_front: np.ndarray, length: float, width: float, swept_b: cKDTree) -> np.ndarray:
    """(S,) bool: whether the body on ``a`` at each front in ``s_front`` overlaps ``swept_b``."""
    pts = _body_points(a, s_front, length, width, outline=True)
    dist, _ = swept_b.query(pts.reshape(-1, 2), distance_upper_bound=_ZONE_MARGIN)
    return (dist.reshape(pts.shape[:2]) < _ZONE_MARGIN).any(axis=1)


def coarse_zone(a: MovementPath, length: float, width: float, swept_b: cKDTree,
                stride: int = 8) -> tuple[float, float] | None:
    """:func:`conflict_zone` of a body ``length`` x ``width`` [m] on ``a`` against ``swept_b``,
    found coarse to fine: fronts ``stride`` samples apart first, then the first and last hit
    refined at every sample around them (a full scan when the coarse one finds none). The same
    zone as the full scan when the fronts that overlap are one stretch, as on a crossing."""
    s_front = _fronts(a, length)
    n = len(s_front)
    coarse = np.flatnonzero(_hits(a, s_front[::stride], length, width, swept_b)) * stride
    if coarse.size == 0:
        hit = np.flatnonzero(_hits(a, s_front, length, width, swept_b))
        return None if hit.size == 0 else (float(s_front[hit[0]]), float(s_front[hit[-1]]))
    lo = max(0, int(coarse[0]) - stride + 1)
    first = lo + int(np.argmax(_hits(a, s_front[lo:int(coarse[0]) + 1], length, width, swept_b)))
    hi = min(n, int(coarse[-1]) + stride)
    tail = _hits(a, s_front[int(coarse[-1]):hi], length, width, swept_b)
    last = int(coarse[-1]) + int(np.flatnonzero(tail)[-1])
    return float(s_front[first]), float(s_front[last])
