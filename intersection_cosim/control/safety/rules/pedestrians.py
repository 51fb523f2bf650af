"""pedestrians: A commanded vehicle is never on its stretch of a zebra crossing within
``pedestrian_time_gap`` of a person being on it, unless it can no longer stop (then it stops as
hard as its emergencyDecel allows at the crossing's edge, or drives on from deep inside).

Trigger: a person on, or walking onto, a crossing of the vehicle's path (any exit lane it may still
take) whose time on the vehicle's stretch comes within the gap of the vehicle's.

Action: holds the vehicle at its stop line if it has not reached it, else ``pedestrian_margin``
before the crossing (control/safety/pedestrians.py has the windows and the braking); a hold harder
than the vehicle's own braking is an emergency stop, which the other rules then count on.

Setting: ``[controller.safety] yield_to_pedestrians``, ``pedestrian_time_gap``,
``pedestrian_clearance``, ``pedestrian_margin``, ``pedestrian_speed_low``,
``pedestrian_speed_high``.

Test: tests/control/test_pedestrians.py::test_a_vehicle_too_close_to_stop_in_its_own_braking_makes_an_emergency_stop_for_a_person
"""

from __future__ import annotations

from intersection_cosim.control.safety.context import StepContext
from intersection_cosim.control.safety.pedestrians import pedestrian_holds
from intersection_cosim.control.safety.rules.base import SAFETY, Rule
from intersection_cosim.control.safety.step import FilterStep

NAME = "pedestrians"


def vehicle_limits(ctx: StepContext, k: int) -> tuple[float, float, float]:
    """[m/s^2] vehicle k's (hardest braking, strongest acceleration) in the game's bounds, and its
    hardest emergency braking (its vType's emergencyDecel; no harder than the first where the World
    carries none)."""
    p = ctx.junction.problem
    lo, hi = ctx.world.accel_limits(k, p.a_min, p.a_max)
    return lo, hi, min(lo, ctx.world.emergency_brake(k, lo))


def run(ctx: StepContext, step: FilterStep) -> None:
    j, world = ctx.junction, ctx.world
    if not ctx.settings.yield_to_pedestrians or not j.crossing_zones or not world.walkers:
        return
    relations = ctx.relations

    def leader_of(k: int, exit_lane: str) -> tuple[float, float] | None:
        row = relations.row_of.get((k, exit_lane))
        lead = None if row is None else relations.leaders.get(row)
        if lead is None:
            return None
        rear = float(world.s[lead.vehicle]) + lead.offset - world.length_of(lead.vehicle, j.model.vehicle_length)
        return rear, float(world.v[lead.vehicle])  # [m] in k's path, [m/s]

    holds = pedestrian_holds(world, j.movements, j.crossing_zones, ctx.options, ctx.plans, ctx.settings,
                             j.model.tcp_speed_floor, lambda k: vehicle_limits(ctx, k), j.problem.comfort_brake,
                             j.period, leader_of)
    step.pedestrian_holds += len(holds)
    index = {vid: k for k, vid in enumerate(world.ids)}
    for vid, a in holds.items():
        if a < vehicle_limits(ctx, index[vid])[0]:  # an emergency stop: the other rules count on it
            step.brakes[vid] = min(a, step.brakes.get(vid, j.problem.a_min))
        if vid in ctx.accel:
            step.lower(vid, a, NAME)


RULE = Rule(NAME, SAFETY, run)
