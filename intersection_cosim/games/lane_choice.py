"""Discrete lane choice on top of the continuous game (paper Case 2: V3's exit lane).

Each player has a finite set of discrete options (an exit lane, or a lane change before the
conflict zone); one :class:`Problem` per combination of options describes the continuous game
that combination leads to (its interactions: whom the player follows, with whom it crosses or
merges). The continuous equilibrium is solved for every combination; its costs, with the
lane-keeping cost of each player's option added, fill a small matrix game, of which a pure Nash
equilibrium is taken:

* leaving the preferred lane costs J_lk (Eq. 23) over the horizon: the option's ``lane_costs``
  entry is put into ``Player.j_lk``, so it enters every step's running cost as
  (1 - kappa) k_lk J_lk (Eqs. 13-14); :func:`lane_change_cost` gives J_lk for a lateral offset;
* several pure equilibria: the one with the least total cost (sum over players) is taken, ties
  going to the first combination in the given order;
* no pure equilibrium: the combination whose largest unilateral regret (what a player would
  gain by switching its own option alone) is smallest, i.e. the epsilon-equilibrium with the
  smallest epsilon; ties by least total cost, then order;
* a combination whose continuous solve failed counts as infinitely costly for every player; if
  all fail, the first combination's (failure) result is returned.

With ``lead`` (the combination the players drive) that combination is solved first and every
other one starts from its equilibrium rather than from its own stored warm start: the players'
states are the same in every combination, and the plans they drive now are a fresher start than
the plans a combination had at its last decision, ``lane_choice_period`` control steps ago. At
high demand that about halves the QPs of the other combinations, and nearly every choice picks
the same combination as before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Hashable, Mapping, Sequence

import numpy as np

from intersection_cosim.games.nash import nash_equilibrium
from intersection_cosim.games.problem import GameResult, Problem
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.models.cost import lane_keeping_cost
from intersection_cosim.models.settings import ModelSettings

RULE_PURE = "pure equilibrium"
RULE_PURE_SEVERAL = "pure equilibrium, least total cost of several"
RULE_NO_PURE = "no pure equilibrium: least largest regret"


@dataclass(frozen=True)
class LaneChoiceResult:
    choice: tuple  # the chosen combination, one option per player
    result: GameResult  # the continuous equilibrium of that combination
    costs: dict  # combination -> players' costs (with their lane costs), shape (n,)
    results: dict  # combination -> GameResult
    equilibria: tuple  # all pure equilibria of the matrix game
    regret: dict  # combination -> largest unilateral regret [-]
    rule: str  # which rule picked ``choice`` (module docstring)


def lane_change_cost(lateral_offset: float, model_settings: ModelSettings | None = None) -> float:
    """[-] J_lk (Eq. 23) of driving ``lateral_offset`` [m] away from the preferred lane centre
    with no heading error: k_y_lk * offset^2."""
    ms = model_settings or ModelSettings()
    return float(lane_keeping_cost(lateral_offset, 0.0, ms.k_y_lk, ms.k_phi_lk))


def lane_choice_game(problems_by_choice: Mapping[tuple, Problem],
                     lane_costs: Sequence[Mapping[Hashable, float]] | None = None,
                     solver: Callable[..., GameResult] = nash_equilibrium,
                     settings: GameSettings | None = None,
                     model_settings: ModelSettings | None = None,
                     warm_starts: Mapping[tuple, object] | None = None,
                     lead: tuple | None = None, **solver_kwargs) -> LaneChoiceResult:
    """Pure equilibrium of the discrete lane-choice game (module docstring).

    ``problems_by_choice[c]``: the continuous problem when the players take options
    c = (c_0, ..., c_{n-1}) (same players in the same order in every problem). ``lane_costs[i][o]``:
    J_lk of player i taking option o (missing entries: 0). ``solver``: ``nash_equilibrium`` or
    ``stackelberg_equilibrium`` (called as solver(problem, settings, model_settings,
    warm_start=..., **solver_kwargs)). ``warm_starts[c]``: warm start of combination c.
    ``lead``: the combination the players drive, solved first to start the others (module
    docstring); None: each from its own warm start.
    """
    if not problems_by_choice:
        raise ValueError("no combinations given")
    gs = settings or GameSettings()
    ms = model_settings or ModelSettings()
    combos = list(problems_by_choice)
    n = len(combos[0])
    results = _solve_combinations(problems_by_choice, lane_costs,
                                  lambda pr, w: solver(pr, gs, ms, warm_start=w, **solver_kwargs),
                                  dict(warm_starts or {}), lead)
    costs = {c: np.full(n, math.inf) if r.status == "solver failure" else np.asarray(r.costs, float)
             for c, r in results.items()}
    options = [list(dict.fromkeys(c[i] for c in combos)) for i in range(n)]  # in order of appearance
    regret = {}
    for c in combos:
        worst = 0.0
        for i in range(n):
            for o in options[i]:
                alt = c[:i] + (o,) + c[i + 1:]
                if o == c[i] or alt not in costs:
                    continue
                gain = costs[c][i] - costs[alt][i]
                if math.isnan(gain):
                    continue
                worst = max(worst, gain)
        regret[c] = worst
    total = {c: float(np.sum(costs[c])) for c in combos}
    tol = 1e-9
    equilibria = tuple(c for c in combos if regret[c] <= tol and math.isfinite(total[c]))
    if len(equilibria) == 1:
        choice, rule = equilibria[0], RULE_PURE
    elif equilibria:
        choice, rule = min(equilibria, key=lambda c: (total[c], combos.index(c))), RULE_PURE_SEVERAL
    else:
        choice = min(combos, key=lambda c: (regret[c], total[c], combos.index(c)))
        rule = RULE_NO_PURE
    return LaneChoiceResult(choice, results[choice], costs, results, equilibria, regret, rule)


def _solve_combinations(problems_by_choice: Mapping[tuple, Problem], lane_costs, solve: Callable,
                        warm: dict, lead: tuple | None) -> dict:
    """combination -> GameResult of ``solve(problem, warm start)`` for every combination, each
    player's J_lk from ``lane_costs``; ``lead`` (if given) first, and the others then start from
    its equilibrium unless its solve failed. In the given order, which breaks ties."""
    order = list(problems_by_choice)
    if lead in problems_by_choice:
        order.remove(lead)
        order.insert(0, lead)
    results: dict = {}
    for c in order:
        problem = problems_by_choice[c]
        if lane_costs is not None:
            players = tuple(replace(p, j_lk=float(lane_costs[i].get(c[i], 0.0)))
                            if i < len(lane_costs) else p for i, p in enumerate(problem.players))
            problem = replace(problem, players=players)
        start = warm.get(c)
        if c != lead and lead in results and results[lead].status != "solver failure":
            start = results[lead].plans
        results[c] = solve(problem, start)
    return {c: results[c] for c in problems_by_choice}
