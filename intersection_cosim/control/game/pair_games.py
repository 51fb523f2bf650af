"""The pairwise games of a control step (paper Algorithm 1): which pairs play, in which order, and
one game's solve.

Each triggered pair plays the pairwise game (Nash: iterated best response; Stackelberg: the
vehicle with the smaller TCP leads), warm-started from the pair's previous plans shifted by the
periods since they were solved (up to half the horizon), or, for a pair that has not played
lately, from the plans its two players drive (what a cold start would first compute again).
When a player may still choose its exit lane, the pair's continuous game is solved for every
combination of exit lanes and a pure equilibrium of the resulting matrix game is taken
(:func:`~intersection_cosim.games.lane_choice.lane_choice_game`); leaving the preferred exit
lane costs J_lk (Eq. 23). The combination of the exit lanes the two hold is solved first, and
the other combinations start from its equilibrium (their own stored plans are a decision old).

A game in progress, warm-started from its own equilibrium of the last control step, runs at most
``PolicySettings.game_max_iter`` equilibrium iterations a step: an unconverged one applies its
last iterate and goes on from it at the next step (a real-time iteration, as the solo vehicles'
SQP). The equilibrium moves by a little from one period to the next, so one iteration a step
follows it closely; a pair's first solve, and one after a pause, runs to convergence.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from functools import partial
from typing import Callable, Mapping

import numpy as np

from intersection_cosim.control.base import World
from intersection_cosim.control.game.lane_options import LaneChangeCosts
from intersection_cosim.control.game.plan_memory import GameKey, PlanMemory
from intersection_cosim.control.game.players import player
from intersection_cosim.control.game.relations import Relations
from intersection_cosim.games.lane_choice import lane_choice_game
from intersection_cosim.games.problem import GameResult, Interaction, Problem
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.models.cost import time_to_conflict_point
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.movements import Movements

log = logging.getLogger(__name__)


@dataclass
class PairGame:
    """A pair that plays this step, with the lateral interactions of each exit-lane combination."""

    a: int  # World index of the first player (a < b)
    b: int
    combos: dict = field(default_factory=dict)  # (option a, option b) -> list of Interaction


@dataclass(frozen=True)
class GameSolver:
    """What one game's solve needs besides the step's data: the equilibrium and its settings."""

    equilibrium: Callable  # nash_equilibrium or stackelberg_equilibrium
    name: str  # "nash" | "stackelberg"
    settings: GameSettings
    model: ModelSettings
    lane_costs: LaneChangeCosts
    movements: Movements
    warm_settings: GameSettings | None = None  # of a game in progress (PolicySettings.game_max_iter)

    def solve(self, problem: Problem, gs: GameSettings, model: ModelSettings, warm_start=None, tracked=(),
              **kwargs) -> GameResult:
        """``equilibrium`` of ``problem``. A solve whose warm start is one of ``tracked`` (the
        pair's own equilibrium of the last control step) runs under ``warm_settings`` when they
        are set: its iterations capped per control step, a real-time iteration that goes on from
        its last iterate at the next step (PolicySettings.game_max_iter)."""
        if self.warm_settings is not None and warm_start is not None and any(warm_start is t for t in tracked):
            gs = self.warm_settings
        return self.equilibrium(problem, gs, model, warm_start=warm_start, **kwargs)


def pair_games(relations: Relations, options: Mapping[int, tuple[str, ...]]) -> dict[tuple[int, int], PairGame]:
    """The triggered vehicle pairs, with the interactions of each of their exit-lane options."""
    rows, pairs = relations.rows, relations.pairs
    games: dict[tuple[int, int], PairGame] = {}
    # the live lateral pairs of the triggered vehicle pairs (any of their rows may have fired),
    # selected with numpy over all the step's lateral pairs
    lo, hi = relations.pair_vehicles()
    key = lo * len(rows) + hi  # unique per vehicle pair: World indices < len(rows)
    fired = np.zeros(len(rows) * len(rows), bool)
    fired[key[pairs.play]] = True
    for m in np.flatnonzero(pairs.live & fired[key]):
        lat = pairs.at(m)
        ri, rj, s_i, s_j = lat.ri, lat.rj, lat.s_i, lat.s_j
        ka, kb = int(rows.vehicle[ri]), int(rows.vehicle[rj])
        if ka > kb:
            ka, kb, ri, rj, s_i, s_j = kb, ka, rj, ri, s_j, s_i
        if rows.option[ri] not in options[ka] or rows.option[rj] not in options[kb]:
            continue
        game = games.setdefault((ka, kb), PairGame(ka, kb))
        make = Interaction.cross if lat.kind == "cross" else Interaction.confluence
        game.combos.setdefault((rows.option[ri], rows.option[rj]), []).append(make(0, 1, s_i, s_j))
    return games


def urgency(world: World, game: PairGame, speed_floor: float) -> tuple[float, int, int]:
    """[s] the smaller time to its conflict point of the pair (TCP, Eqs. 21-22; ``speed_floor``
    [m/s]): games are played in this order, most urgent first (ties by vehicle index)."""
    s_a, v_a, s_b, v_b = (float(x) for x in (world.s[game.a], world.v[game.a], world.s[game.b], world.v[game.b]))
    tcp = math.inf
    for inters in game.combos.values():
        for it in inters:
            if it.lateral:
                tcp = min(tcp, time_to_conflict_point(it.s_cp_i - s_a, v_a, speed_floor),
                          time_to_conflict_point(it.s_cp_j - s_b, v_b, speed_floor))
    return (tcp, game.a, game.b)


def game_problems(world: World, game: PairGame, options: Mapping[int, tuple[str, ...]], relations: Relations,
              memory: PlanMemory) -> tuple[dict, dict]:
    """The continuous game of every exit-lane combination, and its warm start where there is one."""
    ka, kb = game.a, game.b
    problems, warm = {}, {}
    for oa in options[ka]:
        for ob in options[kb]:
            inters = list(game.combos.get((oa, ob), []))
            for f, lead_k, of in ((ka, kb, oa), (kb, ka, ob)):
                lead = relations.leader_of(f, of)
                if lead is not None and lead.vehicle == lead_k:
                    inters.append(Interaction.following(0 if f == ka else 1, 0 if lead_k == ka else 1, lead.offset))
            pa = player(world, ka, oa, relations, memory, partner=kb)
            pb = player(world, kb, ob, relations, memory, partner=ka)
            problems[(oa, ob)] = Problem((pa, pb), tuple(inters))
            start = memory.warm_start(GameKey(world.ids[ka], world.ids[kb], oa, ob), world.time)
            if start is None:  # a newly triggered pair: from the plans its players drive
                start = tuple(memory.driven_plan(world.ids[k], o) for k, o in ((ka, oa), (kb, ob)))
                start = None if all(p is None for p in start) else start
            if start is not None:
                warm[(oa, ob)] = start
    return problems, warm


def play(world: World, game: PairGame, problems: dict, warm: dict, options: Mapping[int, tuple[str, ...]],
         memory: PlanMemory, solver: GameSolver, deadline: float) -> tuple[GameResult, tuple[str, str]]:
    """Solve one pair's game (``problems`` and ``warm`` of :func:`game_problems`: every exit-lane
    combination, then the lane choice); store the warm starts. Returns the chosen combination's
    equilibrium and the exit lanes."""
    ka, kb = game.a, game.b
    gs, model = solver.settings, solver.model
    # warm starts that are the pair's own plans of the last control step: a game in progress
    tracked = tuple(warm[c] for c in warm
                    if memory.periods_since(GameKey(world.ids[ka], world.ids[kb], *c), world.time) == 1)
    if len(problems) == 1:
        (combo, problem), = problems.items()
        result = solver.solve(problem, gs, model, warm_start=warm.get(combo), tracked=tracked, deadline=deadline)
        choice, results = combo, {combo: result}
    else:
        costs = [solver.lane_costs.costs(world.path_ids[k], options[k]) for k in (ka, kb)]
        driven = (memory.options.get(world.ids[ka]), memory.options.get(world.ids[kb]))  # the exit lanes held
        lc = lane_choice_game(problems, costs, solver=partial(solver.solve, tracked=tracked), settings=gs,
                              model_settings=model, warm_starts=warm, lead=driven, deadline=deadline)
        result, choice, results = lc.result, lc.choice, lc.results
    for combo, res in results.items():  # every combination warm-starts its own next solve
        if res.status != "solver failure":
            memory.store(GameKey(world.ids[ka], world.ids[kb], *combo), world.time, res.plans)
    if result.status == "solver failure":
        log.warning("t=%.2f s: %s game %s-%s: solver failure (%s); braking comfortably",
                    world.time, solver.name, world.ids[ka], world.ids[kb], result.message)
    return result, choice
