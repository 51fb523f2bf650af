"""Best response of one player (Eq. 25, one row): sequential QP on the true cost.

Given the other players' planned trajectories, player i's accelerations a (N,) minimise its true
cost C_i(a) (see :mod:`intersection_cosim.games.objective`) subject to a_min <= a <= a_max and
0 <= v <= v_cap. Each SQP iteration

1. builds the convex model of C_i at the iterate a (exact slope, Gauss-Newton curvature),
2. solves the QP of that model inside the trust region |x - a| <= Delta with OSQP (the workspace
   of :mod:`intersection_cosim.games.qp`, updated and warm-started at a) and projects its
   solution onto the exact constraints (ADMM meets them only to its tolerance),
3. accepts a + alpha (x - a) for the first alpha in 1, 1/2, 1/4, ... that lowers the *true* cost
   by at least ``armijo * alpha *`` the model decrease; if none does, Delta shrinks and the QP is
   solved again with the same P (only the bounds change).

Delta doubles after a full step that used the whole region with a good model fit and halves after a
poor fit. The iteration stops when the accepted step is below ``br_step_tol``, when the model
predicts a decrease below ``br_rel_decrease_tol * |C|``, or when Delta falls below
``trust_region_min`` (no further decrease found). So the true cost falls at every accepted step.
If the player has no active coupling term the model is exact and one QP over the whole box gives
the optimum. A start plan that overlaps a leader is first moved behind it (see
:meth:`PlayerObjective.keep_behind`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Mapping, NamedTuple, Sequence

import numpy as np

from intersection_cosim.games.objective import PlayerObjective
from intersection_cosim.games.problem import (Plan, Problem, hold_plan, project_accelerations,
                                              safe_plan)
from intersection_cosim.games.qp import QPWorkspace, workspace
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.models.settings import ModelSettings


class SolverFailure(Exception):
    """Internal: a QP was not solved or a number went non-finite. Never leaves the package."""


@dataclass(frozen=True)
class BestResponseResult:
    plan: Plan
    cost: float  # [-] true cost of the plan against the given plans of the others
    status: str  # "converged", "iteration cap" or "solver failure"
    sqp_iterations: int
    qp_count: int
    message: str = ""


@dataclass
class SQPOutcome:
    a: np.ndarray  # [m/s^2]
    cost: float  # [-]
    iterations: int
    qp_count: int
    converged: bool
    trust_region: float  # [m/s^2] radius to start the next call with
    duals: np.ndarray | None  # [-] row multipliers of the last solved QP
    hessian: tuple[np.ndarray, np.ndarray] | None  # (H, a where computed) of the last fresh model
    x_qp: np.ndarray | None = None  # [m/s^2] solution of the last QP (for active sets)
    cost0: float = math.nan  # [-] true cost at the start plan (after keep_behind)


class _Box(NamedTuple):
    """The QP's bounds: rows 0..N-1 the accelerations (rewritten per trust region), N..2N-1 the
    speed rows; ``sum_lo``, ``sum_hi`` [m/s^2] bound sum(a) so that 0 <= v <= v_cap."""

    l: np.ndarray
    u: np.ndarray
    sum_lo: float
    sum_hi: float


class _Region(NamedTuple):
    """One trust-region step's outcome (the inner loop of an SQP iteration)."""

    a: np.ndarray  # [m/s^2] the iterate after the step (unchanged if none was accepted)
    cost: float  # [-] its true cost
    delta: float  # [m/s^2] the radius to go on with
    converged: bool
    qps: int  # QPs solved
    sol: object  # OSQP's last solution
    x_qp: np.ndarray  # [m/s^2] its plan, projected onto the feasible set


def sqp_best_response(obj: PlayerObjective, a0: np.ndarray, ws: QPWorkspace, gs: GameSettings,
                      max_iter: int, trust_region: float | None = None,
                      duals: np.ndarray | None = None,
                      hessian: np.ndarray | None = None, own_hessian: bool = False) -> SQPOutcome:
    """Run at most ``max_iter`` SQP iterations from the feasible ``a0`` (module docstring).

    ``hessian``: a model Hessian computed near ``a0`` to use in the first iteration instead of
    a fresh one (the gradient is always exact; the caller decides when the curvature is still
    representative, see ``SolverSettings.hessian_refresh``). Raises :class:`SolverFailure` when
    OSQP does not solve a QP or a value is not finite. A player with limits of its own
    (``obj.limited``) plans within them. ``own_hessian``: every QP installs this model's Hessian
    (the workspace never keeps the one installed before, within ``hessian_reuse_tol``; as
    :mod:`~intersection_cosim.games.solo_batch` does).
    """
    if obj.limited:
        gs = dataclasses.replace(gs, problem=obj.gs.problem)
    a = obj.keep_behind(np.array(a0, dtype=float))
    fresh = None
    if hessian is None or not obj.coupled:
        c, g, H = obj.cost_and_model(a)
        fresh = (H, a)
    else:
        (c, g), H = obj.cost_and_gradient(a), hessian
    if not math.isfinite(c):
        raise SolverFailure("non-finite cost at the start")
    c_start = c
    exact = not obj.coupled
    delta = gs.solver.trust_region_max if exact else (trust_region or gs.solver.trust_region)
    box = _box(obj, ws)
    qp, it, converged, y, x_qp = 0, 0, False, duals, None
    while it < max_iter:
        it += 1
        if it > 1:
            g, H = obj.model(a)
            fresh = (H, a)
        region = _trust_region_step(obj, ws, gs, box, a, c, g, H, delta, duals, exact, not own_hessian)
        duals = None
        a, c, delta, converged = region.a, region.cost, region.delta, region.converged
        qp, y, x_qp = qp + region.qps, region.sol, region.x_qp
        if converged:
            break
    if y is not None and not isinstance(y, np.ndarray):
        y = y.y  # multipliers of the last QP (converted only once)
    return SQPOutcome(a, c, it, qp, converged, delta, y, fresh, x_qp, c_start)


def _box(obj: PlayerObjective, ws: QPWorkspace) -> _Box:
    n, dt = obj.n, obj.dt
    l, u = np.empty(2 * n), np.empty(2 * n)
    l[n:], u[n:] = ws.speed_rows(obj.v0, obj.v_cap, dt)
    return _Box(l, u, -obj.v0 / dt, (obj.v_cap - obj.v0) / dt)


def _solve_qp(obj: PlayerObjective, ws: QPWorkspace, gs: GameSettings, box: _Box, a: np.ndarray, g, H,
              delta: float, duals, reuse: bool = True):
    """OSQP's solution of the model QP inside |x - a| <= ``delta``, and its plan projected onto
    the exact feasible set (ADMM solutions violate bounds by up to ~eps); ``reuse``: the
    workspace may keep its installed Hessian (:meth:`QPWorkspace.solve`)."""
    n = obj.n
    a_min, a_max = gs.problem.a_min, gs.problem.a_max
    np.maximum(a - delta, a_min, out=box.l[:n])
    np.minimum(a + delta, a_max, out=box.u[:n])
    sol = ws.solve(H, g, a, box.l, box.u, y0=duals, reuse=reuse)
    if not sol.ok:
        raise SolverFailure(f"OSQP: {sol.status}")
    x_qp = sol.x
    np.maximum(x_qp, a_min, out=x_qp)
    np.minimum(x_qp, a_max, out=x_qp)
    cs = x_qp.cumsum()
    if cs.min() < box.sum_lo or cs.max() > box.sum_hi:
        x_qp = project_accelerations(x_qp, obj.v0, obj.v_cap, gs)
    return sol, x_qp


def _trust_region_step(obj: PlayerObjective, ws: QPWorkspace, gs: GameSettings, box: _Box, a: np.ndarray,
                       c: float, g, H, delta: float, duals, exact: bool, reuse: bool = True) -> _Region:
    """Solve the model QP, shrinking the region until a step lowers the true cost enough, the
    model is stationary, or the region falls below ``trust_region_min``."""
    sv = gs.solver
    qps = 0
    while True:
        sol, x_qp = _solve_qp(obj, ws, gs, box, a, g, H, delta, duals, reuse)
        qps += 1
        duals = None
        d = x_qp - a
        step = float(abs(d).max())
        pred = -float(g @ d + 0.5 * (d @ sol.H @ d))
        if step < sv.br_step_tol or pred <= sv.br_rel_decrease_tol * max(abs(c), 1e-9):
            # stationary for the model: keep the tiny step only if it does not raise the cost
            if step > 0.0:
                c_new = float(obj.cost(x_qp))
                if c_new <= c:
                    a, c = x_qp, c_new
            return _Region(a, c, delta, True, qps, sol, x_qp)
        alpha, c_new = _line_search(obj, gs, a, c, d, pred, x_qp, exact)
        if alpha > 0.0:
            delta = new_radius(sv, delta, alpha, step, (c - c_new) / pred)
            a = x_qp if alpha == 1.0 else a + alpha * d
            return _Region(a, c_new, delta, exact or alpha * step < sv.br_step_tol, qps, sol, x_qp)
        if exact:  # the exact model's optimum does not lower the cost: a is optimal
            return _Region(a, c, delta, True, qps, sol, x_qp)
        delta = 0.25 * min(delta, step)
        if delta < sv.trust_region_min:  # no decrease in any region: a local minimum to tolerance
            return _Region(a, c, delta, True, qps, sol, x_qp)


def _line_search(obj: PlayerObjective, gs: GameSettings, a: np.ndarray, c: float, d: np.ndarray, pred: float,
                 x_qp: np.ndarray, exact: bool) -> tuple[float, float]:
    """(alpha, true cost at a + alpha d): the full step if it meets Armijo's condition, else the
    first halving that does; alpha = 0 when none does."""
    sv = gs.solver
    c_new = float(obj.cost(x_qp))
    if not math.isfinite(c_new):
        raise SolverFailure("non-finite cost")
    if c_new <= c - sv.armijo * pred:
        return 1.0, c_new
    if sv.line_search_steps > 0 and not exact:
        alphas = 0.5 ** np.arange(1, sv.line_search_steps + 1)
        trial = obj.cost(a[None, :] + alphas[:, None] * d[None, :])
        ok = np.nonzero(trial <= c - sv.armijo * alphas * pred)[0]
        if ok.size:
            return float(alphas[ok[0]]), float(trial[ok[0]])
    return 0.0, c_new


def new_radius(sv, delta: float, alpha: float, step: float, ratio: float) -> float:
    """[m/s^2] the trust region after an accepted step of ``alpha`` and size ``step`` whose true
    decrease is ``ratio`` times the predicted one."""
    if alpha < 1.0:
        return max(alpha * step, sv.trust_region_min)
    if ratio > 0.75 and step > 0.9 * delta:
        return min(2.0 * delta, sv.trust_region_max)
    if ratio < 0.25:
        return max(0.5 * delta, sv.trust_region_min)
    return delta


def _others(problem: Problem, p: int, others_plans, gs: GameSettings) -> list[Plan]:
    """Plans of all players; players without a given plan keep their speed (zero acceleration)."""
    out = []
    for q, player in enumerate(problem.players):
        plan = None
        if q != p:
            if isinstance(others_plans, Mapping):
                plan = others_plans.get(q)
            elif others_plans is not None and q < len(others_plans):
                plan = others_plans[q]
        out.append(plan if plan is not None else hold_plan(player, gs))
    return out


def initial_accelerations(obj: PlayerObjective, warm, gs: GameSettings) -> np.ndarray:
    """[m/s^2] a feasible starting plan: ``warm`` (Plan or accelerations) projected, else zeros."""
    if warm is None:
        a = np.zeros(obj.n)
    else:
        a = np.asarray(warm.accelerations if isinstance(warm, Plan) else warm, dtype=float)
        if a.shape != (obj.n,):
            a = np.resize(a, obj.n) if a.size else np.zeros(obj.n)
    return project_accelerations(a, obj.v0, obj.v_cap, dataclasses.replace(gs, problem=obj.gs.problem) if obj.limited else gs)


def best_response(problem: Problem, player_index: int,
                  others_plans: Sequence[Plan | None] | Mapping[int, Plan] | None = None,
                  settings: GameSettings | None = None, model_settings: ModelSettings | None = None,
                  warm: Plan | np.ndarray | None = None) -> BestResponseResult:
    """Player ``player_index``'s best response to the others' plans (Eq. 25, one row).

    ``others_plans[q]`` is player q's Plan (a sequence indexed by player, or a mapping); the entry
    of the player itself is ignored and players without a plan are predicted at constant speed.
    Without interactions (or with ``model_settings.k_lat = 0`` and no leader) this is the player's
    own optimal control: a single QP. Never raises on numerical trouble: a failure returns the
    comfortable-braking plan with status "solver failure".
    """
    gs = settings or GameSettings()
    ms = model_settings or ModelSettings()
    p = player_index
    try:
        bad = problem.validate()
        if not 0 <= p < problem.n:
            bad.append(f"player index {p} out of range")
        if bad:
            raise SolverFailure("; ".join(bad))
        plans = _others(problem, p, others_plans, gs)
        for q in range(problem.n):
            if q != p and not (np.isfinite(plans[q].speeds).all() and np.isfinite(plans[q].positions).all()):
                raise SolverFailure(f"plan of player {q} is not finite")
        obj = PlayerObjective(problem, p, gs, ms)
        obj.set_others(plans)
        a0 = initial_accelerations(obj, warm, gs)
        out = sqp_best_response(obj, a0, workspace(obj.n, gs, ("br", p)), gs, gs.solver.br_max_sqp)
        plan = Plan.from_accelerations(obj.s0, obj.v0, out.a, gs.problem.dt)
        if not (math.isfinite(out.cost) and np.all(np.isfinite(plan.positions))):
            raise SolverFailure("non-finite plan")
        return BestResponseResult(plan, out.cost, "converged" if out.converged else "iteration cap",
                                  out.iterations, out.qp_count)
    except (SolverFailure, ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
        player = problem.players[p] if 0 <= p < problem.n else problem.players[0]
        return BestResponseResult(safe_plan(player, gs), math.nan, "solver failure", 0, 0, str(exc))
