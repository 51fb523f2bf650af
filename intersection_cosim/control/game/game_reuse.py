"""Games whose inputs did not change keep their equilibrium: the event-triggered re-planning of
:mod:`intersection_cosim.control.game.solo`, for pairs.

A pair's open-loop equilibrium, shifted by one control period, answers the same game seen one
period later when nothing the game depends on moved: both players are where their plans put them
(within ``solo_position_tol`` [m] and ``solo_speed_tol`` [m/s]), the exit lanes and interactions
(conflict points, who follows whom) are the ones solved, and each player's leader outside the
game is predicted where it was (within ``solo_leader_tol``). Such a game is not solved again, at
most ``game_resolve_steps`` - 1 steps in a row; its plans restart from the measured states.

Three more conditions keep the decisions (decision record 010 has the measurements):

* only a solve that converged in its first iteration is kept: its warm start, the equilibrium of
  the step before, already was one, so the game is steady; a game still moving may switch
  between equilibria, which only a fresh solve finds;
* by the kept plans the two reach each of their conflict points at least ``game_reuse_gap`` [s]
  apart, a player not there within the horizon counted at its end (two players both beyond it
  are not known to be apart): near the safety filter's threshold a small change of the plans
  flips whom it holds, so such a pair is solved every step;
* one exit-lane combination only (a lane choice is decided anew), no player the safety filter
  held back at the last step, none that crosses human drivers.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from intersection_cosim.control.base import World
from intersection_cosim.control.game.plan_memory import GameKey, PlanMemory
from intersection_cosim.control.game.players import prediction_moved
from intersection_cosim.control.game.settings import PolicySettings
from intersection_cosim.games.problem import GameResult, Plan, Problem, keeps_speed_cap


class _LastGame(NamedTuple):
    age: int  # control steps since the solve
    combo: tuple[str, str]  # exit lanes solved for
    interactions: tuple  # the solved Problem's interactions
    leaders: tuple  # each player's leader prediction (s [m], v [m/s]) outside the game, or None
    v_max: tuple  # [m/s] each player's speed cap v_max solved for (the model's where it has none)


class GameReuse:
    """What each pair's last solve answered, and whether it may stand (module docstring)."""

    def __init__(self, policy: PolicySettings, memory: PlanMemory, v_max: float):
        self.policy, self.memory, self.v_max = policy, memory, v_max  # v_max [m/s]: the model's
        self._last: dict[tuple[str, str], _LastGame] = {}

    def forget(self, vehicle: str) -> None:
        """Drop the games of a vehicle that left."""
        self._last = {key: g for key, g in self._last.items() if vehicle not in key}

    def solved(self, world: World, a: int, b: int, problems: dict, result: GameResult, choice: tuple) -> None:
        """Record the solve of pair (a, b): kept for reuse only when it converged in one iteration
        on one combination."""
        key = (world.ids[a], world.ids[b])
        if len(problems) != 1 or result.status != "converged" or result.iterations > 1:
            self._last.pop(key, None)
            return
        problem = problems[choice]
        self._last[key] = _LastGame(0, choice, problem.interactions, tuple(p.leader for p in problem.players),
                                    tuple(self._v_max(p) for p in problem.players))

    def kept(self, world: World, a: int, b: int, problems: dict, held_before: frozenset[str]) -> tuple | None:
        """The pair's last equilibrium, shifted and restarted from the measured states, as (plans,
        exit lanes) when it still answers the game ``problems`` (module docstring); else None."""
        key = (world.ids[a], world.ids[b])
        last = self._last.get(key)
        if last is None or len(problems) != 1 or last.combo not in problems:
            return None
        problem: Problem = problems[last.combo]
        if (last.age + 1 >= self.policy.game_resolve_steps or problem.interactions != last.interactions
                or any(p.crossers for p in problem.players) or key[0] in held_before or key[1] in held_before):
            return None
        plans = self.memory.warm_start(GameKey(*key, *last.combo), world.time)
        if plans is None or not all(self._on_plan(world, k, plan, pl, then) for k, plan, pl, then in
                                    zip((a, b), plans, problem.players, last.v_max)):
            return None
        if not self._apart(plans, problem.interactions):
            return None
        lag = (last.age + 1) * self.memory.shift  # [plan steps] since the solve
        for then, now in zip(last.leaders, (p.leader for p in problem.players)):
            if (then is None) != (now is None) or (now is not None and prediction_moved(
                    then, now, lag, self.policy.solo_leader_tol)):
                return None
        self._last[key] = last._replace(age=last.age + 1)
        return tuple(self.memory.from_state(world, k, plan.accelerations) for k, plan in zip((a, b), plans)), last.combo

    def _apart(self, plans: tuple, interactions: tuple) -> bool:
        """Whether, by ``plans``, the players arrive at each of their conflict points at least
        ``game_reuse_gap`` [s] apart (a player not there within the horizon: at its end, the
        earliest it may arrive)."""
        for it in interactions:
            if it.lateral and abs(arrival(plans[it.i], it.s_cp_i) - arrival(plans[it.j], it.s_cp_j)) < \
                    self.policy.game_reuse_gap:
                return False
        return True

    def _v_max(self, player) -> float:
        """[m/s] ``player``'s v_max, the model's where it has none."""
        return player.v_max if player.v_max is not None else self.v_max

    def _on_plan(self, world: World, k: int, plan: Plan, player, v_max_then: float) -> bool:
        """Whether vehicle k is where ``plan`` (shifted) puts it and the plan keeps its speed cap
        (``v_max_then`` [m/s]: the cap it was solved for, games.problem.keeps_speed_cap)."""
        return (abs(plan.speeds[0] - float(world.v[k])) <= self.policy.solo_speed_tol
                and abs(plan.positions[0] - float(world.s[k])) <= self.policy.solo_position_tol
                and keeps_speed_cap(plan, self._v_max(player), v_max_then))


def arrival(plan: Plan, s_point: float) -> float:
    """[s] when ``plan`` first reaches arc length ``s_point`` [m] (0 if it is there already); the
    end of its horizon when it does not within it."""
    reached = np.flatnonzero(plan.positions >= s_point)
    return float(reached[0] if reached.size else plan.steps) * plan.dt
