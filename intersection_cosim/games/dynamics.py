"""Longitudinal dynamics over the horizon (the arc-length part of paper Eq. 2), as affine maps.

For piecewise-constant accelerations a_0..a_{N-1} [m/s^2] and step dt [s]:

    v_{k+1} = v_k + a_k dt,        s_{k+1} = s_k + v_k dt + a_k dt^2 / 2,

hence v_{1..N} = v0 + dt Lv a and s_{1..N} = s0 + dt v0 (1..N) + Ls a with constant matrices.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from numba import njit


@dataclass(frozen=True)
class HorizonMatrices:
    n: int  # [-] steps N
    dt: float  # [s]
    Lv: np.ndarray  # [-] lower-triangular ones: v_{1..N} = v0 + dt * Lv @ a
    dtLv: np.ndarray  # [s] dt * Lv
    Ls: np.ndarray  # [s^2] Ls[k, m] = dt^2 (k - m + 1/2) for m <= k: s_{1..N} = s_free + Ls @ a
    t: np.ndarray  # [s] times of the states x_1..x_N: dt * (1..N)
    LtL: np.ndarray  # [-] Lv^T Lv
    DtD: np.ndarray  # [-] D^T D of the first difference D, shape (N, N)
    eye: np.ndarray  # [-] identity (N, N)
    k_half: np.ndarray  # [s^2] dt^2 (k + 1/2), k = 0..N-1: Ls[k, m] = k_half[k] - dt^2 m
    m_dt2: np.ndarray  # [s^2] dt^2 m, m = 0..N-1
    M: np.ndarray  # stacked map a -> (v_0..v_N, s_0..s_N) - offset, shape (2N + 2, N)
    dtLv_colsum: np.ndarray  # [s] column sums of dt * Lv: d/da sum_k v_k


@functools.lru_cache(maxsize=16)
def horizon_matrices(n: int, dt: float) -> HorizonMatrices:
    k = np.arange(n)
    Lv = np.tril(np.ones((n, n)))
    Ls = np.tril(dt * dt * (k[:, None] - k[None, :] + 0.5))
    D = np.diff(np.eye(n), axis=0)
    M = np.zeros((2 * n + 2, n))
    M[1:n + 1] = dt * Lv
    M[n + 2:] = Ls
    out = HorizonMatrices(n, dt, Lv, dt * Lv, Ls, dt * (k + 1.0), Lv.T @ Lv, D.T @ D, np.eye(n),
                          dt * dt * (k + 0.5), dt * dt * k, M, (dt * Lv).sum(axis=0))
    for m in (out.Lv, out.dtLv, out.Ls, out.t, out.LtL, out.DtD, out.eye, out.k_half, out.m_dt2, out.M,
              out.dtLv_colsum):
        m.setflags(write=False)
    return out


def state_offset(s0: float, v0: float, hm: HorizonMatrices) -> np.ndarray:
    """(v_0..v_N, s_0..s_N) at zero acceleration: the offset of the affine map ``hm.M``."""
    out = np.empty(2 * hm.n + 2)
    out[:hm.n + 1] = v0
    out[hm.n + 1] = s0
    out[hm.n + 2:] = s0 + v0 * hm.t
    return out


def plan_trajectory(s0: float, v0: float, a: np.ndarray, hm: HorizonMatrices) -> tuple[np.ndarray, np.ndarray]:
    """[m/s], [m]: v_0..v_N and s_0..s_N from s0 [m], v0 [m/s] for accelerations ``a`` (N,)
    [m/s^2]: ``hm.M @ a`` plus :func:`state_offset`, compiled into one call (every Plan is built
    by it, some hundred a control step)."""
    full = _plan_trajectory(float(s0), float(v0), a, hm.M, hm.t)
    return full[:hm.n + 1], full[hm.n + 1:]


@njit(cache=True)
def _plan_trajectory(s0, v0, a, M, t):  # pragma: no cover - compiled
    n = a.shape[0]
    full = np.empty(2 * n + 2)
    for i in range(2 * n + 2):
        acc = v0 if i <= n else (s0 if i == n + 1 else s0 + v0 * t[i - n - 2])
        for j in range(n):
            acc += M[i, j] * a[j]
        full[i] = acc
    return full


def shifted_trajectory(a: np.ndarray, v_end: float, s1: float, v1: float, hm: HorizonMatrices) -> tuple:
    """The plan one solver step later as one compiled call (games.problem.shift_plan): the
    accelerations [m/s^2] ``a`` (N,) without a_0 and with the last repeated, kept at v >= 0 from
    the plan's last speed ``v_end`` [m/s], and (v_0..v_N [m/s], s_0..s_N [m]) of them from s1 [m],
    v1 [m/s] (the plan's second state), the same numbers as :func:`plan_trajectory` of them."""
    out_a, full = _shifted_trajectory(a, float(v_end), float(s1), float(v1), hm.dt, hm.M, hm.t)
    return out_a, full[:hm.n + 1], full[hm.n + 1:]


@njit(cache=True)
def _shifted_trajectory(a, v_end, s1, v1, dt, M, t):  # pragma: no cover - compiled
    n = a.shape[0]
    out = np.empty(n)
    for i in range(n - 1):
        out[i] = a[i + 1]
    lo = -v_end / dt
    last = a[n - 1]
    out[n - 1] = lo if lo > last else last  # Python's max(last, lo)
    return out, _plan_trajectory(s1, v1, out, M, t)


def rollout(s0: float, v0: float, a, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """[m/s], [m]: speeds v_1..v_N and positions s_1..s_N; ``a`` of shape (N,) or (m, N)."""
    a = np.asarray(a, dtype=float)
    hm = horizon_matrices(a.shape[-1], float(dt))
    if a.ndim == 1:
        return v0 + hm.dtLv @ a, (s0 + v0 * hm.t) + hm.Ls @ a
    return v0 + a @ hm.dtLv.T, (s0 + v0 * hm.t) + a @ hm.Ls.T


def stay_behind(a: np.ndarray, s0: float, v0: float, bound: np.ndarray, dt: float, a_min: float) -> np.ndarray:
    """[m/s^2] accelerations ``a`` (N,) lowered where needed, step by step, so the positions
    s_1..s_N stay at or behind ``bound`` (N,) [m] (a leader's rear), never braking harder than
    ``a_min`` [m/s^2] nor below v = 0; from s0 [m], v0 [m/s]."""
    out = np.array(a, dtype=float)
    vk, sk = v0, s0
    for k in range(len(out)):
        hi = (bound[k] - sk - vk * dt) / (0.5 * dt * dt)
        lo = max(a_min, -vk / dt)
        out[k] = max(min(out[k], hi), lo)
        sk += vk * dt + 0.5 * out[k] * dt * dt
        vk = max(vk + out[k] * dt, 0.0)
    return out
