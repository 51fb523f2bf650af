"""box_clear: A vehicle standing inside a crossing zone that another vehicle waits for drives out of
it, so a wait for a vehicle in the box always ends (the wait it causes is one the crossing rule
chose, and the box empties).

Trigger: this look of ``crossing_order`` made a vehicle stay out of a crossing (or found a human
waiting, as SUMO makes it, for an AV in the box) for another vehicle whose front is inside its
zone of that crossing below ``clear_speed``.

Action: that vehicle accelerates at least ``clear_accel`` (its own plan may wait for the other, as
a game played before the wait can say), unless another rule's cap holds it back; the next look of
the crossings sees it driving on.

Setting: ``[controller.safety] clear_accel``, ``clear_speed``.

Test: tests/control/test_safety_filter.py::test_the_entry_queue_and_the_box_rule
"""

from __future__ import annotations

from intersection_cosim.control.safety.context import StepContext
from intersection_cosim.control.safety.rules.base import LIVENESS, Rule
from intersection_cosim.control.safety.step import FilterStep

NAME = "box_clear"


def run(ctx: StepContext, step: FilterStep) -> None:
    world, slow = ctx.world, ctx.settings.clear_speed
    for wait in step.waits:
        if float(world.s[wait.other]) >= wait.other_enter and float(world.v[wait.other]) < slow:
            step.drive_out(world.ids[wait.other], NAME)
    step.waits.clear()


RULE = Rule(NAME, LIVENESS, run, each_look=True)
