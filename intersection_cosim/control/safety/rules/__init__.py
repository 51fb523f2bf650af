"""The safety filter's rules, in the order :meth:`SafetyFilter.apply` runs them.

Safety rules keep what must never happen from happening; liveness rules resolve the locks that the
safety rules alone could cause. The rules before ``crossing_order`` run once a step, the crossing
rules in each of the filter's two looks (the second sees the vehicles the first braked).
:func:`rule_table` gives each rule's row of the docs (from its module's docstring).
"""

from __future__ import annotations

from intersection_cosim.control.safety.rules import (box_clear, crossing_order, exit_room, human_crossing,
                                                     lane_speed_limit, leader_gap, pedestrians,
                                                     priority_inheritance, stalled_box, standing_obstacle)
from intersection_cosim.control.safety.rules.base import LIVENESS, SAFETY, Rule, describe

RULES: tuple[Rule, ...] = (
    pedestrians.RULE,  # first: its emergency stops are braking the leader rule counts on
    leader_gap.RULE,
    lane_speed_limit.RULE,
    exit_room.RULE,
    priority_inheritance.RULE,  # before the crossings: the ranks they read
    human_crossing.RULE,
    standing_obstacle.RULE,
    stalled_box.RULE,
    crossing_order.RULE,
    box_clear.RULE,
)


def rule_table() -> list[dict[str, str]]:
    """One row per rule of :data:`RULES` (name, kind, invariant, trigger, action, setting, test)."""
    return [describe(rule) for rule in RULES]


__all__ = ["LIVENESS", "RULES", "SAFETY", "Rule", "rule_table"]
