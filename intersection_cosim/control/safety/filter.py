"""The safety filter: the junction guard under the game controllers' decisions (not in the paper).

The paper's running cost makes collisions expensive, not impossible: J_lat and J_log are bounded
by 1 / eps, so two aggressive players (Case 1 D) can find an equilibrium in which both cross the
conflict point at nearly the same time, and an aggressive follower can plan into its leader. SUMO
never lets that happen to its own vehicles (its safe-speed and right-of-way checks, which the
controller switches off); this filter is the controller's equivalent. Every control step it runs
the named rules of :data:`~intersection_cosim.control.safety.rules.RULES` on the step's plans and
decided accelerations, each rule enforcing one stated invariant (a safety rule) or resolving a
lock the invariants alone could cause (a liveness rule), and returns a frozen
:class:`~intersection_cosim.control.safety.step.SafetyResult`. It lowers accelerations, and raises
one only to let a vehicle standing in a crossing drive out of it.

Its one memory across steps is the junction's entry queue (who entered when), which ranks the
vehicles inside the junction first in, first out. Under it every commanded vehicle also has its
onboard guard (control/safety/onboard.py), which the simulator adapter applies every SUMO step
against whatever vehicle is ahead, tracked or not.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Mapping

import numpy as np

from intersection_cosim.control.base import World
from intersection_cosim.control.game.relations import Relations
from intersection_cosim.control.safety.context import GuardedJunction, StepContext
from intersection_cosim.control.safety.kinematics import braking_plan
from intersection_cosim.control.safety import rules as rule_set
from intersection_cosim.control.safety.rules import Rule
from intersection_cosim.control.safety.rules.leader_gap import NAME as LEADER_GAP
from intersection_cosim.control.safety.step import FilterStep, SafetyResult
from intersection_cosim.games.problem import Plan
from intersection_cosim.network.movements import PASSING, READY

LOOKS = 2  # [-] looks at the crossings a step: the second sees the vehicles the first braked


class SafetyFilter:
    """The rules of ``rules`` (default :data:`RULES`) on one junction, with its entry queue and the
    run's counters."""

    def __init__(self, junction: GuardedJunction, rules: tuple[Rule, ...] | None = None):
        self.junction = junction
        self.rules = rule_set.RULES if rules is None else rules
        self.entered: dict[str, float] = {}  # [s] when each vehicle entered the junction (the queue)
        self.filtered = 0  # [-] accelerations the filter lowered
        self.cleared = 0  # [-] accelerations it raised to let a vehicle drive out of a crossing
        self.pedestrian_holds = 0  # [-] control steps x vehicles held back for a pedestrian

    def record_entries(self, world: World) -> None:
        """Put vehicles that entered the junction ("passing") into the entry queue, and take out a
        vehicle read standing (below ``clear_speed``) before its stop line again ("ready"): read
        over a noisy link, a vehicle waiting at its line flickers across it, and a first flicker
        must not rank it, for good, ahead of every vehicle that entered later (it would hold
        them while it waits for them: a lock). Exact positions never go back, so without noise
        the queue is as before."""
        clear_speed = self.junction.settings.clear_speed  # [m/s]
        for k in range(len(world)):
            if world.role[k] == PASSING:
                self.entered.setdefault(world.ids[k], world.time)
            elif world.role[k] == READY and float(world.v[k]) < clear_speed:
                self.entered.pop(world.ids[k], None)

    def release(self, vehicle: str) -> None:
        """Forget a vehicle that left the junction's paths."""
        self.entered.pop(vehicle, None)

    def apply(self, world: World, relations: Relations, plans: Mapping[str, Plan], options: Mapping[str, str],
              accel: Mapping[str, float], games: frozenset[tuple[str, str]] = frozenset()) -> SafetyResult:
        """The rules on this step's decided accelerations ``accel`` [m/s^2] and the ``plans`` they
        come from; ``options``: the exit lane each vehicle takes; ``games``: sorted vehicle-id pairs
        that play their game this step (none in a fallback step, whose plans are the last ones
        shifted)."""
        ctx = self._context(world, relations, plans, options, accel, games)
        step = FilterStep(plans=dict(plans), brakes=ctx.brakes(), queue=dict(self.entered))
        for rule in self.rules:
            if not rule.each_look:
                rule.run(ctx, step)
        for _look in range(LOOKS):
            self._replan(step)
            for rule in self.rules:
                if rule.each_look:
                    rule.run(ctx, step)
        self.pedestrian_holds += step.pedestrian_holds
        return self._result(ctx, step)

    def _context(self, world: World, relations: Relations, plans: Mapping[str, Plan], options: Mapping[str, str],
                 accel: Mapping[str, float], games: frozenset[tuple[str, str]]) -> StepContext:
        rows = relations.rows
        chosen = np.array([rows.option[r] == options.get(world.ids[rows.vehicle[r]], rows.option[r])
                           for r in range(len(rows))], bool)
        relations = self._widened(relations)
        pairs = relations.pairs
        guarded = np.flatnonzero(chosen[pairs.ri] & chosen[pairs.rj]) if len(pairs) else np.zeros(0, np.intp)
        return StepContext(self.junction, world, relations, plans, options, accel, chosen, guarded, games,
                           dict(self.entered))

    def _widened(self, relations: Relations) -> Relations:
        """``relations`` with every crossing zone widened by the junction's ``gap_slack`` [m] at
        both ends (position noise: a vehicle read just short of a zone may be in it)."""
        pairs, slack = relations.pairs, self.junction.gap_slack
        if slack <= 0.0 or not len(pairs):
            return relations
        widen = np.array([-slack, slack])  # [m]
        return dataclasses.replace(relations, pairs=dataclasses.replace(
            pairs, zone_i=pairs.zone_i + widen, zone_j=pairs.zone_j + widen))

    def _replan(self, step: FilterStep) -> None:
        """The plans the crossing rules check next: a vehicle that must drive out at a constant
        ``clear_accel``, a capped one braking at its cap (no harder than it may) to a stop."""
        st, a_min = self.junction.settings, self.junction.problem.a_min
        for vid in step.clear:
            if vid in step.plans and float(step.plans[vid].accelerations[0]) < st.clear_accel:
                step.plans[vid] = braking_plan(step.plans[vid], st.clear_accel)
        for vid in step.caps:
            limit = step.cap(vid)
            if vid in step.plans and limit < float(step.plans[vid].accelerations[0]):
                step.plans[vid] = braking_plan(step.plans[vid], max(limit, step.brakes.get(vid, a_min)))

    def _result(self, ctx: StepContext, step: FilterStep) -> SafetyResult:
        """The decided accelerations with the step's caps and drive-outs enforced, and the caps on
        the junction's guests (each no harder than the braking counted on for it)."""
        st, a_min = self.junction.settings, self.junction.problem.a_min
        out, lowered, raised, held = dict(ctx.accel), {}, {}, set()
        for vid, rule in step.clear.items():
            if vid in out and out[vid] < st.clear_accel:
                out[vid] = min(st.clear_accel, step.cap(vid))
                raised[vid] = rule
                self.cleared += 1
        for vid in step.caps:
            limit = step.cap(vid)
            if vid in out and limit < out[vid]:
                out[vid] = max(limit, step.brakes.get(vid, a_min))
                lowered[vid] = step.binding(vid)
                self.filtered += 1
                if limit < step.caps[vid].get(LEADER_GAP, math.inf):  # held by more than its leader
                    held.add(vid)
        guests = {vid: max(step.cap(vid), step.brakes.get(vid, a_min)) for vid in ctx.guest_ids if vid in step.caps}
        return SafetyResult(out, lowered, raised, frozenset(held), frozenset(step.events),
                            frozenset(step.stall_held), step.pedestrian_holds, guests)
