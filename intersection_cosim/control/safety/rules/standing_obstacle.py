"""standing_obstacle: A commanded vehicle never drives into the body of a vehicle it does not
command that stands: it stops ``margin`` short of the first point of its path at which its own
body would touch the standing body, wherever that vehicle is (in the box, on another lane, a
human, a guest, one whose path the conflict table does not know) and whatever the crossing rules
rank. Two commanded vehicles are kept apart by the crossing rules, which check both plans.

Trigger: a vehicle the filter decides for, and a vehicle of the junction's World it does not
decide for, below ``clear_speed`` on another SUMO lane (the same lane is the leader rules' and the
onboard guard's)
whose body its own body, swept along its path from where it is now over its braking reach and
``LOOKAHEAD``, would
touch; a body it touches already where it stands is left to the rules that clear the box.

Action: caps its acceleration to stop ``margin`` before the first touching point (one sample of
``SWEEP_STEP`` earlier), braking at most as hard as its braking; where it can no longer stop
there, it brakes as hard as it may.

Setting: ``[controller.safety] margin``, ``clear_speed``.

Test: tests/control/safety/test_rules.py::test_no_drive_into_a_standing_body
"""

from __future__ import annotations

import math

import numpy as np

from intersection_cosim.control.safety.context import StepContext
from intersection_cosim.control.safety.kinematics import stopping_acceleration
from intersection_cosim.control.safety.rules.base import SAFETY, Rule
from intersection_cosim.control.safety.step import FilterStep
from intersection_cosim.models.bodies import bodies_overlap, body_corners

NAME = "standing_obstacle"
SWEEP_STEP = 0.5  # [m] spacing of the swept body's samples along the path
LOOKAHEAD = 2.0  # [m] swept beyond the braking reach, so a stop starts before it must be hard


def first_touch(ctx: StepContext, k: int, o: int, reach: float) -> float | None:
    """[m] the arc length of vehicle k's front, along its path within ``reach`` [m] ahead of where
    it is, at which its body first overlaps standing vehicle o's body; None if it never does or
    already does at its present position."""
    world, model = ctx.world, ctx.junction.model
    path = ctx.junction.movements.paths[world.path_ids[k]]
    s0 = float(world.s[k])
    s = s0 + np.arange(0.0, reach + SWEEP_STEP, SWEEP_STEP)
    s = s[s <= path.length]
    if len(s) == 0:
        return None
    xy, heading = path.point_at(s), path.heading_at(s)
    n = len(s)
    mine = body_corners(xy[:, 0], xy[:, 1], heading, np.full(n, world.length_of(k, model.vehicle_length)),
                        np.full(n, _width(world, k, model.vehicle_width)))
    other = body_corners(world.x[o:o + 1], world.y[o:o + 1], world.heading[o:o + 1],
                         np.array([world.length_of(o, model.vehicle_length)]),
                         np.array([_width(world, o, model.vehicle_width)]))
    touch = np.flatnonzero(bodies_overlap(mine, other))
    if len(touch) == 0 or touch[0] == 0:
        return None
    return float(s[touch[0]])


def _width(world, k: int, default: float) -> float:
    return float(default) if world.width is None else float(world.width[k])


def run(ctx: StepContext, step: FilterStep) -> None:
    world, st, j = ctx.world, ctx.settings, ctx.junction
    standing = np.flatnonzero(np.asarray(world.v) < st.clear_speed)
    if len(standing) == 0:
        return
    # a standing vehicle the filter decides for is not an obstacle (ctx.accel stays as it is here)
    others = [o for o in standing.tolist() if world.ids[o] not in ctx.accel]
    if not others:
        return
    model, index = j.model, {vid: k for k, vid in enumerate(world.ids)}
    for vid in ctx.accel:
        k = index.get(vid)
        if k is None or world.is_human(k) or world.path_ids[k] not in j.movements.paths:
            continue
        v_k, brake = float(world.v[k]), ctx.brake(k)  # [m/s], [m/s^2] (< 0)
        reach = v_k * j.period + v_k * v_k / (-2.0 * brake) + st.margin + LOOKAHEAD  # [m]
        length_k = world.length_of(k, model.vehicle_length)
        for o in others:
            if o == k or (world.lanes and world.lanes[o] == world.lanes[k]):
                continue
            far = math.hypot(float(world.x[o] - world.x[k]), float(world.y[o] - world.y[k]))
            if far > reach + length_k + world.length_of(o, model.vehicle_length):
                continue
            touch = first_touch(ctx, k, o, reach)
            if touch is None:
                continue
            a = stopping_acceleration(float(world.s[k]), v_k, touch - SWEEP_STEP - st.margin)
            step.lower(vid, brake if a is None or a < brake else a, NAME)


RULE = Rule(NAME, SAFETY, run)
