"""A player's true cost over the horizon, compiled: the value of
:meth:`intersection_cosim.games.objective.PlayerObjective.cost` (objective.py's module docstring,
Eqs. 13-24) for many acceleration sequences in one call.

The best response evaluates it at every SQP step, line-search trial and equilibrium check, some
ten times a game per control step; as numpy calls on a 30-step horizon it was about 30 calls of
about a microsecond each. The per-step terms are models.cost's own compiled functions
(:func:`~intersection_cosim.models.cost.j_lat_step`, ``j_log_step``, ``tcp_step``), so the
formulas have one source.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from intersection_cosim.models.cost import j_lat_step, j_log_step, tcp_step

# the order of the scalar parameters in ``params``
PARAMS = ("dt", "kappa", "k_log", "k_lat", "k_lk", "k_e", "j_lk", "v_max", "w_acc", "jerk_w", "eps",
          "speed_floor", "clearance")


@njit(cache=True)
def true_cost(a, M, offset, lat_scp, lat_tcp, lat_weight, log_s, log_v, params):  # pragma: no cover - compiled
    """[-] C_i of the accelerations ``a`` (N,) [m/s^2].

    ``M`` (2N + 2, N), ``offset`` (2N + 2,): the affine map a -> (v_0..v_N, s_0..s_N)
    (games.dynamics); per lateral term t: own conflict point ``lat_scp[t]`` [m], the other's TCP
    ``lat_tcp[t]`` (N,) [s] and the weight ``lat_weight[t]`` (N,) [-] (0 where the other has
    passed its point); per following term: the leader's rear ``log_s[t]`` (N,) [m] in the own
    frame (inf: no leader) and speed ``log_v[t]`` (N,) [m/s]; ``params`` in the order of
    :data:`PARAMS`.
    """
    dt, kappa, k_log, k_lat, k_lk, k_e, j_lk, v_max, w_acc, jerk_w, eps, floor, clr = params[:13]
    n = a.shape[0]
    v, s = np.empty(n), np.empty(n)
    for k in range(n):  # v_{k+1}, s_{k+1}
        sv = offset[k + 1]
        ss = offset[n + 2 + k]
        for j in range(n):
            sv += M[k + 1, j] * a[j]
            ss += M[n + 2 + k, j] * a[j]
        v[k], s[k] = sv, ss
    lat = 0.0
    for t in range(lat_scp.shape[0]):
        for k in range(n):
            if s[k] <= lat_scp[t] + clr:
                lat += j_lat_step(tcp_step(lat_scp[t] - s[k], v[k], floor), lat_tcp[t, k], eps, lat_weight[t, k])
    log = 0.0
    for t in range(log_s.shape[0]):
        for k in range(n):
            log += j_log_step(log_s[t, k] - s[k], v[k], log_v[t, k], eps)
    e = 0.0
    for k in range(n):
        e += (v[k] - v_max) * (v[k] - v_max)
    acc = a[0] * a[0]
    jerk = 0.0
    for k in range(1, n):
        acc += a[k] * a[k]
        jerk += (a[k] - a[k - 1]) * (a[k] - a[k - 1])
    safety = k_log * log + k_lat * lat + k_lk * j_lk * n
    return dt * ((1.0 - kappa) * safety + kappa * k_e * e + w_acc * acc + jerk_w * jerk)


@njit(cache=True)
def true_costs(a, M, offset, lat_scp, lat_tcp, lat_weight, log_s, log_v, params):  # pragma: no cover - compiled
    """[-] :func:`true_cost` of every row of ``a`` (m, N), one player's data."""
    out = np.empty(a.shape[0])
    for r in range(a.shape[0]):
        out[r] = true_cost(a[r], M, offset, lat_scp, lat_tcp, lat_weight, log_s, log_v, params)
    return out


@njit(cache=True)
def solo_true_costs(a, rows, M, offsets, log_s, log_v, params):  # pragma: no cover - compiled
    """[-] :func:`true_cost` of row r of ``a`` (k, N) for player ``rows[r]`` of a batch of
    players without lateral terms: its ``offsets`` (m, 2N + 2), its one following term
    ``log_s``, ``log_v`` (m, 1, N) (leader's rear inf: none) and ``params`` (m, len(PARAMS))."""
    none, no_weights = np.empty(0), np.empty((0, a.shape[1]))
    out = np.empty(a.shape[0])
    for r in range(a.shape[0]):
        i = rows[r]
        out[r] = true_cost(a[r], M, offsets[i], none, no_weights, no_weights, log_s[i], log_v[i], params[i])
    return out
