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
[I; K]^T H_L [I; K] (convex), solved inside the leader's trust region (exactly when no bound is
active, else with OSQP: :mod:`intersection_cosim.games.qp`). The active set is then checked at
the new y (x(y) feasible, lam(y) of the right signs); if it changed, the follower's QP is
re-solved at y by an active-set refinement, K rebuilt and the leader's QP solved again, until the
active set settles (at most ``active_set_max_updates`` times).

Acceptance: the step y (then its halves) is first screened with the follower's predicted answer
x(y); for the first promising one the follower re-optimises (``sqp_steps_per_iteration`` SQP
steps of its true best response) and the step is accepted only if the leader's *true* cost at
(y, the follower's answer) fell; else the trust region shrinks (``stackelberg_attempts``
leader QPs per iteration). Converged when the leader's QP step is below ``stackelberg_tol`` or
its model gain below ``stackelberg_gain_rtol`` (relative), or when an accepted step moved less
than ``stackelberg_tol``, or gained less than ``nash_cost_rtol`` while moving less than
``nash_cost_guard`` with the follower settled. The follower is finally polished to a full best
response (``br_max_sqp`` SQP iterations) unless its last answer had already settled or the
deadline stopped the iteration: past the deadline, as in :func:`nash_equilibrium`, no further QP
is solved (a warm start is returned as it is, the follower's last answer as it stands). With
``polish_follower`` off an unsettled follower keeps its last answer too, and the solve counts as
not converged ("iteration cap"): a real-time iteration's step, which the next control step
continues.

A cold solve starts at the Nash equilibrium (where the follower is at its best response); the
leader only ever takes cost-reducing steps, and if the follower's final polish still leaves the
leader worse off than at the Nash point, the Nash point is returned (a valid leader-follower
outcome: the follower is at its best response there), with a message saying so.
"""

from __future__ import annotations

import math
import time

from typing import NamedTuple

import numpy as np

from intersection_cosim.games import budget_clock
from intersection_cosim.games.follower_qp import FollowerQP, active_set
from intersection_cosim.games.sqp import SolverFailure, sqp_best_response
from intersection_cosim.games.nash import EquilibriumSolve, WarmStart, failure_result, nash_equilibrium, warm_list
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


def stackelberg_equilibrium(problem: Problem, settings: GameSettings | None = None,
                            model_settings: ModelSettings | None = None,
                            warm_start: WarmStart = None, deadline: float | None = None,
                            leader: int | None = None, nash: GameResult | None = None) -> GameResult:
    """Open-loop Stackelberg equilibrium of a two-player ``problem`` (Eqs. 34-40).

    ``leader`` overrides the TCP rule (:func:`stackelberg_leader`). ``warm_start``: the previous
    step's plans shifted (:func:`shift_plans`). ``nash``: a Nash result of the same problem to
    start a cold solve from (computed if not given). ``deadline``: :func:`budget_clock.now` value
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


class _LeaderStep(NamedTuple):
    """The leader's QP step with the follower's affine answer to it."""

    y: np.ndarray  # [m/s^2] the leader's new plan
    x0: np.ndarray  # [m/s^2] the follower's answer at the current leader plan
    x_y: np.ndarray  # [m/s^2] the follower's predicted answer at y
    gr: np.ndarray  # gradient of the leader's reduced model
    sol: object  # OSQP's solution of the leader's QP
    sign: np.ndarray  # the follower's active set to start the next attempt from


class _Accepted(NamedTuple):
    plans: list  # the new plans of both players
    cost: float  # [-] the leader's true cost of them
    follower_settled: bool
    follower: object  # the follower's SQPOutcome
    step: float  # [m/s^2] the accepted leader step


class _LeaderIteration:
    """The leader's iteration (module docstring) for leader ``L`` and follower ``F`` of ``game``."""

    def __init__(self, game: EquilibriumSolve, L: int, F: int):
        self.game, self.gs, self.L, self.F = game, game.gs, L, F
        self.objL, self.objF = game.objs[L], game.objs[F]
        self.wsL = workspace(game.N, self.gs, ("stackelberg-leader", L))
        self.wsF = game.ws[F]
        self.n = game.N
        self.y_duals = None  # multipliers that warm-start the first leader QP only

    def follower_answer(self, plans_now, steps, duals=None):
        """The follower's best response (``steps`` SQP steps) and whether it has settled."""
        sv, objF = self.gs.solver, self.objF
        objF.set_others(plans_now)
        out = sqp_best_response(objF, plans_now[self.F].accelerations, self.wsF, self.gs, steps, duals=duals)
        self.game.qp_count += out.qp_count
        gain = (out.cost0 - out.cost) / max(abs(out.cost0), 1e-9)
        moved = float(abs(out.a - plans_now[self.F].accelerations).max())
        return out, out.converged or (gain < sv.nash_cost_rtol and moved < sv.nash_cost_guard)

    def leader_cost(self, y, x) -> float:
        pair = [None, None]
        pair[self.L], pair[self.F] = self.objL.plan(y), self.objF.plan(x)
        self.objL.set_others(pair)
        return float(self.objL.cost(y))

    def models(self, plans, follower: FollowerQP):
        """The follower's model in (aF, aL) into ``follower``; the leader's in (aL, aF)."""
        aL, aF = plans[self.L].accelerations, plans[self.F].accelerations
        self.objF.set_others(plans)
        gF, _, H_FF, H_FL, _ = self.objF.pair_model(aF, self.L, plans[self.L], partner_curvature=False)
        self.objL.set_others(plans)
        gL, gLF, H_LL, H_LF, H_FFL = self.objL.pair_model(aL, self.F, plans[self.F])
        follower.set_model(aF, aL, gF, H_FF, H_FL)
        return gL, gLF, H_LL, H_LF, H_FFL

    def leader_qp(self, follower: FollowerQP, sign, aL, aF, model, delta: float, box) -> _LeaderStep:
        """The leader's QP on its reduced model dy -> (dy, d0 + K dy), re-solved while the
        follower's active set at the new leader plan differs from the assumed one."""
        gs, n = self.gs, self.n
        gL, gLF, H_LL, H_LF, H_FFL = model
        l, u = box
        for _update in range(gs.solver.active_set_max_updates + 1):
            x0, sign_used, K, lam0, Lam = follower.solve_active(sign, aL, need_K=True)
            d0 = x0 - aF
            KH = K.T @ H_FFL
            Hr = H_LL + H_LF @ K + K.T @ H_LF.T + KH @ K
            Hr = 0.5 * (Hr + Hr.T)
            gr = gL + K.T @ gLF + (H_LF + KH) @ d0
            np.maximum(aL - delta, self.objL.gs.problem.a_min, out=l[:n])
            np.minimum(aL + delta, self.objL.gs.problem.a_max, out=u[:n])
            sol = self.wsL.solve(Hr, gr, aL, l, u, y0=self.y_duals)
            self.y_duals = None
            self.game.qp_count += 1
            if not sol.ok:
                raise SolverFailure(f"OSQP (leader): {sol.status}")
            y = np.minimum(np.maximum(sol.x, self.objL.gs.problem.a_min), self.objL.gs.problem.a_max)
            # the follower's QP at the new leader plan: does the active set still hold?
            dy = y - aL
            x_y = x0 + K @ dy
            if follower.consistent(sign_used, x_y, lam0 + Lam @ dy):
                break
            x_y, sign, _K, _lam, _Lam = follower.solve_active(sign_used, y, need_K=False)
        return _LeaderStep(y, x0, x_y, gr, sol, sign)

    def try_step(self, plans, cL: float, qp: _LeaderStep, aL, step: float) -> _Accepted | None:
        """The leader's step, or the first of its halves, that lowers its true cost with the
        follower's true answer; a cheap pre-check with the follower's predicted answer (its QP
        by KKT) first, so the follower solves only for a promising step."""
        gs = self.gs
        for alpha in (1.0, 0.5, 0.25)[:1 + gs.solver.line_search_steps]:
            y_a = qp.y if alpha == 1.0 else aL + alpha * (qp.y - aL)
            x_a = qp.x_y if alpha == 1.0 else np.clip(qp.x0 + alpha * (qp.x_y - qp.x0), self.objF.gs.problem.a_min,
                                                      self.objF.gs.problem.a_max)
            if self.leader_cost(y_a, x_a) < cL:
                break
        else:
            return None
        trial = list(plans)
        trial[self.L] = self.objL.plan(y_a, qp.sol.y)
        out, settled = self.follower_answer(trial, gs.solver.sqp_steps_per_iteration)
        trial[self.F] = self.objF.plan(out.a, out.duals)
        self.objL.set_others(trial)
        c_new = float(self.objL.cost(y_a))
        if not math.isfinite(c_new):
            raise SolverFailure("non-finite leader cost")
        return _Accepted(trial, c_new, settled, out, alpha * step) if c_new < cL else None

    def iterate(self, plans, cL: float, follower: FollowerQP, x_last, delta: float, box):
        """One leader iteration: (accepted step or None when the leader has settled, delta)."""
        gs = self.gs
        aL, aF = plans[self.L].accelerations, plans[self.F].accelerations
        model = self.models(plans, follower)
        sign = active_set(x_last, self.objF.v0, self.objF.v_cap, self.objF.gs)
        for _attempt in range(gs.solver.stackelberg_attempts):
            qp = self.leader_qp(follower, sign, aL, aF, model, delta, box)
            sign = qp.sign
            dy = qp.y - aL
            step = float(abs(dy).max())
            pred = -float(qp.gr @ dy + 0.5 * (dy @ qp.sol.H @ dy))  # model decrease of the leader
            if step < gs.solver.stackelberg_tol or pred < gs.solver.stackelberg_gain_rtol * abs(cL):
                return None, delta  # the leader's best step is below tolerance or gains too little
            accepted = self.try_step(plans, cL, qp, aL, step)
            if accepted is not None:
                return accepted, delta
            delta = 0.25 * min(delta, step)
            if delta < gs.solver.trust_region_min:
                break
        return None, delta


def _leader_iteration(game: EquilibriumSolve, plans: list[Plan], L: int, F: int, deadline, warm: bool,
                      f_cost0: float | None = None):
    """The leader's iteration (module docstring); returns (plans, residuals, status, known
    costs of the final plans, None where not evaluated)."""
    it = _LeaderIteration(game, L, F)
    gs, sv, n = game.gs, game.gs.solver, game.N
    # the Nash point has the follower at its best response; a warm start (the previous step's
    # plans, shifted) first lets the follower answer the shifted leader plan
    x_last, follower_settled, f_cost = plans[F].accelerations, not warm, f_cost0
    if warm and not (deadline is not None and budget_clock.now() >= deadline):
        out, follower_settled = it.follower_answer(plans, sv.sqp_steps_per_iteration, plans[F].duals)
        plans[F] = it.objF.plan(out.a, out.duals)
        x_last = out.x_qp if out.x_qp is not None else out.a
        f_cost = out.cost
    it.objL.set_others(plans)
    cL = float(it.objL.cost(plans[L].accelerations))
    follower = FollowerQP(n, it.objF.v0, it.objF.v_cap, it.objF.gs)
    delta = sv.trust_region
    l, u = np.empty(2 * n), np.empty(2 * n)
    l[n:], u[n:] = it.wsL.speed_rows(it.objL.v0, it.objL.v_cap, gs.problem.dt)
    it.y_duals = plans[L].duals
    residuals: list[float] = []
    status, per_iteration = "iteration cap", 0.0  # [s] the slowest iteration so far
    for _ in range(sv.stackelberg_max_iter):
        start = budget_clock.now()
        if deadline is not None and start + per_iteration > deadline:
            status = "deadline"
            break
        aF = plans[F].accelerations
        accepted, delta = it.iterate(plans, cL, follower, x_last, delta, (l, u))
        if accepted is None:
            residuals.append(0.0)
            status = "converged"
            break
        out, step, follower_settled = accepted.follower, accepted.step, accepted.follower_settled
        f_cost = out.cost
        res = max(step, float(abs(out.a - aF).max()))
        gain = (cL - accepted.cost) / max(abs(cL), 1e-9)
        plans, cL = accepted.plans, accepted.cost
        x_last = out.x_qp if out.x_qp is not None else out.a
        if step > 0.9 * delta:
            delta = min(2.0 * delta, sv.trust_region_max)
        residuals.append(res)
        per_iteration = max(per_iteration, budget_clock.now() - start)
        if res < sv.stackelberg_tol or (res < sv.nash_cost_guard and gain < sv.nash_cost_rtol and follower_settled):
            status = "converged"
            break
    settled = follower_settled or status == "deadline"
    if not (settled or sv.polish_follower):  # a real-time step: the follower goes on next time
        settled, status = True, "iteration cap"
    plans, known = _polish(it, plans, cL, f_cost, settled)
    return plans, residuals, status, known


def _polish(it: _LeaderIteration, plans, cL: float, f_cost, follower_settled: bool):
    """The final plans and their known costs; an unsettled follower is first polished to a full
    best response."""
    known = [None, None]  # true costs of the final plans where already evaluated
    known[it.L], known[it.F] = cL, f_cost
    if not follower_settled:
        out, _ = it.follower_answer(plans, it.gs.solver.br_max_sqp)
        plans[it.F] = it.objF.plan(out.a, out.duals)
        known[it.L], known[it.F] = None, out.cost
    return plans, known
