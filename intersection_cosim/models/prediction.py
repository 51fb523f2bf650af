"""Prediction along the movement paths and the predicted collision point of vehicle pairs
(paper Section III-C; TCP of Eqs. 21-22).

Every vehicle follows a known movement path (``network.paths``), so its motion over the preview
time t_p is predicted along that path only, as its arc length s(t): at constant speed for the
trigger's TCP (``models.cost.time_to_conflict_point``, TCP = distance / speed) and at piecewise
constant acceleration over the game's horizon (``games.dynamics``: s' = v, v' = a). That is what
the kinematic bicycle model (Eqs. 1-4) reduces to on a path: with the steer that tracks the path's
curvature kappa (constant sideslip beta with sin(beta) = l_r kappa, tan(delta_f) = (l / l_r)
tan(beta)) the centre of gravity stays on the path with no slip relative to it, its speed along
the path is v = v_x / cos(beta) and its tangential acceleration a = a_x / cos(beta), so the
bicycle's arc length is exactly the path prediction's (tests/models/test_prediction.py integrates
the bicycle along a circular arc and compares). Position, heading and steer then follow from the
path at s(t); no free (path-less) rollout or polynomial fit is needed.

The predicted collision point of two paths is the precomputed conflict point
(:mod:`intersection_cosim.network.conflicts`); :func:`conflict_lookup` fetches it for many vehicle
pairs at once through integer path indices.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PairConflicts:
    """Conflict points of vehicle pairs (i, j) looked up from a ConflictTable by path index."""

    i: np.ndarray  # (M,) index of the first vehicle of each pair
    j: np.ndarray  # (M,) index of the second vehicle
    kind: np.ndarray  # (M,) int8 kind code (conflicts.KIND_NAMES)
    s_cp_i: np.ndarray  # (M,) [m] arc length of the conflict point on i's path
    s_cp_j: np.ndarray  # (M,) [m] arc length of the conflict point on j's path
    x: np.ndarray  # (M,) [m]
    y: np.ndarray  # (M,) [m]


_TRIU_CACHE: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def all_pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Indices (i, j), i < j, of every unordered pair among ``n`` vehicles (cached per n)."""
    if n not in _TRIU_CACHE:
        i, j = np.triu_indices(n, 1)
        _TRIU_CACHE[n] = (i.astype(np.intp), j.astype(np.intp))
    return _TRIU_CACHE[n]


def conflict_lookup(table, path_idx, pairs=None, *, conflicting_only: bool = True) -> PairConflicts:
    """The precomputed conflict point of every vehicle pair, vectorised over pairs.

    ``table`` is a :class:`~intersection_cosim.network.conflicts.ConflictTable`, ``path_idx`` (N,)
    the vehicles' path indices in it; ``pairs`` (i, j) arrays, default all i < j. With
    ``conflicting_only`` pairs whose paths do not conflict are dropped.
    """
    path_idx = np.asarray(path_idx, dtype=np.intp)
    i, j = all_pairs(len(path_idx)) if pairs is None else (np.asarray(pairs[0]), np.asarray(pairs[1]))
    pi, pj = path_idx[i], path_idx[j]
    kind = table.kind[pi, pj]
    if conflicting_only:
        keep = np.flatnonzero(kind)
        i, j, pi, pj, kind = i[keep], j[keep], pi[keep], pj[keep], kind[keep]
    return PairConflicts(i=i, j=j, kind=kind, s_cp_i=table.s_a[pi, pj], s_cp_j=table.s_b[pi, pj],
                         x=table.x[pi, pj], y=table.y[pi, pj])


def human_accelerations(v0: float, a0: float, a_max: float, v_cap: float, steps: int, dt: float) -> np.ndarray:
    """[m/s^2] (steps,) the accelerations a human driver is predicted to drive by over a horizon.

    A human is a vehicle that will not yield to the controller: from its measured speed ``v0``
    [m/s] and acceleration ``a0`` [m/s^2] it is predicted to keep its acceleration clipped to
    [0, ``a_max``] (it is never assumed to brake, so it reaches every crossing as early as its
    present motion allows), until it reaches ``v_cap`` [m/s], then at constant speed. A human
    standing at its stop line (v0 = 0, a0 <= 0), which SUMO's right of way holds back, is
    predicted to stay there: then an AV may pass; once it moves off the prediction moves with it.
    ``dt`` [s] is the step of the horizon.
    """
    a = min(max(float(a0), 0.0), float(a_max))
    out = np.zeros(int(steps))
    v = float(v0)
    for n in range(int(steps)):
        step = min(a, max(float(v_cap) - v, 0.0) / dt)  # reach v_cap exactly, never pass it
        out[n] = step
        v += step * dt
    return out
