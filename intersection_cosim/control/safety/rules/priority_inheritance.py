"""priority_inheritance: A vehicle in the junction that stands inside the crossing zone of another
vehicle in the junction waiting short of it ranks just ahead of that vehicle (inheriting its entry
time, along chains), so it goes first and clears the way: without it the blocker could wait for a
third vehicle the blocked one ranks ahead of, and the waits close a cycle.

Trigger: two AVs in the entry queue of a guarded crossing, one below ``clear_speed`` short of its
zone, the other's front inside its own zone of that crossing.

Action: the blocker's entry time (the rank the crossing rules read) becomes the waiting one's less
``INHERIT_AHEAD``; human drivers neither pass nor inherit a rank.

Setting: ``[controller.safety] clear_speed``.

Test: tests/control/test_safety_filter.py::test_a_vehicle_standing_in_the_first_ones_crossing_goes_before_the_vehicles_it_ranks_behind
"""

from __future__ import annotations

from intersection_cosim.control.safety.context import StepContext
from intersection_cosim.control.safety.rules.base import LIVENESS, Rule
from intersection_cosim.control.safety.step import FilterStep

NAME = "priority_inheritance"
INHERIT_AHEAD = 1e-6  # [s] an inheriting vehicle ranks this far ahead of the one it blocks (no tie for ids to decide)


def run(ctx: StepContext, step: FilterStep) -> None:
    queue, guarded, world = step.queue, ctx.guarded, ctx.world
    if not len(guarded) or not queue:
        return
    pairs, vehicle, ids = ctx.relations.pairs, ctx.relations.rows.vehicle, world.ids
    inside = ctx.avs_entered()
    ks = (vehicle[pairs.ri[guarded]], vehicle[pairs.rj[guarded]])
    zones = (pairs.zone_i[guarded], pairs.zone_j[guarded])
    links = []  # (the waiting vehicle, the one standing in its crossing)
    for w, b in ((0, 1), (1, 0)):
        s_w, s_b = world.s[ks[w]], world.s[ks[b]]
        m = (inside[ks[w]] & inside[ks[b]] & (world.v[ks[w]] < ctx.settings.clear_speed)
             & (s_w < zones[w][:, 0]) & (zones[b][:, 0] <= s_b) & (s_b < zones[b][:, 1]))
        links += [(ids[x], ids[y]) for x, y in zip(ks[w][m].tolist(), ks[b][m].tolist())]
    for _ in range(len(links)):  # a chain is at most as long as the links
        changed = False
        for waiting, blocking in links:
            if queue[waiting] - INHERIT_AHEAD < queue[blocking]:
                queue[blocking], changed = queue[waiting] - INHERIT_AHEAD, True
        if not changed:
            break


RULE = Rule(NAME, LIVENESS, run)
