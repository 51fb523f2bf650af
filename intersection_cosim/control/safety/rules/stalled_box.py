"""stalled_box: No AV enters a crossing of a vehicle that stalls in the junction short of leaving
that crossing, and the stalled vehicle drives on: a stalled box takes no new entrant into its
crossings, so the waits inside it cannot grow into a cycle.

Trigger: a guarded crossing of an AV not yet in the junction (role ready, front in none of its
crossing zones, near enough its stop line to stop there braking at ``[controller.game]
comfort_brake``) and an AV in the junction below ``clear_speed`` now, or within
``stalled_box_lookahead`` at its present deceleration, that has not left its zone.

Action: holds the entrant ``margin`` before its stop line (nothing for one that can no longer
stop there); the stalled vehicle drives out (as for ``box_clear``), since its own plan may wait
for the entrant.

Setting: ``[controller.safety] stalled_box_hold``, ``stalled_box_lookahead``, ``clear_speed``.

Test: tests/control/safety/test_rules.py::test_a_stalled_box_holds_an_entrant
"""

from __future__ import annotations

import numpy as np

from intersection_cosim.control.safety.context import StepContext
from intersection_cosim.control.safety.rules.base import LIVENESS, Rule
from intersection_cosim.control.safety.step import FilterStep

NAME = "stalled_box"


def _holds(ctx: StepContext) -> set[tuple[int, float, int]]:
    """(entrant, [m] its stop line, the stalled vehicle) of every hold."""
    world, st, j = ctx.world, ctx.settings, ctx.junction
    pairs, rows, guarded = ctx.relations.pairs, ctx.relations.rows, ctx.guarded
    inside = ctx.avs_entered()
    entrant = np.array([vid not in ctx.entered and not world.is_human(k) and world.role[k] == "ready"
                        for k, vid in enumerate(world.ids)], bool)
    v = np.asarray(world.v)  # [m/s]
    soon = v + np.minimum(np.asarray(world.a), 0.0) * st.stalled_box_lookahead  # [m/s]
    stalled = inside & (np.minimum(v, soon) < st.clear_speed)
    reach = v * v / (2.0 * j.problem.comfort_brake) + v * j.period + 2.0 * st.margin  # [m]
    in_zone = np.zeros(len(world.ids), bool)  # its front inside one of its crossing zones
    for r, zone in ((pairs.ri[guarded], pairs.zone_i[guarded]), (pairs.rj[guarded], pairs.zone_j[guarded])):
        k = rows.vehicle[r]
        in_zone[k[(zone[:, 0] <= world.s[k]) & (world.s[k] < zone[:, 1])]] = True
    entrant &= ~in_zone
    held = set()
    for r_e, r_o, zone_o in ((pairs.ri, pairs.rj, pairs.zone_j), (pairs.rj, pairs.ri, pairs.zone_i)):
        ke, ko = rows.vehicle[r_e[guarded]], rows.vehicle[r_o[guarded]]
        s_stop = j.s_stop[rows.pidx[r_e[guarded]]]  # [m]
        near = s_stop - world.s[ke] <= reach[ke]
        m = entrant[ke] & stalled[ko] & (world.s[ko] < zone_o[guarded][:, 1]) & near
        held.update(zip(ke[m].tolist(), s_stop[m].tolist(), ko[m].tolist()))
    return held


def run(ctx: StepContext, step: FilterStep) -> None:
    if not ctx.settings.stalled_box_hold or not len(ctx.guarded) or not ctx.entered:
        return
    ids = ctx.world.ids
    for k, s_stop, o in sorted(_holds(ctx)):
        a = ctx.stop_short_of(k, s_stop, s_stop, ctx.settings.margin)
        if a is None:
            continue
        if a < step.cap(ids[k]):
            step.stall_held.add(ids[k])
        step.lower(ids[k], a, NAME)
        step.drive_out(ids[o], NAME)


RULE = Rule(NAME, LIVENESS, run)
