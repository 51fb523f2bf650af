"""Open-loop Stackelberg equilibrium of a pair (paper Section IV-D, Eqs. 34-40).

Leader = the player with the smaller time to the conflict point, TCP = (s_cp - s0) / max(v0,
floor) (paper: "the vehicle that has the smaller TCP is the leader"); for a following pair the
vehicle in front; without an interaction, player 0.

The follower answers the leader's plan y with its best response. Around the current point
(aL, aF) the follower's best response is its convexified QP (the model of
:mod:`intersection_cosim.games.objective` in both players' plans):

    min_x  gF^T (x - aF) + (x - aF)^T H_FL (y - aL) + 1/2 (x - aF)^T H_FF (x - aF)
    s.t.   a_min <= x <= a_max,  0 <= v(x) <= v_cap.

For a fixed active set E x = e its KKT system is affine in y, so x(y) = x0 + K (y - aL) and the
active multipliers lam(y) = lam0 + Lam (y - aL) (Eq. 38 with the follower's KKT conditions in
place of its PMP conditions; solved with the Schur complement E H_FF^-1 E^T). Substituted into the
leader's convex model in (y, x) this gives one QP in y, with the reduced Hessian
[I; K]^T H_L [I; K] (convex), solved with OSQP inside the leader's trust region. The active set
is then checked at the new y (x(y) feasible, lam(y) of the right signs); if it changed, the
follower's QP is re-solved at y by an active-set refinement, K rebuilt and the leader's QP solved
again, until the active set settles (at most ``active_set_max_updates`` times).

Acceptance: the step y (then its halves) is first screened with the follower's predicted answer
x(y); for the first promising one the follower re-optimises (``sqp_steps_per_iteration`` SQP
steps of its true best response) and the step is accepted only if the leader's *true* cost at
(y, the follower's answer) fell; else the trust region shrinks (``stackelberg_attempts``
leader QPs per iteration). Converged when the leader's QP step is below ``stackelberg_tol`` or
its model gain below ``stackelberg_gain_rtol`` (relative), or when an accepted step moved less
than ``stackelberg_tol``, or gained less than ``nash_cost_rtol`` while moving less than
``nash_cost_guard`` with the follower settled. The follower is finally polished to a full best
response (``br_max_sqp`` SQP iterations) unless its last answer had already settled.

A cold solve starts at the Nash equilibrium (where the follower is at its best response); the
leader only ever takes cost-reducing steps, and if the follower's final polish still leaves the
leader worse off than at the Nash point, the Nash point is returned (a valid leader-follower
outcome: the follower is at its best response there), with a message saying so.
"""

from __future__ import annotations

import functools
import math
import time

import numpy as np
from scipy.linalg import lapack

from intersection_cosim.games.sqp import SolverFailure, sqp_best_response
from intersection_cosim.games.nash import WarmStart, EquilibriumSolve, warm_list, failure_result, nash_equilibrium
from intersection_cosim.games.problem import GameResult, Plan, Problem
from intersection_cosim.games.qp import workspace
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.models.settings import ModelSettings


def stackelberg_leader(problem: Problem, model_settings: ModelSettings | None = None) -> int:
    """Index of the leader: the smaller TCP to the pair's conflict point (Section IV-D)."""
    ms = model_settings or ModelSettings()
    for it in problem.interactions:
        if it.kind == "following":
            return it.j
        if it.lateral:
            pi, pj = problem.players[it.i], problem.players[it.j]
            tcp_i = (it.s_cp_i - pi.s0) / max(pi.v0, ms.tcp_speed_floor)
            tcp_j = (it.s_cp_j - pj.s0) / max(pj.v0, ms.tcp_speed_floor)
            return it.i if tcp_i <= tcp_j else it.j
    return 0


def _active_set(x: np.ndarray, v0: float, v_cap: float, gs: GameSettings) -> np.ndarray:
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
def _rows(n: int) -> np.ndarray:
    """The QP's constraint rows [I; Lv] (input box, then cumulative sums for the speeds)."""
    A = np.vstack([np.eye(n), np.tril(np.ones((n, n)))])
    A.setflags(write=False)
    return A


def _spd_solve(S: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Solve S X = B for symmetric positive definite S (LAPACK dposv), least squares if singular."""
    _c, X, info = lapack.dposv(S, B)
    if info != 0:
        X = np.linalg.lstsq(S, B, rcond=None)[0]
    return X


class _Follower:
    """The follower's QP around (aF, aL) and its affine response x(y) = x0 + K (y - aL).

    KKT system of the QP for the active rows E x = e (rows of A = [I; Lv]) solved with the
    Schur complement S = E H^-1 E^T (H = H_FF is positive definite: it contains the comfort
    term): x = x_u - H^-1 E^T S^-1 (E x_u - e), x_u the unconstrained minimiser.
    """

    def __init__(self, n: int, v0: float, v_cap: float, gs: GameSettings):
        self.n, self.gs = n, gs
        dt = gs.problem.dt
        self.A = _rows(n)
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
        X = _spd_solve(H_FF, rhs)
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
                lam = _spd_solve(S, E @ xu - b)
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
            W = _spd_solve(S, E @ self.Z)
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


def stackelberg_equilibrium(problem: Problem, settings: GameSettings | None = None,
                            model_settings: ModelSettings | None = None,
                            warm_start: WarmStart = None, deadline: float | None = None,
                            leader: int | None = None, nash: GameResult | None = None) -> GameResult:
    """Open-loop Stackelberg equilibrium of a two-player ``problem`` (Eqs. 34-40).

    ``leader`` overrides the TCP rule (:func:`stackelberg_leader`). ``warm_start``: the previous
    step's plans shifted (:func:`shift_plans`). ``nash``: a Nash result of the same problem to
    start a cold solve from (computed if not given). ``deadline``: ``time.perf_counter()`` value
    for anytime mode. Never raises on numerical trouble: a failure returns comfortable braking
    for both with status "solver failure". Raises ValueError if the problem has not 2 players.
    """
    gs = settings or GameSettings()
    ms = model_settings or ModelSettings()
    t0 = time.perf_counter()
    if problem.n != 2:
        raise ValueError("stackelberg_equilibrium needs exactly two players")
    L = stackelberg_leader(problem, ms) if leader is None else int(leader)
    F = 1 - L
    game = None
    try:
        game = EquilibriumSolve(problem, gs, ms, "stackelberg")
        warm = warm_list(warm_start, 2)
        c_nash = None
        nash_plans = None
        if any(w is None for w in warm):
            if nash is None:
                nash = nash_equilibrium(problem, gs, ms, deadline=deadline)
                game.qp_count += nash.qp_count
            if nash.status == "solver failure":
                raise SolverFailure("Nash start failed: " + nash.message)
            plans = list(nash.plans)
            nash_plans = list(plans)
            c_nash = float(nash.costs[L])
        else:
            plans = [game.warm_plan(p, warm[p]) for p in range(2)]
        f_cost0 = None if c_nash is None else float(nash.costs[F])
        plans, residuals, status, known = _leader_iteration(game, plans, L, F, deadline,
                                                            c_nash is None, f_cost0)
        costs = np.array([known[p] if known[p] is not None else math.nan for p in range(2)])
        if any(k is None for k in known):
            costs = game.costs(plans)
        if c_nash is not None and costs[L] > c_nash + 1e-9 * abs(c_nash):
            plans, costs = nash_plans, game.costs(nash_plans)
            message = "leader no better than at the Nash point: Nash point returned"
        else:
            message = ""
        if not (np.all(np.isfinite(costs)) and all(np.all(np.isfinite(p.positions)) for p in plans)):
            raise SolverFailure("non-finite plan or cost")
        return GameResult(tuple(plans), costs, tuple(residuals), np.zeros((0, 2)), len(residuals),
                          game.qp_count, status, "stackelberg", time.perf_counter() - t0, L, message)
    except (SolverFailure, ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
        return failure_result(problem, gs, "stackelberg", t0, f"{type(exc).__name__}: {exc}",
                              game.qp_count if game else 0, L)


def _leader_iteration(game: EquilibriumSolve, plans: list[Plan], L: int, F: int, deadline, warm: bool,
                      f_cost0: float | None = None):
    """The leader's iteration (module docstring); returns (plans, residuals, status, known
    costs of the final plans, None where not evaluated)."""
    gs = game.gs
    objL, objF = game.objs[L], game.objs[F]
    wsL = workspace(game.N, gs, ("stackelberg-leader", L))
    wsF = game.ws[F]
    n, dt = game.N, gs.problem.dt

    def follower_answer(plans_now, steps, duals=None):
        """The follower's best response (``steps`` SQP steps) and whether it has settled."""
        objF.set_others(plans_now)
        out = sqp_best_response(objF, plans_now[F].accelerations, wsF, gs, steps, duals=duals)
        game.qp_count += out.qp_count
        gain = (out.cost0 - out.cost) / max(abs(out.cost0), 1e-9)
        moved = float(abs(out.a - plans_now[F].accelerations).max())
        settled = out.converged or (gain < gs.solver.nash_cost_rtol and moved < gs.solver.nash_cost_guard)
        return out, settled

    def leader_cost(y, x):
        pair = [None, None]
        pair[L], pair[F] = objL.plan(y), objF.plan(x)
        objL.set_others(pair)
        return float(objL.cost(y))

    # the Nash point has the follower at its best response; a warm start (the previous step's
    # plans, shifted) first lets the follower answer the shifted leader plan
    x_last = plans[F].accelerations
    follower_settled = not warm
    f_cost = f_cost0  # the follower's true cost of the current plans, when known
    if warm:
        out, follower_settled = follower_answer(plans, gs.solver.sqp_steps_per_iteration, plans[F].duals)
        plans[F] = objF.plan(out.a, out.duals)
        x_last = out.x_qp if out.x_qp is not None else out.a
        f_cost = out.cost
    objL.set_others(plans)
    cL = float(objL.cost(plans[L].accelerations))
    follower = _Follower(n, objF.v0, objF.v_cap, gs)
    delta = gs.solver.trust_region
    l, u = np.empty(2 * n), np.empty(2 * n)
    l[n:], u[n:] = wsL.speed_rows(objL.v0, objL.v_cap, dt)
    y_duals = plans[L].duals
    residuals: list[float] = []
    status = "iteration cap"
    per_iteration = 0.0
    for _ in range(gs.solver.stackelberg_max_iter):
        start = time.perf_counter()
        if deadline is not None and start + per_iteration > deadline:
            status = "deadline"
            break
        aL, aF = plans[L].accelerations, plans[F].accelerations
        # follower's model in (aF, aL) and leader's model in (aL, aF)
        objF.set_others(plans)
        gF, _, H_FF, H_FL, _ = objF.pair_model(aF, L, plans[L], partner_curvature=False)
        objL.set_others(plans)
        gL, gLF, H_LL, H_LF, H_FFL = objL.pair_model(aL, F, plans[F])
        follower.set_model(aF, aL, gF, H_FF, H_FL)
        sign = _active_set(x_last, objF.v0, objF.v_cap, gs)
        accepted = None
        for _attempt in range(gs.solver.stackelberg_attempts):
            for _update in range(gs.solver.active_set_max_updates + 1):
                x0, sign_used, K, lam0, Lam = follower.solve_active(sign, aL, need_K=True)
                d0 = x0 - aF
                # leader's reduced model in y: dy -> (dy, d0 + K dy)
                KH = K.T @ H_FFL
                Hr = H_LL + H_LF @ K + K.T @ H_LF.T + KH @ K
                Hr = 0.5 * (Hr + Hr.T)
                gr = gL + K.T @ gLF + (H_LF + KH) @ d0
                np.maximum(aL - delta, gs.problem.a_min, out=l[:n])
                np.minimum(aL + delta, gs.problem.a_max, out=u[:n])
                sol = wsL.solve(Hr, gr, aL, l, u, y0=y_duals)
                y_duals = None
                game.qp_count += 1
                if not sol.ok:
                    raise SolverFailure(f"OSQP (leader): {sol.status}")
                y = np.minimum(np.maximum(sol.x, gs.problem.a_min), gs.problem.a_max)
                # the follower's QP at the new leader plan: does the active set still hold?
                dy = y - aL
                x_y = x0 + K @ dy
                if follower.consistent(sign_used, x_y, lam0 + Lam @ dy):
                    break
                x_y, sign, _K, _lam, _Lam = follower.solve_active(sign_used, y, need_K=False)
            step = float(abs(y - aL).max())
            dy = y - aL
            pred = -float(gr @ dy + 0.5 * (dy @ sol.H @ dy))  # model decrease of the leader
            if step < gs.solver.stackelberg_tol or pred < gs.solver.stackelberg_gain_rtol * abs(cL):
                break  # the leader's best step is below tolerance or gains too little: settled
            # cheap pre-check along the step with the follower's predicted answer (its QP by
            # KKT): full step, then halves; the follower's true answer only for a promising one
            for alpha in (1.0, 0.5, 0.25)[:1 + gs.solver.line_search_steps]:
                y_a = y if alpha == 1.0 else aL + alpha * (y - aL)
                x_a = x_y if alpha == 1.0 else np.clip(x0 + alpha * (x_y - x0), gs.problem.a_min, gs.problem.a_max)
                if leader_cost(y_a, x_a) < cL:
                    break
            else:
                alpha = 0.0
            if alpha > 0.0:
                trial = list(plans)
                trial[L] = objL.plan(y_a, sol.y)
                out, settled = follower_answer(trial, gs.solver.sqp_steps_per_iteration)
                trial[F] = objF.plan(out.a, out.duals)
                objL.set_others(trial)
                c_new = float(objL.cost(y_a))
                if not math.isfinite(c_new):
                    raise SolverFailure("non-finite leader cost")
                if c_new < cL:
                    accepted = (trial, c_new, settled, out, alpha * step)
                    break
            delta = 0.25 * min(delta, step)
            if delta < gs.solver.trust_region_min:
                break
        if accepted is None:
            residuals.append(0.0)
            status = "converged"
            break
        trial, c_new, follower_settled, out, step = accepted
        f_cost = out.cost
        res = max(step, float(abs(out.a - aF).max()))
        gain = (cL - c_new) / max(abs(cL), 1e-9)
        plans, cL = trial, c_new
        x_last = out.x_qp if out.x_qp is not None else out.a
        if step > 0.9 * delta:
            delta = min(2.0 * delta, gs.solver.trust_region_max)
        residuals.append(res)
        per_iteration = max(per_iteration, time.perf_counter() - start)
        if res < gs.solver.stackelberg_tol or (res < gs.solver.nash_cost_guard and gain < gs.solver.nash_cost_rtol
                                        and follower_settled):
            status = "converged"
            break
    known = [None, None]  # true costs of the final plans where already evaluated
    known[L], known[F] = cL, f_cost
    if not follower_settled:  # polish the follower to a full best response
        out, _ = follower_answer(plans, gs.solver.br_max_sqp)
        plans[F] = objF.plan(out.a, out.duals)
        known[L], known[F] = None, out.cost
    return plans, residuals, status, known
