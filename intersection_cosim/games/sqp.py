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

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

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


def sqp_best_response(obj: PlayerObjective, a0: np.ndarray, ws: QPWorkspace, gs: GameSettings,
                      max_iter: int, trust_region: float | None = None,
                      duals: np.ndarray | None = None,
                      hessian: np.ndarray | None = None) -> SQPOutcome:
    """Run at most ``max_iter`` SQP iterations from the feasible ``a0`` (module docstring).

    ``hessian``: a model Hessian computed near ``a0`` to use in the first iteration instead of
    a fresh one (the gradient is always exact; the caller decides when the curvature is still
    representative, see ``GameSettings.hessian_refresh``). Raises :class:`SolverFailure` when
    OSQP does not solve a QP or a value is not finite.
    """
    n, dt = obj.n, obj.dt
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
    l, u = np.empty(2 * n), np.empty(2 * n)
    l[n:], u[n:] = ws.speed_rows(obj.v0, obj.v_cap, dt)
    lo, hi = l[:n], u[:n]
    a_min, a_max = gs.problem.a_min, gs.problem.a_max
    sum_lo, sum_hi = -obj.v0 / dt, (obj.v_cap - obj.v0) / dt  # bounds of sum(a) for 0 <= v <= v_cap
    qp = 0
    it = 0
    converged = False
    y = duals
    x_qp = None
    while it < max_iter:
        it += 1
        if it > 1:
            g, H = obj.model(a)
            fresh = (H, a)
        while True:
            np.maximum(a - delta, a_min, out=lo)
            np.minimum(a + delta, a_max, out=hi)
            sol = ws.solve(H, g, a, l, u, y0=duals)
            qp += 1
            if not sol.ok:
                raise SolverFailure(f"OSQP: {sol.status}")
            duals = None
            y = sol
            # ADMM solutions violate bounds by up to ~eps: project onto the exact feasible set
            x_qp = sol.x
            np.maximum(x_qp, a_min, out=x_qp)
            np.minimum(x_qp, a_max, out=x_qp)
            cs = x_qp.cumsum()
            if cs.min() < sum_lo or cs.max() > sum_hi:
                x_qp = project_accelerations(x_qp, obj.v0, obj.v_cap, gs)
            d = x_qp - a
            step = float(abs(d).max())
            pred = -float(g @ d + 0.5 * (d @ sol.H @ d))
            if step < gs.solver.br_step_tol or pred <= gs.solver.br_rel_decrease_tol * max(abs(c), 1e-9):
                # stationary for the model: keep the tiny step only if it does not raise the cost
                if step > 0.0:
                    c_new = float(obj.cost(x_qp))
                    if c_new <= c:
                        a, c = x_qp, c_new
                converged = True
                break
            c_new = float(obj.cost(x_qp))
            if not math.isfinite(c_new):
                raise SolverFailure("non-finite cost")
            alpha = 1.0
            if c_new > c - gs.solver.armijo * pred:
                alpha = 0.0
                if gs.solver.line_search_steps > 0 and not exact:
                    alphas = 0.5 ** np.arange(1, gs.solver.line_search_steps + 1)
                    trial = obj.cost(a[None, :] + alphas[:, None] * d[None, :])
                    ok = np.nonzero(trial <= c - gs.solver.armijo * alphas * pred)[0]
                    if ok.size:
                        alpha, c_new = float(alphas[ok[0]]), float(trial[ok[0]])
            if alpha > 0.0:
                ratio = (c - c_new) / pred
                a = x_qp if alpha == 1.0 else a + alpha * d
                c = c_new
                if alpha < 1.0:
                    delta = max(alpha * step, gs.solver.trust_region_min)
                elif ratio > 0.75 and step > 0.9 * delta:
                    delta = min(2.0 * delta, gs.solver.trust_region_max)
                elif ratio < 0.25:
                    delta = max(0.5 * delta, gs.solver.trust_region_min)
                if exact or alpha * step < gs.solver.br_step_tol:
                    converged = True
                break
            if exact:  # the exact model's optimum does not lower the cost: a is optimal
                converged = True
                break
            delta = 0.25 * min(delta, step)
            if delta < gs.solver.trust_region_min:
                converged = True  # no decrease in any region: a local minimum to tolerance
                break
        if converged:
            break
    if y is not None and not isinstance(y, np.ndarray):
        y = y.y  # multipliers of the last QP (converted only once)
    return SQPOutcome(a, c, it, qp, converged, delta, y, fresh, x_qp, c_start)


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
    return project_accelerations(a, obj.v0, obj.v_cap, gs)


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
