"""Running-cost terms of the paper, Eqs. 13-24, vectorised over any array shape (e.g. horizon).

All functions take numpy arrays (or scalars) and broadcast. Speeds in m/s, distances in m,
times in s. These are the *true* costs; the game solvers convexify them but always judge a step
by these functions. The three the solvers evaluate thousands of times a control step (J_log,
J_lat, TCP) are compiled numpy ufuncs (numba ``vectorize``): one call instead of some ten numpy
calls of about a microsecond each on a 30-step horizon, with the same floating-point operations.
"""

from __future__ import annotations

import numpy as np
from numba import njit, vectorize

from intersection_cosim.models.settings import ModelSettings


def longitudinal_ttc(gap, v, v_lead):
    """[s] TTC_log = gap / (v - v_LV) (Eqs. 16-17); +inf where the host is not closing in, and 0
    where the gap is negative (the bodies overlap).

    gap [m] is the bumper-to-bumper distance to the leading vehicle (LV), v and v_lead [m/s].
    """
    out = _ttc_log(np.asarray(gap, float), np.asarray(v, float) - np.asarray(v_lead, float))
    return out if out.ndim else float(out)


def _ttc_log(gap: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """TTC_log [s] for arrays gap [m] and closing speed dv [m/s] (:func:`longitudinal_ttc`)."""
    if gap.shape != dv.shape:
        gap, dv = np.broadcast_arrays(gap, dv)
    out = np.full(gap.shape, np.inf)
    np.divide(gap, dv, out=out, where=dv > 0)
    # Overlapping bodies (gap < 0) have collided: TTC 0 whatever the speeds. Without this a
    # negative gap gives a negative TTC whose cost *falls* as the overlap grows.
    np.copyto(out, 0.0, where=gap < 0.0)
    return out


@njit(cache=True)
def j_log_step(gap, v, v_lead, eps):  # pragma: no cover - compiled
    """J_s-log at one step (:func:`longitudinal_safety_cost`), for compiled callers."""
    if gap < 0.0:
        return 1.0 / eps
    dv = v - v_lead
    if dv > 0.0:
        ttc = gap / dv
        return 1.0 / (ttc * ttc + eps)
    return 0.0


@vectorize(["float64(float64, float64, float64, float64)"], cache=True)
def _j_log_dufunc(gap, v, v_lead, eps):  # pragma: no cover - compiled
    return j_log_step(gap, v, v_lead, eps)


_j_log = _j_log_dufunc.ufunc  # the plain numpy ufunc, without DUFunc's Python call (~0.8 us)


def longitudinal_safety_cost(gap, v, v_lead, eps):
    """J_s-log = gamma_log / (TTC_log^2 + eps) (Eqs. 15-18); gamma_log = 0 when not closing.

    Dimensionless cost [1/s^2 scaled]; eps [s^2] > 0. Where the bodies overlap (gap < 0) TTC_log
    is 0 and the cost 1 / eps; where the host does not close in (or TTC_log is infinite) it is 0.
    """
    out = _j_log(gap, v, v_lead, eps)
    return out if np.ndim(out) else float(out)


@njit(cache=True)
def tcp_step(distance, v, speed_floor):  # pragma: no cover - compiled
    """TCP at one step (:func:`time_to_conflict_point`), for compiled callers; NaN speeds stay
    NaN, as with np.maximum."""
    return distance / (v if (v > speed_floor or v != v) else speed_floor)


@vectorize(["float64(float64, float64, float64)"], cache=True)
def _tcp_dufunc(distance, v, speed_floor):  # pragma: no cover - compiled
    return tcp_step(distance, v, speed_floor)


_tcp = _tcp_dufunc.ufunc  # the plain numpy ufunc, without DUFunc's Python call (~0.8 us)


def time_to_conflict_point(distance, v, speed_floor=0.1):
    """[s] TCP = distance to the conflict point / speed (Eqs. 21-22).

    distance [m] is signed (negative once the vehicle is past the point); the speed [m/s] is
    floored at ``speed_floor`` so a stopped vehicle has a large, finite TCP.
    """
    out = _tcp(distance, v, speed_floor)
    return out if np.ndim(out) else float(out)


def lateral_ttc(tcp_i, tcp_j):
    """[s] TTC_lat = TCP_i - TCP_j (Eq. 20): how far apart in time the two reach the point."""
    out = np.asarray(tcp_i, float) - np.asarray(tcp_j, float)
    return out if out.ndim else float(out)


@njit(cache=True)
def j_lat_step(tcp_i, tcp_j, eps, weight):  # pragma: no cover - compiled
    """J_s-lat at one step times its ``weight`` (:func:`lateral_safety_cost`), for compiled
    callers; 0 where the weight is."""
    if weight == 0.0:
        return 0.0
    ttc = tcp_i - tcp_j
    return (1.0 / (ttc * ttc + eps)) * weight


@vectorize(["float64(float64, float64, float64, float64)"], cache=True)
def _j_lat_dufunc(tcp_i, tcp_j, eps, weight):  # pragma: no cover - compiled
    return j_lat_step(tcp_i, tcp_j, eps, weight)


_j_lat = _j_lat_dufunc.ufunc  # the plain numpy ufunc, without DUFunc's Python call (~0.8 us)


def lateral_safety_cost(tcp_i, tcp_j, eps, active=True):
    """J_s-lat = 1 / (TTC_lat^2 + eps) (Eq. 19), zero where ``active`` is False.

    ``active`` is False once either vehicle has passed the conflict point: the pair then has no
    lateral cost (the paper is silent on a passed point; our reading). A float array ``active``
    is a weight per step (0 where not active) that multiplies the cost: the term's risk
    weight of ``games.weights.lateral_risk_weight``.
    """
    out = _j_lat(tcp_i, tcp_j, eps, active)
    return out if np.ndim(out) else float(out)


def lane_keeping_cost(lateral_offset, heading_error, k_y, k_phi):
    """J_s-lk = k_y (dy)^2 + k_phi (dphi)^2 (Eq. 23); dy [m], dphi [rad]."""
    out = k_y * np.square(np.asarray(lateral_offset, float)) + k_phi * np.square(np.asarray(heading_error, float))
    return out if out.ndim else float(out)


def efficiency_cost(v, v_max, k_e):
    """J_e = k_e (v - v_max)^2 (Eq. 24); v, v_max [m/s], k_e [s^2/m^2]."""
    out = k_e * np.square(np.asarray(v, float) - v_max)
    return out if out.ndim else float(out)


def safety_cost(j_log, j_lat, j_lk, settings: ModelSettings):
    """J_s = k_log J_log + k_lat J_lat + k_lk J_lk (Eq. 14)."""
    return settings.k_log * np.asarray(j_log) + settings.k_lat * np.asarray(j_lat) + settings.k_lk * np.asarray(j_lk)


def running_cost(kappa, j_log, j_lat, j_lk, j_e, settings: ModelSettings):
    """J = (1 - kappa) J_s + kappa J_e (Eq. 13); kappa in [0, 1] is the aggressiveness."""
    out = (1.0 - kappa) * safety_cost(j_log, j_lat, j_lk, settings) + kappa * np.asarray(j_e)
    return out if np.ndim(out) else float(out)
