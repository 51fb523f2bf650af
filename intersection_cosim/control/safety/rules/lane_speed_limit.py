"""lane_speed_limit: A commanded vehicle enters every lane of its path no faster than that lane's
speed limit, as SUMO's own drivers keep it (on by default: ``[model] lane_speed_limits``).

Trigger: a vehicle that would reach a lane with a lower limit (a tight turn's internal lane, a
slower exit road) too fast, on any exit lane it may still take, or that drives faster than the
limit of its lane.

Action: brakes it from the last moment at which ``[model] lane_speed_decel`` still slows it to the
limit at the lane's start, one control period ahead; on the lane it keeps to the limit.

Setting: ``[model] lane_speed_limits``, ``lane_speed_decel``.

Test: tests/control/test_speed_limits.py::test_with_limits_on_a_right_turner_plans_for_its_limit_and_is_held_to_it
"""

from __future__ import annotations

from intersection_cosim.control.safety.context import StepContext
from intersection_cosim.control.safety.rules.base import SAFETY, Rule
from intersection_cosim.control.safety.speed_limits import lane_speed_holds
from intersection_cosim.control.safety.step import FilterStep

NAME = "lane_speed_limit"


def run(ctx: StepContext, step: FilterStep) -> None:
    j = ctx.junction
    if not j.model.lane_speed_limits:
        return
    for vid, a in lane_speed_holds(ctx.world, j.movements, ctx.options, j.model.lane_speed_decel, j.period).items():
        if vid in ctx.accel:
            step.lower(vid, a, NAME)


RULE = Rule(NAME, SAFETY, run)
