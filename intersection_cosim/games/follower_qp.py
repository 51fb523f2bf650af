"""The follower's side of the Stackelberg game (paper Section IV-D): its convexified QP around
the current plans and its affine answer x(y) to the leader's plan y, by the KKT conditions of an
active set (see :mod:`intersection_cosim.games.stackelberg`)."""

from __future__ import annotations

import functools

import numpy as np
from scipy.linalg import lapack

from intersection_cosim.games.settings import GameSettings


def active_set(x: np.ndarray, v0: float, v_cap: float, gs: GameSettings) -> np.ndarray:
    """Signs of the active physical rows at x: +1 upper, -1 lower, 0 inactive; rows [I; Lv]."""
    n, dt = len(x), gs.problem.dt
    tol = gs.solver.active_tol
    rows = np.concatenate((x, np.cumsum(x)))
    lo = np.concatenate((np.full(n, gs.problem.a_min), np.full(n, -v0 / dt)))
    hi = np.concatenate((np.full(n, gs.problem.a_max), np.full(n, (v_cap - v0) / dt)))
    sign = np.zeros(2 * n, dtype=int)
    sign[rows >= hi - tol] = 1
    sign[rows <= lo + tol] = -1
    return sign


@functools.lru_cache(maxsize=8)
def constraint_rows(n: int) -> np.ndarray:
    """The QP's constraint rows [I; Lv] (input box, then cumulative sums for the speeds)."""
    A = np.vstack([np.eye(n), np.tril(np.ones((n, n)))])
    A.setflags(write=False)
    return A


def spd_solve(S: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Solve S X = B for symmetric positive definite S (LAPACK dposv), least squares if singular."""
    _c, X, info = lapack.dposv(S, B)
    if info != 0:
        X = np.linalg.lstsq(S, B, rcond=None)[0]
    return X


class FollowerQP:
    """The follower's QP around (aF, aL) and its affine response x(y) = x0 + K (y - aL).

    KKT system of the QP for the active rows E x = e (rows of A = [I; Lv]) solved with the
    Schur complement S = E H^-1 E^T (H = H_FF is positive definite: it contains the comfort
    term): x = x_u - H^-1 E^T S^-1 (E x_u - e), x_u the unconstrained minimiser.
    """

    def __init__(self, n: int, v0: float, v_cap: float, gs: GameSettings):
        self.n, self.gs = n, gs
        dt = gs.problem.dt
        self.A = constraint_rows(n)
        self.lo, self.hi = np.empty(2 * n), np.empty(2 * n)
        self.lo[:n], self.lo[n:] = gs.problem.a_min, -v0 / dt
        self.hi[:n], self.hi[n:] = gs.problem.a_max, (v_cap - v0) / dt

    def set_model(self, aF, aL, gF, H_FF, H_FL):
        n = self.n
        self.aL = aL
        # [H^-1 | H^-1 H_FL | unconstrained minimiser at y = aL], one factorisation
        rhs = np.empty((n, 2 * n + 1))
        rhs[:, :n] = np.eye(n)
        rhs[:, n:2 * n] = H_FL
        rhs[:, 2 * n] = H_FF @ aF - gF
        X = spd_solve(H_FF, rhs)
        self.Hinv, self.Z, self.xu0 = X[:, :n], X[:, n:2 * n], X[:, 2 * n]
        self.HinvAT = self.Hinv @ self.A.T  # H^-1 A^T, columns for every row of A

    def solve_active(self, sign: np.ndarray, y: np.ndarray, need_K: bool):
        """QP solution at leader plan y, active set ``sign`` (+1 upper, -1 lower, 0 free) refined
        until consistent (multiplier signs, primal feasibility).

        Returns (x, sign, K, lam, Lam): with ``need_K`` also the affine maps of the solution and
        of the active multipliers in y for this active set, x(y') = x + K (y' - y),
        lam(y') = lam + Lam (y' - y); else K = Lam = None.
        """
        n = self.n
        xu = self.xu0 - self.Z @ (y - self.aL)
        sign = sign.copy()
        for _ in range(2 * n):
            act = np.nonzero(sign)[0]
            if act.size:
                E = self.A[act]
                HE = self.HinvAT[:, act]
                b = np.where(sign[act] > 0, self.hi[act], self.lo[act])
                S = E @ HE
                lam = spd_solve(S, E @ xu - b)
                x = xu - HE @ lam
            else:
                lam = np.zeros(0)
                x = xu
            # wrong-sign multiplier: upper bound needs lam >= 0, lower bound lam <= 0
            signed = lam * sign[act]
            Ax = self.A @ x
            viol = np.maximum(Ax - self.hi, self.lo - Ax)
            viol[act] = -np.inf
            if act.size and signed.min() < -1e-10:
                sign[act[int(np.argmin(signed))]] = 0
            elif viol.max() > 1e-9:
                k = int(np.argmax(viol))
                sign[k] = 1 if Ax[k] > self.hi[k] else -1
            else:
                break
        if not need_K:
            return x, sign, None, lam, None
        if act.size:
            W = spd_solve(S, E @ self.Z)
            return x, sign, -(self.Z - HE @ W), lam, -W
        return x, sign, -self.Z, lam, np.zeros((0, n))

    def consistent(self, sign: np.ndarray, x: np.ndarray, lam: np.ndarray) -> bool:
        """Does the active set ``sign`` still hold at (x, lam)?"""
        act = np.nonzero(sign)[0]
        if act.size and (lam * sign[act]).min() < -1e-10:
            return False
        Ax = self.A @ x
        viol = np.maximum(Ax - self.hi, self.lo - Ax)
        viol[act] = -np.inf
        return bool(viol.max() <= 1e-9)
