"""exit_room: A vehicle enters its junction only if its exit lane will have room for its body and a
standstill gap when it gets there, so it never stops inside the box blocking others' crossings.

Trigger: a vehicle not yet in the junction whose exit lane has less free length (from its start to
the rear of its last vehicle, that vehicle driving on at its speed until the entrant reaches its
stop line) than its length plus ``exit_min_gap``, counting the vehicles standing in the junction
towards that lane and those ahead of it let go this step.

Action: holds it ``margin`` before its stop line, braking from the last moment at which
``[controller.game] comfort_brake`` still stops it there; nothing for one that can no longer stop
there.

Setting: ``[controller.safety] exit_room``, ``exit_min_gap``, ``margin``.

Test: tests/control/safety/test_rules.py::test_no_entry_towards_a_full_exit_lane
"""

from __future__ import annotations

from intersection_cosim.control.safety.context import StepContext
from intersection_cosim.control.safety.exit_room import exit_room_caps
from intersection_cosim.control.safety.rules.base import SAFETY, Rule
from intersection_cosim.control.safety.step import FilterStep

NAME = "exit_room"


def run(ctx: StepContext, step: FilterStep) -> None:
    st, j = ctx.settings, ctx.junction
    if not st.exit_room:
        return
    caps = exit_room_caps(ctx.world, j.movements, ctx.options, j.model.vehicle_length, st.exit_min_gap, st.margin,
                          j.problem.comfort_brake, j.problem.a_min, j.period, st.clear_speed)
    for vid, a in caps.items():
        if vid in ctx.accel:
            step.lower(vid, a, NAME)


RULE = Rule(NAME, SAFETY, run)
