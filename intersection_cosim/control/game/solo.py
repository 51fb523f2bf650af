"""Vehicles in no game: their own best response (k_lat = 0: J_log and J_e only) and its
event-triggered re-planning.

A solo vehicle minimises its own cost against its leader's predicted trajectory, choosing its
exit lane among its own options (J_lk, Eq. 23). It re-plans only when an input of that problem
moved, else keeps its last plan shifted, which answers the same problem seen one period later
(in the spirit of the paper's ETM; :meth:`SoloPlanner.reusable`). Its SQP runs as a real-time
iteration: ``solo_max_iter`` steps per control period, continued from the applied plan at the
next period.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from typing import NamedTuple

import numpy as np

from intersection_cosim.games import budget_clock
from intersection_cosim.control.game.anytime import BatchTimeEstimate
from intersection_cosim.control.base import World
from intersection_cosim.control.game.lane_options import LaneChangeCosts
from intersection_cosim.control.game.plan_memory import PlanMemory, SoloKey
from intersection_cosim.control.game.players import player, prediction_moved
from intersection_cosim.control.game.relations import Relations
from intersection_cosim.games.solo_batch import solo_responses
from intersection_cosim.games.problem import Plan, Player, Problem, keeps_speed_cap, safe_plan
from intersection_cosim.control.game.settings import GameControllerSettings
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.movements import Movements

log = logging.getLogger(__name__)


class SoloOutcome(NamedTuple):
    plan: Plan
    option: str  # exit lane
    deferred: bool  # past the cutoff: the last plan kept, shifted


class _LastSolve(NamedTuple):
    age: int  # control steps since the solve
    option: str  # exit lane solved for
    leader: tuple | None  # the leader prediction (s [m], v [m/s]) the plan answered
    v_max: float  # [m/s] the speed cap v_max solved for (the player's, else the model's)


class SoloPlanner:
    """Solo best responses of one controller, with what each vehicle's last solve answered."""

    def __init__(self, settings: GameControllerSettings, model: ModelSettings, memory: PlanMemory,
                 lane_costs: LaneChangeCosts, movements: Movements):
        self.settings, self.policy, self.model, self.memory = settings, settings.policy, model, memory
        self.lane_costs, self.paths = lane_costs, movements.paths
        # a solo vehicle's SQP stops after solo_max_iter steps and goes on at the next period
        self.solo_gs = GameSettings(settings.game, dataclasses.replace(settings.solver,
                                                                       nash_max_iter=settings.policy.solo_max_iter))
        self._last: dict[str, _LastSolve] = {}

    def forget(self, vehicle: str) -> None:
        """Drop a vehicle's last solve (it left, joined a game, or its plan must be solved anew)."""
        self._last.pop(vehicle, None)

    def plan_all(self, world: World, ks: list[int], options, relations: Relations, held_before: frozenset[str],
                 estimate: BatchTimeEstimate, cutoff: float) -> dict[int, SoloOutcome]:
        """Best responses of the solo vehicles ``ks`` (most urgent first), each with its exit-lane
        choice among ``options[k]``: a vehicle whose problem did not change keeps its plan
        (:meth:`reusable`); the others are solved together (games.solo_batch), as many as the
        anytime schedule fits before ``cutoff`` (budget_clock.now); past it a vehicle with a plan keeps
        it, shifted. Every vehicle's leader enters as its plan of the last step (shifted), the
        Jacobi order: no solo vehicle sees another's plan of this step. ``held_before``: the
        vehicles the safety filter held back at a crossing at the last step."""
        out: dict[int, SoloOutcome] = {}
        jobs = []  # (k, {option: Player}) to solve
        for k in ks:
            players = {o: player(world, k, o, relations, self.memory) for o in options[k]}
            if len(players) == 1:
                (o, pl), = players.items()
                kept = self.reusable(world, k, o, pl, held_before)
                if kept is not None:
                    out[k] = SoloOutcome(kept, o, False)
                    continue
            jobs.append((k, players))
        units, solved = 0, []
        for k, players in jobs:
            units += len(players)
            if world.ids[k] in self.memory.plans and not estimate.fits(units, cutoff):
                units -= len(players)
                out[k] = self._defer(world, k, estimate)
            else:
                solved.append((k, players))
        if solved:
            t0 = budget_clock.now()
            outcomes = self._solve_all(world, solved, held_before)
            estimate.measured(units, budget_clock.now() - t0)
            out.update(outcomes)
        return out

    def _defer(self, world: World, k: int, estimate: BatchTimeEstimate) -> SoloOutcome:
        """Vehicle k keeps its last plan, shifted (its solve does not fit the step)."""
        vid = world.ids[k]
        estimate.deferred()
        self.forget(vid)
        default = self.paths[world.path_ids[k]].exit_lane
        return SoloOutcome(self.memory.kept_plan(world, k, self.settings.game.comfort_brake),
                           self.memory.held_option(vid, default), True)

    def _solve_all(self, world: World, jobs: list, held_before: frozenset[str]) -> dict[int, SoloOutcome]:
        """Every (vehicle, exit lane) problem of ``jobs`` in one batch, then each vehicle's lane
        choice among its results (:func:`cheapest`) and the plan it drives."""
        problems, warms, index = [], [], []
        for k, players in jobs:
            costs = self.lane_costs.costs(world.path_ids[k], tuple(players)) if len(players) > 1 else {}
            for o, pl in players.items():
                if costs:  # J_lk of the option enters its running cost, as lane_choice_game does
                    pl = dataclasses.replace(pl, j_lk=float(costs.get(o, 0.0)))
                problems.append(Problem((pl,), ()))
                warms.append(self._warm(world.ids[k], o, world.time))
                index.append((k, o))
        results = dict(zip(index, solo_responses(problems, self.solo_gs, self.model, warms)))
        out = {}
        for k, players in jobs:
            vid = world.ids[k]
            mine = {(o,): results[(k, o)] for o in players}
            for (o,), res in mine.items():
                if res.status != "solver failure":
                    self.memory.store(SoloKey(vid, o), world.time, res.plans)
            choice = cheapest(mine)
            result = mine[choice]
            out[k] = SoloOutcome(self._accept(world, vid, result, choice[0], players[choice[0]], held_before),
                                 choice[0], False)
        return out

    def _warm(self, vid: str, option: str, now: float):
        """Warm start of ``vid``'s solo problem for exit lane ``option`` at ``now`` [s]: the plan
        it drives (maybe a game's), else its last solo plan, else None (a cold start)."""
        if (driven := self.memory.driven_plan(vid, option)) is not None:
            return (driven,)
        return self.memory.warm_start(SoloKey(vid, option), now)

    def _accept(self, world: World, vid: str, result, option: str, chosen: Player, held_before) -> Plan:
        """The plan to apply for exit lane ``option`` (solved as player ``chosen``), and whether the
        next step may reuse it."""
        if result.status == "solver failure":
            log.warning("t=%.2f s: best response of %s failed (%s); braking comfortably",
                        world.time, vid, result.message)
            self.forget(vid)
            return safe_plan(chosen, self.settings.games)
        settled = max(self.settings.solver.nash_tol, self.policy.solo_reuse_residual)  # [m/s^2]
        if (result.status != "converged" and vid not in held_before
                and not (result.residuals and result.residuals[-1] < settled)):
            # real-time iteration: the capped SQP continues from this plan at the next step. A
            # capped step that moved the plan less than nash_tol (or solo_reuse_residual) counts
            # as converged, and so does the plan of a vehicle the filter holds back (its plan is
            # only the intent the filter checks)
            self.forget(vid)
        else:
            self._last[vid] = _LastSolve(0, option, chosen.leader, self._v_max(chosen))
        return result.plans[0]

    def reusable(self, world: World, k: int, option: str, player_now: Player,
                 held_before: frozenset[str]) -> Plan | None:
        """The last plan, shifted and re-anchored at the measured state, when the problem is the
        last solve's problem moved on in time; None when it must be solved again.

        It is the same problem when the measured state is where the last plan put it (within
        ``solo_position_tol`` [m] and ``solo_speed_tol`` [m/s]) and the
        leader's prediction is the one it answered (shifted, within ``solo_leader_tol``, or
        moved only where J_log is zero along the plan), and the shifted plan stays within the
        speed limits; at the latest after ``free_resolve_steps`` steps it is solved again. A
        vehicle the safety filter held back at a crossing is off its plan by the filter's doing,
        so its plan (its intent, which the filter goes on checking) is kept until it is due.
        """
        vid = world.ids[k]
        last, plan = self._last.get(vid), self.memory.plans.get(vid)
        if last is None or plan is None:
            return None
        if player_now.crossers:  # a human's forecast moves with its measured state: solve again
            return None
        if (last.age + 1 >= self.policy.free_resolve_steps or last.option != option
                or self.memory.options.get(vid) != option or (last.leader is None) != (player_now.leader is None)):
            return None
        plan = self.memory.shifted(plan)
        off_plan = vid not in held_before and (
            abs(plan.speeds[0] - float(world.v[k])) > self.policy.solo_speed_tol
            or abs(plan.positions[0] - float(world.s[k])) > self.policy.solo_position_tol)
        if off_plan or not keeps_speed_cap(plan, self._v_max(player_now), last.v_max):
            return None
        if player_now.leader is not None and self._leader_moved(plan, last, player_now.leader,
                                                                 player_now.leader_length):
            return None
        self._last[vid] = last._replace(age=last.age + 1)
        return self.memory.anchored(world, k)  # the shifted plan above, from the measured state

    def _v_max(self, player: Player) -> float:
        """[m/s] ``player``'s v_max, the model's where it has none."""
        return player.v_max if player.v_max is not None else self.model.v_max

    def _leader_moved(self, plan: Plan, last: _LastSolve, leader_now: tuple, length: float | None = None) -> bool:
        """Whether the leader's prediction moved since the solve where it matters to ``plan``
        (``length`` [m]: the leader's body, None: the model's)."""
        lag = (last.age + 1) * self.memory.shift  # [steps] since the solve
        s_then, v_then = last.leader
        s_now, v_now = leader_now
        if len(s_now) <= lag:
            return True
        moved = prediction_moved(last.leader, leader_now, lag, self.policy.solo_leader_tol)
        # a moved prediction matters only where it enters the cost: J_log is zero along a plan
        # that is never faster than the leader and never overlaps it, under the old prediction
        # (so the plan did not answer it) and the new one (so it need not)
        return moved and not (self._leader_inactive(plan, s_then[lag:], v_then[lag:], length)
                              and self._leader_inactive(plan, s_now, v_now, length))

    def _leader_inactive(self, plan: Plan, s_lead: np.ndarray, v_lead: np.ndarray, length: float | None = None) -> bool:
        """True when J_log (Eqs. 15-18) is zero along ``plan`` against a leader predicted at
        ``s_lead`` (follower frame, front) [m] and ``v_lead`` [m/s] over the plan's first steps:
        the follower is never faster than the leader (TTC_log infinite) and never overlaps it."""
        n = len(s_lead)
        v, s = plan.speeds[1:n + 1], plan.positions[1:n + 1]
        body = self.model.vehicle_length if length is None else length  # [m]
        return bool(np.all(v <= v_lead) and np.all(s_lead - body - s >= 0.0))


def cheapest(results: dict) -> tuple:
    """The exit lane of a solo vehicle: the option whose solve has the least true cost (its J_lk
    included), the first of equals; the first when every solve failed. This is
    games.lane_choice.lane_choice_game's pure equilibrium for one player."""
    best, best_cost = None, math.inf
    for combo, res in results.items():
        cost = math.inf if res.status == "solver failure" else float(res.costs[0])
        if best is None or cost < best_cost:
            best, best_cost = combo, cost
    return best
