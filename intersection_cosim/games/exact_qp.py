"""Exact answers of the SQP step's QP, compiled: the unconstrained minimiser when it meets every
row, else the primal-dual active-set solution over the input-box rows when that meets the speed
rows (:mod:`intersection_cosim.games.qp`, "Interior solutions" and "Box solutions").

The QP is min 1/2 x^T H x + c^T x with c = g - H a, over the N input-box rows l[:N] <= x <= u[:N]
and the N speed rows l[N:] <= row_scale[N:] * cumsum(x) <= u[N:]. For N = 30 the arithmetic is a
few microseconds; written as numpy calls it was some 30 calls of about 1 us each per pass, so it
is compiled with numba (``cache=True``: compiled once per machine, then loaded). Cholesky
factorisations read the upper triangle of H, as LAPACK's ``dposv`` does with its default.
"""

from __future__ import annotations

import numpy as np
from numba import njit

INTERIOR = 0  # no row active: all multipliers zero
BOX = 1  # only input-box rows active: their multipliers in y[:N], the speed rows' zero
NOT_FOUND = -1  # H not positive definite, a value not finite, or a speed row active: OSQP decides


@njit(cache=True)
def _cholesky_solve(H, idx, m, b):
    """Solve H[idx[:m], idx[:m]] z = b[:m] by Cholesky (upper triangle of H); z and a success flag."""
    L = np.zeros((m, m))
    for j in range(m):
        d = H[idx[j], idx[j]]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:  # also NaN
            return b[:m].copy(), False
        L[j, j] = np.sqrt(d)
        for i in range(j + 1, m):
            s = H[idx[j], idx[i]]  # upper triangle: row j < column i
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / L[j, j]
    z = b[:m].copy()
    for i in range(m):  # L w = b
        s = z[i]
        for k in range(i):
            s -= L[i, k] * z[k]
        z[i] = s / L[i, i]
    for i in range(m - 1, -1, -1):  # L^T z = w
        s = z[i]
        for k in range(i + 1, m):
            s -= L[k, i] * z[k]
        z[i] = s / L[i, i]
    return z, True


@njit(cache=True)
def _meets_rows(x, l, u, row_scale):
    """Whether ``x`` meets the 2N scaled rows (False for NaN)."""
    n = x.shape[0]
    total = 0.0
    for k in range(n):
        if not (l[k] <= x[k] <= u[k]):
            return False
        total += x[k]
        row = total * row_scale[n + k]
        if not (l[n + k] <= row <= u[n + k]):
            return False
    return True


@njit(cache=True)
def _gradient(H, x, c):
    """H x + c."""
    n = x.shape[0]
    r = c.copy()
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += H[i, j] * x[j]
        r[i] += s
    return r


@njit(cache=True)
def exact_qp(H, g, a, l, u, row_scale, box_iter):
    """(status, x, y): the exact solution x [m/s^2] of the module docstring's QP with its row
    multipliers y (2N,), status INTERIOR or BOX; status NOT_FOUND when there is none to be had
    here (``box_iter`` passes of the active set at most; 0: interior answers only)."""
    n = a.shape[0]
    idx = np.arange(n)
    y = np.zeros(2 * n)
    step, ok = _cholesky_solve(H, idx, n, g)
    if not ok:
        return NOT_FOUND, a, y
    x = a - step
    if _meets_rows(x, l, u, row_scale):
        return INTERIOR, x, y
    if box_iter == 0 or not np.isfinite(x).all():
        return NOT_FOUND, x, y
    c = g - _gradient(H, a, np.zeros(n))
    up, down = x > u[:n], x < l[:n]
    for _ in range(box_iter):
        fixed = up | down
        x = np.where(up, u[:n], np.where(down, l[:n], 0.0))
        m = 0
        for k in range(n):
            if not fixed[k]:
                idx[m] = k
                m += 1
        if m:
            rhs = -_gradient(H, x, c)
            sub = np.empty(m)
            for j in range(m):
                sub[j] = rhs[idx[j]]
            z, ok = _cholesky_solve(H, idx, m, sub)
            if not ok:
                return NOT_FOUND, x, y
            for j in range(m):
                x[idx[j]] = z[j]
        r = _gradient(H, x, c)  # a fixed bound's multiplier is -r
        new_up = (up & (r <= 0.0)) | (~fixed & (x > u[:n]))
        new_down = (down & (r >= 0.0)) | (~fixed & (x < l[:n]))
        if (new_up != up).any() or (new_down != down).any():
            up, down = new_up, new_down
            continue
        if not _meets_rows(x, l, u, row_scale):
            return NOT_FOUND, x, y
        for k in range(n):
            if fixed[k]:
                y[k] = -r[k]
        return BOX, x, y
    return NOT_FOUND, x, y


@njit(cache=True)
def exact_qps(H, g, a, l, u, row_scale, box_iter):
    """:func:`exact_qp` of m QPs at once (H (m, N, N), g, a (m, N), l, u (m, 2N)): statuses (m,),
    solutions (m, N) and multipliers (m, 2N), without a Python call per QP."""
    m, n = a.shape
    status = np.empty(m, np.int64)
    xs, ys = np.empty((m, n)), np.empty((m, 2 * n))
    for i in range(m):
        status[i], xs[i], ys[i] = exact_qp(H[i], g[i], a[i], l[i], u[i], row_scale, box_iter)
    return status, xs, ys
