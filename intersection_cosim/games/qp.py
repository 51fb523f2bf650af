"""The QP of one SQP step: exact when no row is active, else OSQP; one workspace per shape, reused.

Every QP of the game layer has the same shape: N variables (a player's accelerations) and 2N rows

    max(a_min, a0 - Delta) <= x_k <= min(a_max, a0 + Delta)          (input box and trust region)
    -v0 / dt <= sum_{m <= k} x_m <= (v_cap - v0) / dt                 (0 <= v_{k+1} <= v_cap)

with a dense convex P (the Gauss-Newton Hessian). The constraint matrix is constant, so one OSQP
object per (N, slot) is set up once and afterwards only updated (P values, q, l, u) and
warm-started (x given, y kept from the slot's previous solve); it is never rebuilt. ``slot``
separates workspaces whose warm starts should not mix (one per player of a game, one for the
Stackelberg leader). Workspaces live per thread.

Conditioning, chosen on QPs recorded from the solvers (median 15-25 ADMM iterations instead of
55): the row k of the speed constraints is divided by sqrt(k + 1) so all rows have unit norm, the
objective is divided by the mean diagonal of P, and OSQP's own Ruiz scaling is off (it would be
recomputed on every P update). If the new P differs from the slot's current one by less than
``hessian_reuse_tol`` (relative, max norm), the current P is kept: no refactorisation, and the QP
uses that (still convex) model curvature with the exact gradient.

Interior solutions: before OSQP, the model's unconstrained minimiser a - H^-1 g is computed by a
Cholesky solve (compiled, :mod:`intersection_cosim.games.exact_qp`, a few microseconds). If it
meets every row, it is the QP's exact solution (no row active, all multipliers zero) and OSQP is
not called; so it is for two thirds of the QPs of a congested run. Otherwise OSQP solves the QP as above. The exact answer differs
from OSQP's by its tolerance (median 5e-5 m/s^2, at most about 1e-3 m/s^2 on recorded games).

Box solutions: when the unconstrained minimiser breaks a row, a primal-dual active-set method over
the N input-box rows (the trust region and a_min, a_max) looks for the exact solution first: the
broken bounds are fixed, the free entries solved by Cholesky on their block of H, a fixed bound
whose multiplier has the wrong sign released and a free entry outside its box fixed, until the
sets repeat. If the answer then also meets the speed rows (inactive, multipliers zero), it
satisfies the QP's KKT conditions and is its exact solution; otherwise, or after
``qp_box_iter`` passes, OSQP solves the QP. In the jam of ``scripts/bench_scale.py`` (80
vehicles) 86-93 % of the QPs that reached OSQP have such an answer (the trust region binds;
speed rows rarely), found in one to three passes; compiled, a box answer takes about 10 us and
an interior one about 5 us (N = 30), against OSQP's 130-180 us.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np
import osqp
import scipy.sparse as sp

from intersection_cosim.games.exact_qp import BOX, INTERIOR, NOT_FOUND, exact_qp, exact_qps
from intersection_cosim.games.settings import GameSettings

_SOLVED = int(osqp.SolverStatus.OSQP_SOLVED)
_local = threading.local()


@dataclass
class QPSolution:
    x: np.ndarray | None  # [m/s^2] primal solution, None when OSQP did not solve the QP
    y_osqp: np.ndarray | None  # OSQP's duals of the scaled problem
    H: np.ndarray | None  # the Hessian the QP actually used (see hessian reuse)
    status: str  # OSQP status text
    iterations: int  # ADMM iterations
    y_scale: np.ndarray | None = None  # y = y_scale * y_osqp

    @property
    def ok(self) -> bool:
        return self.x is not None

    @property
    def y(self) -> np.ndarray | None:
        """[-] multipliers of the 2N unscaled rows (> 0: upper bound active)."""
        return None if self.y_osqp is None else self.y_scale * self.y_osqp


class QPWorkspace:
    """One OSQP problem of N variables and rows [I; Lv] (module docstring)."""

    def __init__(self, n: int, gs: GameSettings):
        self.n = n
        self.gs = gs
        Lv = np.tril(np.ones((n, n)))
        self.row_scale = np.concatenate((np.ones(n), 1.0 / np.sqrt(np.arange(1, n + 1))))
        self.A_rows = np.vstack([np.eye(n), Lv])  # unscaled rows, for activity tests
        A = sp.csc_matrix(self.A_rows * self.row_scale[:, None])
        pattern = sp.triu(sp.csc_matrix(np.ones((n, n)))).tocsc()
        self._rows = pattern.indices.copy()
        self._cols = np.repeat(np.arange(n), np.diff(pattern.indptr))
        self._flat = self._rows * n + self._cols  # CSC order of the upper triangle in H.ravel()
        H0 = np.eye(n)
        P0 = sp.csc_matrix((H0[self._rows, self._cols], self._rows, pattern.indptr), shape=(n, n))
        self.solver = osqp.OSQP()
        self.solver.setup(P0, np.zeros(n), A, -np.ones(2 * n), np.ones(2 * n), verbose=False,
                          eps_abs=gs.solver.osqp_eps_abs, eps_rel=gs.solver.osqp_eps_rel,
                          max_iter=gs.solver.osqp_max_iter, check_termination=gs.solver.osqp_check_termination,
                          polishing=False, warm_starting=True, scaling=0)
        # the extension object; the public wrapper adds ~50 us of Python per call (constants
        # looked up by import, an info dict rebuilt), too much for a 1 ms budget
        raw = getattr(self.solver, "_solver", None)
        needed = ("update_data_vec", "update_data_mat", "warm_start", "solve", "info", "solution")
        self._raw = raw if all(hasattr(raw, m) for m in needed) else None
        self._no_duals = np.zeros(2 * n)  # the multipliers of an interior solution (read-only)
        self._no_duals.setflags(write=False)
        self.H: np.ndarray | None = None  # P currently installed (unnormalised)
        self._reuse_bound = 0.0
        self._scale = 1.0
        self.solves = 0

    def speed_rows(self, v0, v_cap, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Scaled bounds of the N speed rows for 0 <= v_{k+1} <= v_cap, from v0 [m/s]: (N,) each
        for scalar v0 and v_cap, (m, N) for arrays of m vehicles."""
        rs = self.row_scale[self.n:]
        v0, v_cap = np.asarray(v0, dtype=float)[..., None], np.asarray(v_cap, dtype=float)[..., None]
        return (-v0 / dt) * rs, ((v_cap - v0) / dt) * rs

    def solve(self, H: np.ndarray, g: np.ndarray, a: np.ndarray, l: np.ndarray, u: np.ndarray,
              y0: np.ndarray | None = None, reuse: bool = True, exact: bool = True) -> QPSolution:
        """min 1/2 x^T H x + (g - H a)^T x  s.t.  l <= R [I; Lv] x <= u, warm-started at x = a.

        This is the model g^T (x - a) + 1/2 (x - a)^T H (x - a) of an SQP step. ``l``, ``u`` are
        the bounds of the *scaled* rows (R = diag(row_scale)): the input-box rows are unscaled,
        the speed rows come from :meth:`speed_rows`. ``y0``: multipliers of the unscaled rows to
        warm-start with (e.g. carried by the previous control step's plan); without it OSQP keeps
        the duals of the slot's previous solve. With ``reuse`` the installed P may stand in for H
        (module docstring); the solution reports the H used. A QP whose unconstrained minimiser
        meets every row is answered exactly without OSQP (module docstring, "Interior solutions");
        ``exact=False`` skips that (:meth:`exact_many` has found none).
        """
        _local.solves = getattr(_local, "solves", 0) + 1
        if exact and (answer := self._exact(H, g, a, l, u)) is not None:
            return answer
        Hc = self.H
        if reuse and Hc is not None and (H is Hc or abs(H - Hc).max() <= self._reuse_bound):
            H = Hc
        else:
            Hc = None
            d = float(H.trace()) / self.n
            if not (d > 0.0 and math.isfinite(d)):
                return QPSolution(None, None, None, "invalid Hessian", 0)
            self._scale = 1.0 / d
        scale, rs = self._scale, self.row_scale
        q = scale * (g - H @ a)
        if self._raw is not None:
            raw = self._raw
            err = raw.update_data_vec(q=q, l=l, u=u)
            if not err and Hc is None:
                err = raw.update_data_mat(P_x=scale * H.ravel()[self._flat], P_i=None, A_x=None, A_i=None)
            if err:  # OSQP rejected the data (l > u, non-finite, not quasi-definite)
                self.H = None
                return QPSolution(None, None, None, f"data rejected (OSQP error {err})", 0)
            raw.warm_start(a, None if y0 is None else (scale / rs) * y0)
            raw.solve()
            info, x, y = raw.info, np.array(raw.solution.x), np.array(raw.solution.y)
        else:
            info, x, y = self._solve_public(q, l, u, None if Hc is not None else scale * H.ravel()[self._flat],
                                            a, None if y0 is None else (scale / rs) * y0)
        status_val, iters = int(info.status_val), int(info.iter)
        self.solves += 1
        if Hc is None:
            self.H = H
            # H is positive semidefinite: its largest entry in magnitude is on the diagonal
            self._reuse_bound = self.gs.solver.hessian_reuse_tol * float(H.diagonal().max())
        if status_val != _SOLVED or not math.isfinite(float(x.sum())):
            self.H = None  # do not reuse data of a failed solve
            status = "non-finite solution" if status_val == _SOLVED else str(info.status)
            return QPSolution(None, None, None, status, iters)
        return QPSolution(x, y, H, "solved", iters, rs / scale)

    def exact_many(self, H: np.ndarray, g: np.ndarray, a: np.ndarray, l: np.ndarray,
                   u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`solve`'s exact answers of m QPs at once (H (m, N, N); g, a (m, N); l, u (m, 2N)):
        (found (m,) bool, x (m, N) [m/s^2], y (m, 2N) the multipliers :attr:`QPSolution.y`
        would hold). A QP not found needs :meth:`solve` with ``exact=False``; each found one
        counts as a solve (:func:`solve_count`)."""
        status, x, y = exact_qps(H, g, a, l, u, self.row_scale, self.gs.solver.qp_box_iter)
        found = status != NOT_FOUND
        _local.solves = getattr(_local, "solves", 0) + int(found.sum())
        return found, x, y

    def _solve_public(self, q, l, u, Px, a, y_scaled):
        """OSQP's public interface where the extension object is not reachable: update (P values
        only when ``Px`` is given), warm start at ``a`` (and ``y_scaled``), solve. Returns OSQP's
        info, x and y (scaled problem)."""
        if Px is None:
            self.solver.update(q=q, l=l, u=u)
        else:
            self.solver.update(q=q, l=l, u=u, Px=Px)
        if y_scaled is None:
            self.solver.warm_start(x=a)
        else:
            self.solver.warm_start(x=a, y=y_scaled)
        res = self.solver.solve(raise_error=False)
        return res.info, np.array(res.x), np.array(res.y)

    def _exact(self, H: np.ndarray, g: np.ndarray, a: np.ndarray, l: np.ndarray,
               u: np.ndarray) -> QPSolution | None:
        """The exact solution of :meth:`solve`'s QP when no row is active, x = a - H^-1 g [m/s^2]
        (module docstring, "Interior solutions"), or when only input-box rows are ("Box
        solutions"), by :func:`~intersection_cosim.games.exact_qp.exact_qp`; None when H is not
        positive definite, a number is not finite, or a speed row is active (then OSQP solves it)."""
        status, x, y = exact_qp(H, g, a, l, u, self.row_scale, self.gs.solver.qp_box_iter)
        if status == INTERIOR:  # no row active, all multipliers zero
            return QPSolution(x, self._no_duals, H, "solved", 0, self._no_duals)
        if status == BOX:
            return QPSolution(x, y, H, "solved", 0, self.row_scale)
        return None


def solve_count() -> int:
    """QPs this thread has solved so far (every call of :meth:`QPWorkspace.solve`): a measure of
    a controller's work that, unlike its wall time, does not move with the machine's load."""
    return getattr(_local, "solves", 0)


def reset_workspaces() -> None:
    """Drop this thread's workspaces. OSQP warm-starts from a workspace's last solution, so a
    closed-loop run calls this first: its results then do not depend on what the process
    solved before (two runs of one scenario in one process give identical trajectories)."""
    _local.pool = {}


def workspace(n: int, gs: GameSettings, slot: object = 0) -> QPWorkspace:
    """The thread's workspace for N = ``n`` and ``slot``, created on first use."""
    pool = getattr(_local, "pool", None)
    if pool is None:
        pool = _local.pool = {}
    key = (n, slot, gs.solver.osqp_eps_abs, gs.solver.osqp_eps_rel, gs.solver.osqp_max_iter, gs.solver.osqp_check_termination,
           gs.solver.hessian_reuse_tol, gs.solver.qp_box_iter)
    ws = pool.get(key)
    if ws is None:
        ws = pool[key] = QPWorkspace(n, gs)
    return ws
