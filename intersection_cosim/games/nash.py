"""Open-loop Nash equilibrium by iterated best response (paper Section IV-C, Eqs. 25-33).

The paper expands the equilibrium of weakly coupled players around the decoupled optimal-control
problems (Eq. 33, the zeroth-order term) and improves it iteratively; here that is the
best-response iteration started from the decoupled optimum:

* cold start: each player's own optimal control with every interaction removed (one QP each);
* iteration m: Gauss-Seidel (each player in turn answers the latest plans of the others) or
  Jacobi (all answer the plans of iteration m - 1). Each answer is ``sqp_steps_per_iteration``
  SQP steps of :func:`~intersection_cosim.games.sqp.sqp_best_response` from the player's
  current plan (a converged iteration is then a point where no player's best-response SQP moves:
  every player is at a local best response to the others). Within one solve a player's model
  Hessian is reused until a plan moved more than ``hessian_refresh`` (the gradient is always
  exact); the QP duals travel with the plans for warm starts;
* residual of iteration m = the largest change of any acceleration in it [m/s^2] (Fig. 3 data);
* converged when the residual is below ``nash_tol``, or when every best response of the
  iteration lowered its player's true cost by less than ``nash_cost_rtol`` (relative) while no
  plan moved more than ``nash_cost_guard``: then each player is within a second-order small gain
  of its best response to the final plans (a flat optimum can still move its plan a little).

With ``GameSettings.cold_start_orders`` a cold solve of a game with lateral conflicts also runs
the iteration from starts where each player in turn passes the conflict point first (full
acceleration for it, comfortable braking for its partners) and keeps, among the converged
results, the equilibrium with the least total cost: the order of passing is a discrete choice the
local iteration cannot change on its own, so a game can have one local equilibrium per order.
Off by default (it triples the work of a cold solve; on a seeded battery it changed the passing
order in 2 of 60 pairs).

Status: "converged", "iteration cap", "deadline" (anytime mode: the next iteration would not
fit before ``deadline``; the best plans so far are returned) or "solver failure" (an OSQP status
other than solved, or a non-finite number: every player gets the comfortable-braking plan). The
function never raises on numerical trouble.
"""

from __future__ import annotations

import math
import time
from typing import Sequence

import numpy as np

from intersection_cosim.games import budget_clock
from intersection_cosim.games.objective import PlayerObjective
from intersection_cosim.games.problem import GameResult, Plan, Problem, safe_plan
from intersection_cosim.games.qp import workspace
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.games.sqp import SolverFailure, initial_accelerations, sqp_best_response
from intersection_cosim.models.settings import ModelSettings

WarmStart = Sequence[Plan | np.ndarray | None] | GameResult | None


def failure_result(problem: Problem, gs: GameSettings, solver: str, t0: float, message: str,
                   qp_count: int = 0, leader: int | None = None) -> GameResult:
    """Every player brakes comfortably to a stop; status "solver failure"."""
    plans = tuple(safe_plan(p, gs) for p in problem.players)
    n = problem.n
    return GameResult(plans, np.full(n, math.nan), (), np.zeros((0, n)), 0, qp_count,
                      "solver failure", solver, time.perf_counter() - t0, leader, message)


def warm_list(warm_start: WarmStart, n: int) -> list:
    if warm_start is None:
        return [None] * n
    if isinstance(warm_start, GameResult):
        warm_start = warm_start.plans
    out = list(warm_start)[:n]
    return out + [None] * (n - len(out))


class EquilibriumSolve:
    """Shared state of one equilibrium solve: objectives, plans, workspaces, counters."""

    def __init__(self, problem: Problem, gs: GameSettings, ms: ModelSettings, tag: str):
        bad = problem.validate()
        if bad:
            raise SolverFailure("; ".join(bad))
        self.problem, self.gs, self.ms = problem, gs, ms
        self.n, self.N, self.dt = problem.n, gs.problem.steps, gs.problem.dt
        self.objs = [PlayerObjective(problem, p, gs, ms) for p in range(self.n)]
        self.ws = [workspace(self.N, gs, (tag, p)) for p in range(self.n)]
        self.qp_count = 0
        self.delta = [gs.solver.trust_region] * self.n
        self.gain = [0.0] * self.n  # relative cost decrease of each player's last response
        self.known_cost: list[float | None] = [None] * self.n  # cost valid for the current plans
        # per player: (model Hessian, own plan and partners' plans where it was computed)
        self.hessians: list[tuple | None] = [None] * self.n
        self.partners = [sorted({it.j if it.i == p else it.i for it in problem.interactions
                                 if it.involves(p)}) for p in range(self.n)]

    def plan(self, p: int, a: np.ndarray, duals: np.ndarray | None = None) -> Plan:
        return self.objs[p].plan(a, duals)

    def warm_plan(self, p: int, warm) -> Plan:
        """A warm start (Plan or accelerations) made feasible for player p's current state."""
        a = initial_accelerations(self.objs[p], warm, self.gs)
        duals = warm.duals if isinstance(warm, Plan) else None
        if duals is not None and duals.shape != (2 * self.N,):
            duals = None
        return self.plan(p, a, duals)

    def decoupled_start(self) -> list[Plan]:
        """Zeroth-order plans (Eq. 33): each player's optimum with no interaction, one QP each."""
        dec = self.problem.decoupled()
        plans = []
        for p in range(self.n):
            obj = PlayerObjective(dec, p, self.gs, self.ms)
            out = sqp_best_response(obj, initial_accelerations(obj, None, self.gs), self.ws[p],
                                    self.gs, 1)
            self.qp_count += out.qp_count
            plans.append(self.plan(p, out.a, out.duals))
        return plans

    def respond(self, p: int, others: Sequence[Plan], steps: int) -> Plan:
        """Player p's (inexact, ``steps`` SQP steps) best response to ``others``, from others[p]."""
        obj = self.objs[p]
        obj.set_others(others)
        a = others[p].accelerations
        out = sqp_best_response(obj, a, self.ws[p], self.gs, steps, trust_region=self.delta[p],
                                duals=others[p].duals, hessian=self._hessian(p, a, others))
        self.qp_count += out.qp_count
        self.delta[p] = out.trust_region
        self.gain[p] = (out.cost0 - out.cost) / max(abs(out.cost0), 1e-9)
        # p's cost is now known for the current plans; its partners' costs are not
        self.known_cost[p] = out.cost
        for q in self.partners[p]:
            self.known_cost[q] = None
        if out.hessian is not None:
            H, at = out.hessian
            self.hessians[p] = (H, at, [others[q].accelerations for q in self.partners[p]])
        return self.plan(p, out.a, out.duals)

    def _hessian(self, p: int, a: np.ndarray, others: Sequence[Plan]) -> np.ndarray | None:
        """Player p's last model Hessian if neither its plan nor a partner's moved more than
        ``hessian_refresh`` since it was computed, else None (compute a fresh one)."""
        stored = self.hessians[p]
        if stored is None:
            return None
        H, at, partner_plans = stored
        tol = self.gs.solver.hessian_refresh
        if np.abs(a - at).max() > tol:
            return None
        for q, aq in zip(self.partners[p], partner_plans):
            if np.abs(others[q].accelerations - aq).max() > tol:
                return None
        return H

    def costs(self, plans: Sequence[Plan], known: bool = False) -> np.ndarray:
        """True costs of ``plans``; with ``known`` the costs of the last best responses are reused
        where no partner moved since (Gauss-Seidel: the last player's)."""
        out = np.empty(self.n)
        for p, obj in enumerate(self.objs):
            c = self.known_cost[p] if known else None
            if c is None:
                obj.set_others(plans)
                c = obj.cost(plans[p].accelerations)
            out[p] = c
        return out


def _iterate(game: EquilibriumSolve, plans: list[Plan], deadline: float | None, max_iter: int,
             record_costs: bool = False):
    """Best-response iteration from ``plans``; returns (plans, residuals, history, status)."""
    gs = game.gs
    residuals: list[float] = []
    history: list[np.ndarray] = []
    status = "iteration cap"
    per_iteration = 0.0
    confirmed = False
    for _ in range(max_iter):
        start = budget_clock.now()
        if deadline is not None and start + per_iteration > deadline:
            status = "deadline"
            break
        old = [p.accelerations for p in plans]
        if gs.solver.scheme == "jacobi":
            frozen = list(plans)
            plans = [game.respond(p, frozen, gs.solver.sqp_steps_per_iteration) for p in range(game.n)]
            game.known_cost = [None] * game.n  # each answered the old plans of the others
        else:
            for p in range(game.n):
                plans[p] = game.respond(p, plans, gs.solver.sqp_steps_per_iteration)
        res = max(float(np.max(np.abs(plans[p].accelerations - old[p]))) for p in range(game.n))
        residuals.append(res)
        if record_costs:
            history.append(game.costs(plans))
        per_iteration = max(per_iteration, budget_clock.now() - start)
        if res < gs.solver.nash_tol or (res < gs.solver.nash_cost_guard and max(game.gain) < gs.solver.nash_cost_rtol):
            if confirmed or res < gs.solver.nash_tol or not _collapsed(game):
                status = "converged"
                break
            confirmed = True  # once per solve: one more iteration with every radius restored
            game.delta = [max(d, gs.solver.trust_region) for d in game.delta]
    return plans, residuals, history, status


def _collapsed(game: EquilibriumSolve) -> bool:
    """Whether, in a game of two or more players, a player's trust region, carried from one
    iteration to the next, has shrunk below a quarter of its initial radius. When the iteration
    stops on a small gain while a plan still moved (by nash_tol or more), that player's last
    answers were held to small steps while its partners moved, so its small gain does not show
    that it is at its best response. The iteration then goes on once with the radii restored;
    without this the stop rule accepted points a player could still improve on by up to 11 %
    (games battery nos. 16 and 35), which a warm re-solve then left. A lone player's shrunk
    region is its own SQP's verdict (no step lowers its cost), as :func:`solo_response` has it."""
    return game.n > 1 and min(game.delta) < 0.25 * game.gs.solver.trust_region


def nash_equilibrium(problem: Problem, settings: GameSettings | None = None,
                     model_settings: ModelSettings | None = None, warm_start: WarmStart = None,
                     deadline: float | None = None, record_costs: bool = False) -> GameResult:
    """Open-loop Nash equilibrium of ``problem`` (Eq. 25) by iterated best response.

    ``warm_start``: the previous control step's plans shifted by one step (:func:`shift_plans`),
    as Plans or acceleration arrays, one per player (None entries start decoupled); they are
    projected onto the current constraints. ``deadline``: a :func:`budget_clock.now` value; the
    iteration stops when the next one would not fit and returns the best plans so far with status
    "deadline". ``record_costs``: also fill ``cost_history`` (one cost evaluation per player per
    iteration). Never raises on numerical trouble (module docstring).
    """
    gs = settings or GameSettings()
    ms = model_settings or ModelSettings()
    t0 = time.perf_counter()
    game = None
    try:
        game = EquilibriumSolve(problem, gs, ms, "nash")
        warm = warm_list(warm_start, game.n)
        cold = all(w is None for w in warm)
        if deadline is not None and budget_clock.now() >= deadline:
            plans = [game.warm_plan(p, warm[p]) if warm[p] is not None
                     else safe_plan(problem.players[p], gs) for p in range(game.n)]
            return _finish(game, plans, [], "deadline", t0, [])
        if cold:
            starts = [game.decoupled_start()]
            if gs.solver.cold_start_orders:
                starts += _order_starts(game)
        else:
            dec = None
            plans = []
            for p in range(game.n):
                if warm[p] is None:
                    dec = dec or game.decoupled_start()
                    plans.append(dec[p])
                else:
                    plans.append(game.warm_plan(p, warm[p]))
            starts = [plans]
        best = None
        for plans in starts:
            plans, residuals, history, status = _iterate(game, list(plans), deadline,
                                                         gs.solver.nash_max_iter, record_costs)
            total = float(np.sum(game.costs(plans))) if len(starts) > 1 else 0.0
            rank = (status != "converged", total)
            if best is None or rank < best[0]:
                best = (rank, plans, residuals, history, status)
            if status == "deadline":
                break
        _, plans, residuals, history, status = best
        return _finish(game, plans, residuals, status, t0, history, known=len(starts) == 1)
    except (SolverFailure, ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
        return failure_result(problem, gs, "nash", t0, f"{type(exc).__name__}: {exc}",
                              game.qp_count if game else 0)


def _order_starts(game: EquilibriumSolve) -> list[list[Plan]]:
    """Cold starts in which one player of a lateral conflict passes first: it keeps full
    acceleration and every partner of its lateral interactions brakes comfortably."""
    gs = game.gs
    starts = []
    lateral = [it for it in game.problem.interactions if it.lateral]
    if not lateral:
        return starts
    players = sorted({it.i for it in lateral} | {it.j for it in lateral})
    for first in players:
        plans = []
        partners = {it.j if it.i == first else it.i for it in lateral if it.involves(first)}
        for p in range(game.n):
            obj = game.objs[p]
            if p == first:
                a = np.full(game.N, obj.gs.problem.a_max)
            elif p in partners:
                a = np.full(game.N, -gs.problem.comfort_brake)
            else:
                a = np.zeros(game.N)
            plans.append(game.plan(p, initial_accelerations(obj, a, gs)))
        starts.append(plans)
    return starts


def _finish(game: EquilibriumSolve, plans, residuals, status, t0, history, known: bool = False) -> GameResult:
    costs = game.costs(plans, known)
    if not (np.all(np.isfinite(costs)) and all(np.all(np.isfinite(p.positions)) for p in plans)):
        raise SolverFailure("non-finite plan or cost")
    hist = np.array(history) if history else np.zeros((0, game.n))
    return GameResult(tuple(plans), costs, tuple(residuals), hist, len(residuals), game.qp_count,
                      status, "nash", time.perf_counter() - t0)


def solo_response(problem: Problem, settings: GameSettings | None = None,
                  model_settings: ModelSettings | None = None, warm_start: WarmStart = None,
                  own_hessian: bool = False) -> GameResult:
    """:func:`nash_equilibrium` of a one-player problem without interactions (a vehicle in no
    game), without the machinery of an n-player solve: the same QPs in the same workspace, in
    the same order, and the same result, at a fraction of the Python overhead.

    The player's best response is its own optimal control against its fixed leader prediction
    (no partner moves, so the iteration is ``nash_max_iter`` SQP passes of one player). Any other
    problem is handed to :func:`nash_equilibrium`. With ``own_hessian`` every QP installs the
    player's own model Hessian and every iteration builds a fresh one (as
    :mod:`~intersection_cosim.games.solo_batch`, whose small batches come here). Never raises
    on numerical trouble.
    """
    gs = settings or GameSettings()
    ms = model_settings or ModelSettings()
    if problem.n != 1 or problem.interactions:
        return nash_equilibrium(problem, gs, ms, warm_start=warm_start)
    t0 = time.perf_counter()
    qps = [0]  # QPs solved so far (kept when a later one fails)
    try:
        bad = problem.validate()
        if bad:
            raise SolverFailure("; ".join(bad))
        obj = PlayerObjective(problem, 0, gs, ms)
        ws = workspace(gs.problem.steps, gs, ("nash", 0))  # the slot nash_equilibrium's player 0 uses
        warm = warm_list(warm_start, 1)[0]
        if warm is None:  # the decoupled start of Eq. 33: the problem without the player's leader terms
            dec = PlayerObjective(problem.decoupled(), 0, gs, ms)
            out = sqp_best_response(dec, initial_accelerations(dec, None, gs), ws, gs, 1, own_hessian=own_hessian)
            qps[0] += out.qp_count
            plan = obj.plan(out.a, out.duals)
        else:
            duals = warm.duals if isinstance(warm, Plan) else None
            if duals is not None and duals.shape != (2 * gs.problem.steps,):
                duals = None
            plan = obj.plan(initial_accelerations(obj, warm, gs), duals)
        plan, residuals, cost = _solo_iterate(obj, ws, gs, plan, qps, own_hessian)
        if cost is None:  # Jacobi: nash_equilibrium evaluates the final cost afresh
            obj.set_others((plan,))
            cost = obj.cost(plan.accelerations)
        if not (math.isfinite(cost) and np.all(np.isfinite(plan.positions))):
            raise SolverFailure("non-finite plan or cost")
        status = "converged" if residuals[-1][1] else "iteration cap"
        res = tuple(r for r, _ in residuals)
        return GameResult((plan,), np.array([cost]), res, np.zeros((0, 1)), len(res), qps[0],
                          status, "nash", time.perf_counter() - t0)
    except (SolverFailure, ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
        return failure_result(problem, gs, "nash", t0, f"{type(exc).__name__}: {exc}", qps[0])


def _solo_iterate(obj: PlayerObjective, ws, gs: GameSettings, plan: Plan, qps: list[int], own_hessian: bool = False):
    """:func:`_iterate` for one player: returns (plan, [(residual [m/s^2], converged)], its cost
    or None for the Jacobi scheme); adds the QPs solved to ``qps[0]``. ``own_hessian``:
    :func:`solo_response`'s."""
    sv = gs.solver
    delta, hessian = sv.trust_region, None
    residuals = []
    for _ in range(sv.nash_max_iter):
        old = plan.accelerations
        obj.set_others((plan,))
        H = None
        if not own_hessian and hessian is not None and not np.abs(old - hessian[1]).max() > sv.hessian_refresh:
            H = hessian[0]  # as EquilibriumSolve._hessian: the plan moved less than hessian_refresh
        out = sqp_best_response(obj, old, ws, gs, sv.sqp_steps_per_iteration, trust_region=delta,
                                duals=plan.duals, hessian=H, own_hessian=own_hessian)
        qps[0] += out.qp_count
        delta = out.trust_region
        gain = (out.cost0 - out.cost) / max(abs(out.cost0), 1e-9)
        if out.hessian is not None:
            hessian = out.hessian
        plan = obj.plan(out.a, out.duals)
        res = float(np.max(np.abs(plan.accelerations - old)))
        done = res < sv.nash_tol or (res < sv.nash_cost_guard and gain < sv.nash_cost_rtol)
        residuals.append((res, done))
        if done:
            break
    return plan, residuals, (None if sv.scheme == "jacobi" else out.cost)
