"""The coupled games of a control step (``[controller.game] coupling = "cluster"``): every
connected component of three or more vehicles in the graph of the triggered pairs plays one
N-player game (games/coupled.py) instead of one game per pair; smaller components play pairwise.

A cluster's problem holds each member with the exit lane it holds (the first of its options when
it holds none) and every interaction between members: the lateral ones of the triggered pairs
for those exit lanes, and following where a member leads another. Its players are ordered by TCP
(most urgent first: the Gauss-Seidel order, and the Stackelberg hierarchy's). Warm start: the
cluster's own plans of the last control step, shifted (same members, same exit lanes), else the
plans the members drive. A game in progress runs under the capped settings of a pair's
(PolicySettings.game_max_iter). Exit-lane choice: after the solve, each member that may still
choose tries its other exit lanes alone, in TCP order, the cluster re-solved from the current
plans, and keeps one that lowers its own true cost (J_lk of Eq. 23 included): one pass of
unilateral discrete best responses. The anytime schedule keeps its own running estimates of a
cluster's solve time; a cluster is deferred (its members keep their plans) only when not even a
game in progress's capped solve would fit; any longer solve is cut at the anytime deadline.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Mapping

from intersection_cosim.control.base import World
from intersection_cosim.control.game.anytime import SLOW_SOLVE_FACTOR, SolveTimeEstimate
from intersection_cosim.control.game.pair_games import GameSolver, PairGame
from intersection_cosim.control.game.plan_memory import PlanMemory
from intersection_cosim.control.game.players import player
from intersection_cosim.control.game.relations import Relations
from intersection_cosim.games import budget_clock
from intersection_cosim.games.coupled import conflict_clusters, coupled_nash, coupled_stackelberg, player_tcp
from intersection_cosim.games.coupled_check import check_cluster
from intersection_cosim.games.problem import GameResult, Interaction, Problem

COUPLED = {"nash": coupled_nash, "stackelberg": coupled_stackelberg}
CLUSTER_WARM_S = 0.004  # [s] first estimate of a game in progress's solve (one capped iteration)
MIN_SIZE = 3  # [-] vehicles of the smallest component that plays one coupled game


@dataclass(frozen=True)
class ClusterKey:
    """The game of a cluster for one combination of exit lanes (a warm-start key of PlanMemory)."""

    members: tuple[str, ...]  # sorted vehicle ids
    exits: tuple[str, ...]  # each member's exit lane

    def vehicles(self) -> tuple[str, ...]:
        return self.members


@dataclass(frozen=True)
class ClusterSolve:
    """One cluster game solved at one step; ``problem`` kept only when it is to be checked."""

    time: float  # [s]
    members: tuple[str, ...]  # vehicle ids in the problem's player order (TCP order)
    solver: str
    status: str
    iterations: int
    residual: float  # [m/s^2] the last iteration's residual (NaN: none)
    result: GameResult | None = None
    problem: Problem | None = None


@dataclass(frozen=True)
class ClusterRow:
    """A cluster game's record in games.csv (:meth:`ClusterGames.rows`)."""

    time: float  # [s]
    members: tuple[str, ...]
    iterations: int
    residual: float  # [m/s^2]
    status: str
    check: str  # "pass" | "fail" | "" (not checked: checks off, or the game did not converge)
    gain_sampled: float  # [-] largest relative gain of a unilateral deviation, SLSQP (NaN: not checked)
    gain_resolve: float  # [-] ... by a best-response re-solve


def cluster_key(world: World, members: tuple[int, ...], exits: Mapping[int, str]) -> ClusterKey:
    """The key of ``members`` taking ``exits``, whatever their order this step (by vehicle id)."""
    by_id = sorted((world.ids[k], exits[k]) for k in members)
    return ClusterKey(tuple(v for v, _ in by_id), tuple(e for _, e in by_id))


def split_clusters(games: Mapping[tuple[int, int], PairGame]) -> tuple[list[tuple[int, ...]], dict]:
    """The components of ``MIN_SIZE`` or more vehicles, and the pair games outside them."""
    big = [c for c in conflict_clusters(games) if len(c) >= MIN_SIZE]
    inside = {k for c in big for k in c}
    return big, {key: g for key, g in games.items() if key[0] not in inside}


def cluster_problem(world: World, members: tuple[int, ...], exits: Mapping[int, str], games: Mapping, relations: Relations,
                    memory: PlanMemory, lane_costs: Mapping[int, Mapping[str, float]]) -> Problem:
    """The N-player problem of ``members`` (World indices) taking exit lanes ``exits``; a member
    choosing among several exit lanes carries its option's J_lk (``lane_costs``)."""
    idx = {k: m for m, k in enumerate(members)}
    players, inters = [], []
    for k in members:
        lead = relations.leader_of(k, exits[k])
        partner = lead.vehicle if lead is not None and lead.vehicle in idx else None
        pl = player(world, k, exits[k], relations, memory, partner=partner)
        if k in lane_costs:
            pl = dataclasses.replace(pl, j_lk=float(lane_costs[k].get(exits[k], 0.0)))
        players.append(pl)
        if partner is not None:
            inters.append(Interaction.following(idx[k], idx[partner], lead.offset))
    for (a, b), game in games.items():
        if a in idx and b in idx:
            for it in game.combos.get((exits[a], exits[b]), ()):
                inters.append(Interaction(it.kind, idx[a], idx[b], it.s_cp_i, it.s_cp_j))
    return Problem(tuple(players), tuple(inters))


def tcp_order(problem: Problem, members: tuple[int, ...], model) -> tuple[int, ...]:
    """``members`` most urgent first (the smallest TCP of a player's conflict points)."""
    tcp = player_tcp(problem, model)
    return tuple(members[m] for m in sorted(range(len(members)), key=lambda m: (tcp[m], members[m])))


class _WarmEstimate(SolveTimeEstimate):
    """The running mean time [s] of a game in progress's (capped) solve. A cluster is deferred only
    when not even that fits; a longer solve (a first one, several capped iterations) runs under
    the anytime deadline and returns its best plans so far when it is reached."""

    def fits(self, cutoff: float) -> bool:
        return budget_clock.now() + SLOW_SOLVE_FACTOR * self.seconds <= cutoff


class ClusterGames:
    """The coupled games of one controller: solves, warm starts, anytime estimates, records."""

    def __init__(self, equilibrium: str, solver: GameSolver, memory: PlanMemory, check: bool):
        self.equilibrium, self.solver, self.memory, self.check = equilibrium, solver, memory, check
        self.estimate = _WarmEstimate(CLUSTER_WARM_S)
        self.solves: list[ClusterSolve] = []
        self._rows: list[ClusterRow] = []  # the records of solves[:len(_rows)], checked

    def play(self, world: World, members: tuple[int, ...], games: Mapping, options: Mapping[int, tuple[str, ...]],
             relations: Relations, cutoff: float) -> tuple[tuple[int, ...], GameResult, dict[int, str]] | None:
        """Solve the cluster ``members``: (members in player order, result, exit lane per member),
        or None when it would not fit before ``cutoff`` (deferred)."""
        ids = world.ids
        exits = {k: (self.memory.options.get(ids[k]) if self.memory.options.get(ids[k]) in options[k]
                     else options[k][0]) for k in members}
        lane_costs = {k: self.solver.lane_costs.costs(world.path_ids[k], options[k])
                      for k in members if len(options[k]) > 1}
        problem = cluster_problem(world, members, exits, games, relations, self.memory, lane_costs)
        members = tcp_order(problem, members, self.solver.model)
        problem = cluster_problem(world, members, exits, games, relations, self.memory, lane_costs)
        key = cluster_key(world, members, exits)
        warm = self._warm(key, world, members)
        if warm is None:
            warm = tuple(self.memory.driven_plan(ids[k], exits[k]) for k in members)
            warm = None if all(p is None for p in warm) else warm
        if not self.estimate.fits(cutoff):
            self.estimate.deferred()
            return None
        t0 = budget_clock.now()
        in_progress = self.memory.periods_since(key, world.time) == 1
        result = self._solve(problem, warm, in_progress, cutoff)
        if in_progress:
            self.estimate.measured(budget_clock.now() - t0)
        if result.status != "solver failure":
            self._store(key, world, members, result.plans)
        if lane_costs:
            problem, result, exits = self._lane_choice(world, members, games, options, relations, lane_costs,
                                                       problem, result, exits, cutoff)
        self._record(world, tuple(ids[k] for k in members), problem, result)
        return members, result, exits

    def _warm(self, key: ClusterKey, world: World, members: tuple[int, ...]):
        """The cluster's stored plans, shifted, in the order of ``members`` (None: none)."""
        plans = self.memory.warm_start(key, world.time)
        if plans is None:
            return None
        by_id = dict(zip(key.members, plans))
        return tuple(by_id[world.ids[k]] for k in members)

    def _store(self, key: ClusterKey, world: World, members: tuple[int, ...], plans) -> None:
        by_id = {world.ids[k]: p for k, p in zip(members, plans)}
        self.memory.store(key, world.time, tuple(by_id[v] for v in key.members))

    def _solve(self, problem: Problem, warm, in_progress: bool, cutoff: float) -> GameResult:
        gs = self.solver.warm_settings if in_progress and self.solver.warm_settings is not None else self.solver.settings
        return COUPLED[self.equilibrium](problem, gs, self.solver.model, warm_start=warm, deadline=cutoff)

    def _lane_choice(self, world, members, games, options, relations, lane_costs, problem, result, exits, cutoff):
        """One pass of unilateral exit-lane changes (module docstring)."""
        for m, k in enumerate(members):
            for o in options[k]:
                if o == exits[k] or k not in lane_costs or budget_clock.now() >= cutoff:
                    continue
                trial_exits = dict(exits)
                trial_exits[k] = o
                trial = cluster_problem(world, members, trial_exits, games, relations, self.memory, lane_costs)
                res = self._solve(trial, result.plans, False, cutoff)
                if res.status != "solver failure" and res.costs[m] < result.costs[m]:
                    problem, result, exits = trial, res, trial_exits
                    self._store(cluster_key(world, members, exits), world, members, res.plans)
        return problem, result, exits

    def _record(self, world: World, members: tuple[str, ...], problem: Problem, result: GameResult) -> None:
        keep = self.check and result.status == "converged"
        residual = float(result.residuals[-1]) if result.residuals else math.nan
        self.solves.append(ClusterSolve(world.time, members, self.equilibrium, result.status, result.iterations,
                                        residual, result if keep else None, problem if keep else None))

    def rows(self) -> tuple[ClusterRow, ...]:
        """Every cluster game's record, its converged solves checked when checks are on (here,
        after the run, outside the step budget)."""
        for s in self.solves[len(self._rows):]:
            check, g_s, g_r = "", math.nan, math.nan
            if s.problem is not None and s.result is not None:
                c = check_cluster(s.problem, s.result, s.solver, self.solver.settings, self.solver.model)
                check, g_s, g_r = ("pass" if c.passed else "fail"), c.sampled_gain, c.resolve_gain
            self._rows.append(ClusterRow(s.time, s.members, s.iterations, s.residual, s.status, check, g_s, g_r))
        return tuple(self._rows)


def cluster_pairs(members: tuple[int, ...], games: Mapping) -> list[tuple[int, int]]:
    """The triggered pairs inside a cluster (World indices, a < b), sorted."""
    inside = set(members)
    return sorted(key for key in games if key[0] in inside and key[1] in inside)

