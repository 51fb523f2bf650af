"""A player's convex (Gauss-Newton) model of its cost, compiled: the gradient and Hessian of
:meth:`intersection_cosim.games.objective.PlayerObjective.model` (objective.py's module
docstring, "Convex model").

Per lateral term, g_k = TTC_lat = d_k / max(v_k, floor) - TCP_other,k with d_k = s_cp - s_k, and
f(g) = 1 / (g^2 + eps) (Eq. 19); per following term, r_k = (v_k - v_lead,k) / max(gap_k,
gap_floor) and h(r) = r^2 / (1 + eps r^2) for r > 0 (Eq. 15). Each adds w f'(g) G^T 1 to the
gradient and G^T diag(w max(f''(g), 0)) G to the Hessian, G the Jacobian of g in the
accelerations: lower-triangular, G[k, m] = inv_k m dt^2 - alpha_k (m <= k) for a lateral term
and R[k, m] = dt / gap_k + dv_k / gap_k^2 Ls[k, m] for a following one. Built as numpy calls
(PlayerObjective._lateral_weights, _lateral_jacobian and _following_terms, which the Stackelberg
pair model still uses) it cost some 40 calls per term; ``tests/games`` holds the two to each
other. The Hessian is returned exactly symmetric (its upper triangle mirrored).
"""

from __future__ import annotations

import numpy as np
from numba import njit

# the order of the scalar parameters in ``params``
PARAMS = ("dt", "w_lat", "w_log", "eps", "speed_floor", "clearance", "gap_floor")


@njit(cache=True)
def _add_term(grad, H, J, w1, w2, n):  # pragma: no cover - compiled
    """grad += J^T w1; upper triangle of H += J^T diag(w2) J, J lower-triangular (n, n)."""
    for k in range(n):
        if w1[k] != 0.0:
            for m in range(k + 1):
                grad[m] += J[k, m] * w1[k]
        if w2[k] != 0.0:
            for i in range(k + 1):
                t = w2[k] * J[k, i]
                for j in range(i, k + 1):
                    H[i, j] += t * J[k, j]


@njit(cache=True)
def convex_model(a, M, offset, Q, b0, k_half, m_dt2, lat_scp, lat_tcp, lat_weight, log_s, log_v,
                 params):  # pragma: no cover - compiled
    """Gradient (N,) and Hessian (N, N) of the model at ``a`` (N,) [m/s^2]; the data as
    :func:`~intersection_cosim.games.true_cost.true_costs` takes them, ``Q`` (N, N) and ``b0``
    (N,) the exact quadratic part, ``k_half``, ``m_dt2`` (N,) [s^2] of games.dynamics;
    ``params`` in the order of :data:`PARAMS`."""
    dt, w_lat, w_log, eps, floor, clr, gap_floor = params[:7]
    n = a.shape[0]
    grad = Q @ a + b0
    H = np.triu(Q)
    v, s = np.empty(n), np.empty(n)
    for k in range(n):
        sv, ss = offset[k + 1], offset[n + 2 + k]
        for j in range(n):
            sv += M[k + 1, j] * a[j]
            ss += M[n + 2 + k, j] * a[j]
        v[k], s[k] = sv, ss
    J = np.zeros((n, n))
    w1, w2 = np.empty(n), np.empty(n)
    for t in range(lat_scp.shape[0]):
        any_active = False
        for k in range(n):
            inv = 1.0 / (v[k] if v[k] > floor else floor)
            d = lat_scp[t] - s[k]
            g = d * inv - lat_tcp[t, k]
            w = w_lat * lat_weight[t, k] if s[k] <= lat_scp[t] + clr else 0.0
            any_active = any_active or w != 0.0
            gg = g * g
            den = gg + eps
            w1[k] = w * (-2.0 * g) / (den * den)
            w2[k] = w * max((6.0 * gg - 2.0 * eps) / (den * den * den), 0.0)
            alpha = inv * k_half[k] + (d * inv * inv * dt if v[k] > floor else 0.0)
            for m in range(k + 1):
                J[k, m] = inv * m_dt2[m] - alpha
        if any_active:
            _add_term(grad, H, J, w1, w2, n)
    for t in range(log_s.shape[0]):
        closing = False
        for k in range(n):
            gap = max(log_s[t, k] - s[k], gap_floor)
            dv = v[k] - log_v[t, k]
            r = dv / gap
            w = w_log if r > 0.0 else 0.0
            closing = closing or r > 0.0
            den = 1.0 + eps * r * r
            w1[k] = w * 2.0 * r / (den * den)
            w2[k] = w * max((2.0 - 6.0 * eps * r * r) / (den * den * den), 0.0)
            for m in range(k + 1):
                J[k, m] = dt / gap + dv / (gap * gap) * (k_half[k] - m_dt2[m])
        if closing:
            _add_term(grad, H, J, w1, w2, n)
    for i in range(n):
        for j in range(i):
            H[i, j] = H[j, i]
    return grad, H


@njit(cache=True)
def solo_convex_models(a, rows, M, offsets, Q, b0, k_half, m_dt2, log_s, log_v, params):  # pragma: no cover - compiled
    """:func:`convex_model` of row r of ``a`` (k, N) for player ``rows[r]`` of a batch of players
    without lateral terms (its ``offsets``, ``Q``, ``b0``, one following term ``log_s``,
    ``log_v`` (m, 1, N), leader's rear inf: none, ``params``): gradients (k, N), Hessians (k, N, N)."""
    k, n = a.shape
    none, no_weights = np.empty(0), np.empty((0, n))
    grads, hessians = np.empty((k, n)), np.empty((k, n, n))
    for r in range(k):
        i = rows[r]
        grads[r], hessians[r] = convex_model(a[r], M, offsets[i], Q[i], b0[i], k_half, m_dt2, none, no_weights,
                                             no_weights, log_s[i], log_v[i], params[i])
    return grads, hessians
