"""The coupled N-player game of a conflict cluster: every vehicle plays one game with all its
partners at once, instead of one pairwise game per partner.

A cluster is a connected component of the graph whose edges are the pairs that play a game
(:func:`conflict_clusters`). Its :class:`~intersection_cosim.games.problem.Problem` holds every
member and every interaction between members, so each player's cost is the paper's J (Eqs.
13-24) with J_lat summed over all its partners in the cluster and J_log over its leader
(:class:`~intersection_cosim.games.objective.PlayerObjective` sums over a player's interactions).

* :func:`coupled_nash`: open-loop Nash equilibrium (Eq. 25) by iterated best response over all
  players, Gauss-Seidel in the problem's player order (Jacobi with ``SolverSettings.scheme``);
  warm starts and the anytime deadline as for a pair (it is
  :func:`~intersection_cosim.games.nash.nash_equilibrium` of the whole cluster).
* :func:`coupled_stackelberg`: the leader-follower rule of Section IV-D generalised to a
  hierarchy ordered by TCP (:func:`hierarchy_order`). Level l's player commits a plan given the
  committed plans of the levels above; the levels below answer it with their own hierarchy, the
  last level (and every level past ``HIERARCHY_DEPTH``) by iterated best response. A leader
  chooses among a finite set of candidate plans (its current plan, its plan for passing first -
  its best response to every player below braking comfortably - and their midpoint) the one with
  the least true cost once the levels below have answered it; its current plan comes first, so a
  cold solve, started at the Nash equilibrium, never leaves the top leader worse off than Nash.
  This is a coarser leader search than the pair's KKT-based one
  (:mod:`~intersection_cosim.games.stackelberg`): the answers below are re-solved, not predicted.
"""

from __future__ import annotations

import math
import time
from typing import Iterable

import numpy as np

from intersection_cosim.games import budget_clock
from intersection_cosim.games.nash import EquilibriumSolve, WarmStart, failure_result, nash_equilibrium, warm_list
from intersection_cosim.games.problem import GameResult, Plan, Problem, safe_plan
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.games.sqp import SolverFailure
from intersection_cosim.models.cost import time_to_conflict_point
from intersection_cosim.models.settings import ModelSettings

HIERARCHY_DEPTH = 2  # [-] leader levels that search over candidate plans; below them: Nash
MIDPOINT = 0.5  # [-] weight of the pass-first plan in the third leader candidate


def conflict_clusters(pairs: Iterable[tuple[int, int]]) -> list[tuple[int, ...]]:
    """The connected components of the graph with edges ``pairs`` (vehicle indices), each sorted,
    in the order of their smallest member."""
    parent: dict[int, int] = {}

    def find(x: int) -> int:
        parent.setdefault(x, x)
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for a, b in pairs:
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    groups: dict[int, list[int]] = {}
    for x in list(parent):
        groups.setdefault(find(x), []).append(x)
    return sorted((tuple(sorted(g)) for g in groups.values()), key=lambda g: g[0])


def player_tcp(problem: Problem, model_settings: ModelSettings | None = None) -> np.ndarray:
    """[s] each player's smallest time to a conflict point of its lateral interactions (TCP,
    Eqs. 21-22); inf for a player without one."""
    ms = model_settings or ModelSettings()
    tcp = np.full(problem.n, math.inf)
    for it in problem.interactions:
        if it.lateral:
            for p, s_cp in ((it.i, it.s_cp_i), (it.j, it.s_cp_j)):
                pl = problem.players[p]
                tcp[p] = min(tcp[p], time_to_conflict_point(s_cp - pl.s0, pl.v0, ms.tcp_speed_floor))
    return tcp


def hierarchy_order(problem: Problem, model_settings: ModelSettings | None = None) -> tuple[int, ...]:
    """The players from the top of the Stackelberg hierarchy down: by TCP (:func:`player_tcp`,
    ties by index), a leader of a following interaction always above its follower."""
    rank = player_tcp(problem, model_settings)
    follows = [(it.i, it.j) for it in problem.interactions if it.kind == "following"]
    for _ in range(problem.n):  # a follower ranks just below its leader at the least
        for f, lead in follows:
            if not rank[f] > rank[lead]:
                rank[f] = np.nextafter(rank[lead], math.inf) if math.isfinite(rank[lead]) else math.inf
    return tuple(sorted(range(problem.n), key=lambda p: (rank[p], p)))


def coupled_nash(problem: Problem, settings: GameSettings | None = None,
                 model_settings: ModelSettings | None = None, warm_start: WarmStart = None,
                 deadline: float | None = None, record_costs: bool = False) -> GameResult:
    """Open-loop Nash equilibrium of the whole cluster ``problem`` by iterated best response over
    all its players (module docstring); the arguments and result as
    :func:`~intersection_cosim.games.nash.nash_equilibrium`'s. Never raises on numerical trouble."""
    return nash_equilibrium(problem, settings, model_settings, warm_start=warm_start, deadline=deadline,
                            record_costs=record_costs)


def coupled_stackelberg(problem: Problem, settings: GameSettings | None = None,
                        model_settings: ModelSettings | None = None, warm_start: WarmStart = None,
                        deadline: float | None = None, nash: GameResult | None = None) -> GameResult:
    """The TCP-ordered Stackelberg hierarchy of the cluster ``problem`` (module docstring).

    A cold solve (a player without a warm start) starts at the coupled Nash equilibrium (``nash``
    if given); a warm one from ``warm_start`` (the previous step's plans, shifted). ``deadline``:
    :func:`budget_clock.now` value; past it the best plans so far are returned with status
    "deadline". ``leader`` of the result is the top of the hierarchy. Never raises on numerical
    trouble: a failure returns comfortable braking for every player ("solver failure").
    """
    gs = settings or GameSettings()
    ms = model_settings or ModelSettings()
    t0 = time.perf_counter()
    order = hierarchy_order(problem, ms)
    game = None
    try:
        game = EquilibriumSolve(problem, gs, ms, "stackelberg")
        warm = warm_list(warm_start, game.n)
        if any(w is None for w in warm):
            if nash is None:
                nash = coupled_nash(problem, gs, ms, deadline=deadline)
                game.qp_count += nash.qp_count
            if nash.status == "solver failure":
                raise SolverFailure("Nash start failed: " + nash.message)
            plans = list(nash.plans)
        else:
            plans = [game.warm_plan(p, warm[p]) for p in range(game.n)]
        h = _Hierarchy(game, order, deadline)
        plans = h.solve(plans, 0)
        costs = game.costs(plans)
        if not (np.all(np.isfinite(costs)) and all(np.all(np.isfinite(p.positions)) for p in plans)):
            raise SolverFailure("non-finite plan or cost")
        status = "deadline" if h.timed_out else ("converged" if h.converged else "iteration cap")
        return GameResult(tuple(plans), costs, tuple(h.residuals), np.zeros((0, game.n)), len(h.residuals),
                          game.qp_count, status, "stackelberg", time.perf_counter() - t0, order[0])
    except (SolverFailure, ArithmeticError, ValueError, np.linalg.LinAlgError) as exc:
        return failure_result(problem, gs, "stackelberg", t0, f"{type(exc).__name__}: {exc}",
                              game.qp_count if game else 0, order[0])


class _Hierarchy:
    """One solve of the hierarchy: the levels' leader searches and the answers below them."""

    def __init__(self, game: EquilibriumSolve, order: tuple[int, ...], deadline: float | None):
        self.game, self.order, self.deadline = game, order, deadline
        self.residuals: list[float] = []  # [m/s^2] per best-response round of any level
        self.converged, self.timed_out = True, False

    def late(self) -> bool:
        if self.deadline is not None and budget_clock.now() >= self.deadline:
            self.timed_out = True
        return self.timed_out

    def answer(self, plans: list[Plan], free: tuple[int, ...]) -> list[Plan]:
        """Iterated (Gauss-Seidel) best responses of the players ``free``, the others' plans
        fixed, until no plan moves by ``nash_tol`` [m/s^2] in a round (at most ``nash_max_iter``)."""
        sv = self.game.gs.solver
        for p in free:  # a fresh trust region: the leaders' searches moved the plans it was sized for
            self.game.delta[p] = max(self.game.delta[p], sv.trust_region)
        for _ in range(sv.nash_max_iter):
            if self.late():
                return plans
            old = [plans[p].accelerations for p in free]
            for p in free:
                plans[p] = self.game.respond(p, plans, sv.sqp_steps_per_iteration)
            res = max(float(np.max(np.abs(plans[p].accelerations - a))) for p, a in zip(free, old))
            self.residuals.append(res)
            if res < sv.nash_tol:
                return self.other_orders(plans, free[0]) if len(free) == 1 else plans
        self.converged = False
        return plans

    def other_orders(self, plans: list[Plan], p: int) -> list[Plan]:
        """A lone answering player's best response also from full acceleration and from
        comfortable braking (passing before or after a partner are separate local optima); the
        least true cost of the three."""
        game, sv = self.game, self.game.gs.solver
        steps = min(sv.br_max_sqp, sv.nash_max_iter * sv.sqp_steps_per_iteration)  # the answer's own cap
        best = (self.cost(p, plans), plans[p])
        for a in (np.full(game.N, game.gs.problem.a_max), safe_plan(game.problem.players[p], game.gs)):
            if self.late():
                break
            trial = list(plans)
            trial[p] = game.warm_plan(p, a)
            game.delta[p] = sv.trust_region
            trial[p] = self.respond(p, trial, steps)
            c = self.cost(p, trial)
            if c < best[0]:
                best = (c, trial[p])
        plans = list(plans)
        plans[p] = best[1]
        return plans

    def solve(self, plans: list[Plan], level: int) -> list[Plan]:
        """Levels ``order[level:]`` play their hierarchy against the committed plans above."""
        below = self.order[level:]
        if len(below) == 1 or level >= HIERARCHY_DEPTH:
            return self.answer(list(plans), below)
        leader = below[0]
        best = None
        for cand in self.candidates(plans, leader, below[1:]):
            trial = list(plans)
            trial[leader] = cand
            trial = self.solve(trial, level + 1)
            cost = self.cost(leader, trial)
            if best is None or cost < best[0]:
                best = (cost, trial)
            if self.late():
                break
        return best[1]

    def candidates(self, plans: list[Plan], leader: int, followers: tuple[int, ...]) -> list[Plan]:
        """The leader's current plan, its pass-first plan (``stackelberg_max_iter`` SQP steps
        of its best response to every follower braking comfortably: a game in progress, capped at
        one leader iteration a step, takes one) and their midpoint."""
        if self.late():
            return [plans[leader]]
        game = self.game
        yielding = list(plans)
        for f in followers:
            yielding[f] = safe_plan(game.problem.players[f], game.gs)
        first = self.respond(leader, yielding, game.gs.solver.stackelberg_max_iter)
        a = plans[leader].accelerations
        mid = game.plan(leader, a + MIDPOINT * (first.accelerations - a))
        return [plans[leader], first, mid]

    def respond(self, p: int, plans: list[Plan], steps: int) -> Plan:
        """Player p's best response to ``plans`` from plans[p]: up to ``steps`` SQP steps, one at a
        time so that the anytime deadline can stop it between two, and no further once a step
        moved the plan less than ``br_step_tol`` [m/s^2]."""
        plans = list(plans)
        for _ in range(steps):
            old = plans[p].accelerations
            plans[p] = self.game.respond(p, plans, 1)
            if float(np.max(np.abs(plans[p].accelerations - old))) < self.game.gs.solver.br_step_tol or self.late():
                break
        return plans[p]

    def cost(self, p: int, plans: list[Plan]) -> float:
        obj = self.game.objs[p]
        obj.set_others(plans)
        c = float(obj.cost(plans[p].accelerations))
        if not math.isfinite(c):
            raise SolverFailure("non-finite leader cost")
        return c
