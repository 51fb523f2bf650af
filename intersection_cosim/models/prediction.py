"""Model-based trajectory prediction over the preview time t_p, and the predicted collision point
(paper Section III-C: "the kinematic model and polynomial fitting"; TCP of Eqs. 21-22).

Two forms, both vectorised over vehicles:

- :func:`predict_along_paths` -- for vehicles that follow a known movement path (our case in the
  co-simulation): the longitudinal row of the kinematic model (Eq. 2, dv/dt = a_x) integrated at
  constant acceleration, stopping at zero speed, gives the arc length s(t); the path gives the
  position, heading and the steer delta_f = atan(l * curvature) (Eqs. 1-4) along it.
- :func:`predict_free` -- for a vehicle with no known path: roll the bicycle model (Eqs. 1-4) out
  with its current control held, then fit a polynomial X(t), Y(t) to the samples (least squares)
  so the predicted trajectory is smooth and can be evaluated at any time in [0, t_p].

The predicted collision point of two paths is the precomputed conflict point
(:mod:`intersection_cosim.network.conflicts`); :func:`conflict_lookup` fetches it for many vehicle
pairs at once through integer path indices. For two free predictions,
:func:`predicted_collision_point` finds where the predicted trajectories first come within a
vehicle width. Each vehicle's time to the point is TCP = distance / speed (Eqs. 21-22), computed by
:func:`intersection_cosim.models.cost.time_to_conflict_point`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from intersection_cosim.models.cost import time_to_conflict_point
from intersection_cosim.models.path_table import PathTable
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.models.vehicle import rollout


def preview_times(t_p: float, dt: float) -> np.ndarray:
    """[s] sample times 0, dt, ..., t_p of a prediction over the preview time ``t_p`` [s]."""
    n = int(round(t_p / dt))
    return np.linspace(0.0, n * dt, n + 1)


def predict_arc_length(s0, v0, a, t):
    """Arc length [m] and speed [m/s] at times ``t`` [s] (last axis) under constant acceleration
    ``a`` [m/s^2] from ``s0`` [m], ``v0`` [m/s] (Eq. 2, first row); a braking vehicle stops and stays.

    ``s0``, ``v0``, ``a`` broadcast to the vehicle shape (N,); returns two (N, T) arrays.
    """
    s0, v0, a = (np.asarray(x, float)[..., None] for x in np.broadcast_arrays(s0, v0, a))
    t = np.asarray(t, float)
    braking = a < 0
    t_stop = np.where(braking, v0 / np.where(braking, -a, 1.0), np.inf)  # [s] time to standstill
    tt = np.minimum(t, t_stop)
    return s0 + v0 * tt + 0.5 * a * tt**2, np.maximum(v0 + a * tt, 0.0)


@dataclass(frozen=True)
class PathPrediction:
    """Predicted motion of N path-following vehicles at T sample times."""

    t: np.ndarray  # (T,) [s]
    s: np.ndarray  # (N, T) [m] arc length along each vehicle's path
    v: np.ndarray  # (N, T) [m/s]
    xy: np.ndarray  # (N, T, 2) [m] centre of gravity
    yaw: np.ndarray  # (N, T) [rad]
    delta_f: np.ndarray  # (N, T) [rad] steer implied by the path curvature


def predict_along_paths(paths: PathTable, path_idx, s0, v0, settings: ModelSettings, a=0.0,
                        dt: float | None = None) -> PathPrediction:
    """Predict N vehicles along their paths over ``settings.t_p`` (Eqs. 1-4, path-constrained).

    ``path_idx`` (N,) integer path indices, ``s0`` [m], ``v0`` [m/s], ``a`` [m/s^2] (held);
    ``dt`` [s] defaults to ``settings.prediction_dt``.
    """
    path_idx = np.asarray(path_idx, dtype=np.intp)
    t = preview_times(settings.t_p, dt or settings.prediction_dt)
    s, v = predict_arc_length(s0, v0, a, t)
    xy, heading, curvature = paths.sample(path_idx[:, None], s)
    return PathPrediction(t=t, s=s, v=v, xy=xy, yaw=heading,
                          delta_f=np.arctan(settings.wheelbase * curvature))


@dataclass(frozen=True)
class FreePrediction:
    """Bicycle-model rollout and its polynomial fit for N vehicles."""

    t: np.ndarray  # (T,) [s]
    states: np.ndarray  # (N, T, 4) rolled-out states [v, yaw, X, Y]
    coeffs: np.ndarray  # (N, 2, degree + 1) polynomial coefficients of X(t), Y(t), highest first
    xy: np.ndarray  # (N, T, 2) [m] the fitted trajectory at t

    def position(self, t) -> np.ndarray:
        """[m] fitted (X, Y) at times ``t`` [s], shape (N, len(t), 2)."""
        t = np.atleast_1d(np.asarray(t, float))
        powers = np.vander(t, self.coeffs.shape[-1])  # (len(t), degree + 1)
        return np.einsum("tk,nck->ntc", powers, self.coeffs)


def predict_free(state, control, settings: ModelSettings, dt: float | None = None,
                 degree: int | None = None) -> FreePrediction:
    """Model-based prediction with polynomial fitting over ``settings.t_p`` (Section III-C).

    ``state`` (N, 4) = [v, yaw, X, Y]; ``control`` (N, 2) = [a_x, delta_f], held constant. The
    bicycle model (Eqs. 1-4) is rolled out at ``dt`` [s], then X(t) and Y(t) are each fitted with a
    polynomial of ``degree`` by least squares. ``dt`` and ``degree`` default to
    ``settings.prediction_dt`` and ``settings.prediction_degree``.
    """
    dt = dt or settings.prediction_dt
    degree = degree or settings.prediction_degree
    state = np.atleast_2d(np.asarray(state, float))
    control = np.atleast_2d(np.asarray(control, float))
    t = preview_times(settings.t_p, dt)
    controls = np.broadcast_to(control[:, None, :], (state.shape[0], len(t) - 1, 2))
    states = rollout(state, controls, dt, settings)
    vander = np.vander(t, degree + 1)  # (T, degree + 1)
    fit = np.linalg.pinv(vander)  # (degree + 1, T)
    coeffs = np.einsum("kt,ntc->nck", fit, states[..., 2:4])
    xy = np.einsum("tk,nck->ntc", vander, coeffs)
    return FreePrediction(t=t, states=states, coeffs=coeffs, xy=xy)


@dataclass(frozen=True)
class PredictedCollision:
    """Where two predicted trajectories first come within a vehicle width, and when."""

    x: float  # [m]
    y: float  # [m]
    s_i: float  # [m] distance along i's predicted trajectory to the point
    s_j: float  # [m] distance along j's predicted trajectory to the point
    t_i: float  # [s] predicted time at which i reaches the point
    t_j: float  # [s] predicted time at which j reaches the point
    tcp_i: float  # [s] TCP of i = s_i / v_i (Eq. 21)
    tcp_j: float  # [s] TCP of j = s_j / v_j (Eq. 22)


def _first_within(d_min: np.ndarray) -> int | None:
    idx = np.flatnonzero(d_min)
    return int(idx[0]) if idx.size else None


def predicted_collision_point(t, xy_i, xy_j, v_i: float, v_j: float, width: float,
                              speed_floor: float = 0.1) -> PredictedCollision | None:
    """Predicted collision point of two predicted trajectories sampled at times ``t`` [s].

    ``xy_i``, ``xy_j`` (T, 2) [m]. The point on each trajectory is the first sample at which the
    other trajectory (anywhere on it) is closer than ``width`` [m] -- the rule used for the net's
    confluence points; (x, y) is the midpoint of the two. None if the trajectories stay apart.
    The TCPs use the current speeds ``v_i``, ``v_j`` [m/s] (Eqs. 21-22).
    """
    t = np.asarray(t, float)
    xy_i, xy_j = np.asarray(xy_i, float), np.asarray(xy_j, float)
    dist = np.linalg.norm(xy_i[:, None, :] - xy_j[None, :, :], axis=2)
    ki = _first_within(dist.min(axis=1) < width)
    kj = _first_within(dist.min(axis=0) < width)
    if ki is None or kj is None:
        return None
    arc_i = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy_i, axis=0), axis=1))])
    arc_j = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(xy_j, axis=0), axis=1))])
    x, y = 0.5 * (xy_i[ki] + xy_j[kj])
    return PredictedCollision(
        x=float(x), y=float(y), s_i=float(arc_i[ki]), s_j=float(arc_j[kj]), t_i=float(t[ki]),
        t_j=float(t[kj]), tcp_i=float(time_to_conflict_point(arc_i[ki], v_i, speed_floor)),
        tcp_j=float(time_to_conflict_point(arc_j[kj], v_j, speed_floor)))


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
