"""human_crossing: An AV not yet in the junction never enters a crossing in which a human driver
stands, will stop (braking at ``human_brake`` or harder), or may be held by SUMO at its waiting
position while the AV would still be in its way: inside, the AV would stop short of the human, in
others' crossings, while SUMO holds the human for the AV (a cycle no rule inside the box undoes).

Trigger: a guarded crossing of an AV (role ready, not in the entry queue, short of its zone) and a
human who stands in its zone, brakes to stop in it, or has not passed a waiting position inside
it (an internal junction where SUMO holds a turn for the opposing stream) while the AV's plan
leaves the zone less than ``time_gap`` before the human's forecast reaches it.

Action: holds the AV ``margin`` before its stop line (it stays at its line if it stands there);
nothing for an AV that can no longer stop there.

Setting: ``[controller.safety] human_brake``, ``time_gap``, ``margin``.

Test: tests/control/test_humans.py::test_an_av_waits_at_its_stop_line_while_a_human_brakes_to_stop_in_its_crossing
"""

from __future__ import annotations

import math

import numpy as np

from intersection_cosim.control.safety.context import StepContext
from intersection_cosim.control.safety.kinematics import occupancy, stopping_acceleration
from intersection_cosim.control.safety.rules.base import SAFETY, Rule
from intersection_cosim.control.safety.step import FilterStep
from intersection_cosim.games.problem import Plan
from intersection_cosim.models.cost import time_to_conflict_point

NAME = "human_crossing"


def human_stops_in(ctx: StepContext, h: int, zone_h: tuple[float, float], s_wait: float, plan_k: Plan | None,
                   zone_k: tuple[float, float]) -> bool:
    """Whether human h stands in its zone ``zone_h`` [m], brakes (``human_brake``) to stop in it, or
    may stop in it at its waiting position ``s_wait`` [m]: the last when it has not passed that
    position and the AV's ``plan_k`` does not leave its zone ``zone_k`` ``time_gap`` before the
    human's forecast reaches its zone (the AV would still be in the way)."""
    st, world, floor = ctx.settings, ctx.world, ctx.junction.model.tcp_speed_floor
    s_h, v_h, a_h = float(world.s[h]), float(world.v[h]), float(world.a[h])  # [m], [m/s], [m/s^2]
    if v_h < st.clear_speed:
        stop_h = s_h  # where it stands
    elif a_h <= -st.human_brake:
        stop_h = s_h + v_h * v_h / (2.0 * -a_h)  # where it will stop
    elif s_h < s_wait and zone_h[0] <= s_wait < zone_h[1] and plan_k is not None:
        in_h, _ = occupancy(ctx.plan_of(h, {}), *zone_h)
        if math.isinf(in_h):  # beyond the horizon: at its present speed (its forecast is no slower)
            in_h = time_to_conflict_point(zone_h[0] - s_h, v_h, floor)
        _, out_k = occupancy(plan_k, *zone_k)
        if math.isinf(out_k):  # beyond the horizon: on from the plan's end at its end speed
            out_k = plan_k.steps * plan_k.dt + time_to_conflict_point(
                zone_k[1] - float(plan_k.positions[-1]), float(plan_k.speeds[-1]), floor)
        return out_k + st.time_gap > in_h
    else:
        return False
    return zone_h[0] <= stop_h < zone_h[1]


def run(ctx: StepContext, step: FilterStep) -> None:
    world = ctx.world
    if world.human is None or not bool(np.any(world.human)):
        return
    st, j, rows, pairs = ctx.settings, ctx.junction, ctx.relations.rows, ctx.relations.pairs
    for m in ctx.guarded:
        lat = pairs.at(m)
        ki, kj = int(rows.vehicle[lat.ri]), int(rows.vehicle[lat.rj])
        for h, k, zone_h, rh, row, zone_k in ((ki, kj, lat.zone_i, lat.ri, lat.rj, lat.zone_j),
                                             (kj, ki, lat.zone_j, lat.rj, lat.ri, lat.zone_i)):
            if not world.is_human(h) or world.is_human(k) or world.role[k] != "ready" or world.ids[k] in ctx.entered:
                continue
            s_k, v_k = float(world.s[k]), float(world.v[k])
            if s_k >= zone_k[0] or not human_stops_in(ctx, h, zone_h, float(j.s_wait[rows.pidx[rh]]),
                                                      step.plans.get(world.ids[k]), zone_k):
                continue
            brake = ctx.brake(k)  # [m/s^2]
            a = stopping_acceleration(s_k, v_k, float(j.s_stop[rows.pidx[row]]) - st.margin)
            if a is None:  # at (or just past) its stop line: stay there
                a = max(brake, -v_k / j.period) if v_k < st.clear_speed else brake - 1.0
            if a >= brake:
                step.lower(world.ids[k], a, NAME)


RULE = Rule(NAME, SAFETY, run)
