"""Equilibrium check of an N-player cluster game: what a player gains by deviating alone.

Two independent tests of each checked player, the others' plans fixed:

* sampled: :func:`~intersection_cosim.games.checks.best_deviation` (SLSQP on the true cost from
  the equilibrium plan, full acceleration, comfortable braking, constant speed and seeded random
  plans);
* re-solve: a full best response (:func:`~intersection_cosim.games.sqp.best_response`, the
  solvers' own SQP run to convergence) started from the equilibrium plan.

The point passes when neither lowers any checked player's true cost by more than ``tolerance``
times max(|cost|, COST_FLOOR). A Nash result checks every player; a Stackelberg hierarchy checks
the players that answer (every level below the leaders' searches), since a leader by definition
need not be at a best response to the plans below it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from intersection_cosim.games.checks import COST_FLOOR, best_deviation
from intersection_cosim.games.coupled import HIERARCHY_DEPTH, hierarchy_order
from intersection_cosim.games.problem import GameResult, Plan, Problem
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.games.sqp import best_response
from intersection_cosim.models.settings import ModelSettings


@dataclass(frozen=True)
class ClusterCheck:
    """The largest relative gains [-] of a unilateral deviation among the checked players."""

    players: tuple[int, ...]  # the checked players
    sampled_gain: float  # [-] by SLSQP from several starts
    resolve_gain: float  # [-] by a best-response re-solve
    tolerance: float  # [-] allowed relative gain

    @property
    def passed(self) -> bool:
        return self.sampled_gain <= self.tolerance and self.resolve_gain <= self.tolerance


def checked_players(problem: Problem, solver: str, model_settings: ModelSettings | None = None) -> tuple[int, ...]:
    """Who must be at a best response: all players of a Nash result; the answering levels of a
    Stackelberg hierarchy (:mod:`~intersection_cosim.games.coupled`)."""
    if solver != "stackelberg":
        return tuple(range(problem.n))
    order = hierarchy_order(problem, model_settings)
    return tuple(sorted(order[min(HIERARCHY_DEPTH, problem.n - 1):]))


def check_cluster(problem: Problem, result: GameResult | Sequence[Plan], solver: str = "nash",
                  settings: GameSettings | None = None, model_settings: ModelSettings | None = None,
                  starts: int = 4, seed: int = 0, tolerance: float = 0.01) -> ClusterCheck:
    """Unilateral deviations of the checked players from ``result`` (module docstring)."""
    gs = settings or GameSettings()
    ms = model_settings or ModelSettings()
    plans = list(result.plans if isinstance(result, GameResult) else result)
    players = checked_players(problem, solver, ms)
    sampled, resolved = 0.0, 0.0
    for p in players:
        dev = best_deviation(problem, plans, p, gs, ms, starts, seed + p)
        sampled = max(sampled, dev.relative_gain)
        br = best_response(problem, p, plans, gs, ms, warm=plans[p])
        if np.isfinite(br.cost):
            resolved = max(resolved, max(0.0, dev.cost - br.cost) / max(abs(dev.cost), COST_FLOOR))
    return ClusterCheck(players, sampled, resolved, tolerance)
