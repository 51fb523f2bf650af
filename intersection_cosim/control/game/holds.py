"""The caps the game controller hands its safety filter each step: the exit-room rule
(control/exit_room.py), the pedestrians at the crossings (control/pedestrians.py) and, with
ModelSettings.lane_speed_limits, the lane speed limits (control/speed_limits.py), the lowest per
vehicle [m/s^2]."""

from __future__ import annotations

import math
from typing import Mapping, NamedTuple

from intersection_cosim.control.base import ControlContext, World
from intersection_cosim.control.exit_room import exit_room_caps
from intersection_cosim.control.game.plan_memory import PlanMemory
from intersection_cosim.control.game.relations import Relations
from intersection_cosim.control.game.settings import GameControllerSettings
from intersection_cosim.control.pedestrians import pedestrian_holds
from intersection_cosim.control.speed_limits import lane_speed_holds
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.crossings import CrossingZone


class StepHolds(NamedTuple):
    """The holds of one step."""

    holds: dict[str, float]  # [m/s^2] the lowest cap per vehicle
    floors: dict[str, float]  # [m/s^2] the pedestrian caps that are emergency stops (harder than the
    #                           vehicle's own braking), which the filter applies as they are
    pedestrian_holds: int  # [-] vehicles a pedestrian held back


def step_holds(world: World, relations: Relations, ctx: ControlContext, settings: GameControllerSettings,
               model: ModelSettings, memory: PlanMemory, crossing_zones: Mapping[str, tuple[CrossingZone, ...]]
               ) -> StepHolds:
    """[m/s^2] the caps of the exit-room rule, of the pedestrians at the crossings
    (control/pedestrians.py) and, with ModelSettings.lane_speed_limits, of the lane speed
    limits (control/speed_limits.py), the lowest per vehicle; and [m/s^2] the pedestrian caps
    that are emergency stops (harder than the vehicle's own braking), which the filter applies
    as they are."""
    holds = exit_holds(world, ctx, settings, model, memory)
    period = ctx.control_period
    game, zones = settings.game, crossing_zones if settings.safety.yield_to_pedestrians else {}

    def leader_of(k: int, exit_lane: str) -> tuple[float, float] | None:
        row = relations.row_of.get((k, exit_lane))
        lead = None if row is None else relations.leaders.get(row)
        if lead is None:
            return None
        rear = float(world.s[lead.vehicle]) + lead.offset - world.length_of(lead.vehicle, model.vehicle_length)
        return rear, float(world.v[lead.vehicle])  # [m] in k's path, [m/s]

    others = [pedestrian_holds(world, ctx.movements, zones, memory.options, memory.plans,
                               settings.safety, model.tcp_speed_floor,
                               lambda k: vehicle_limits(world, k, settings), game.comfort_brake, period, leader_of)]
    n_pedestrian = len(others[0])
    floors = {}
    if others[0]:  # the holds harder than the vehicle's own braking: emergency stops
        index = {vid: k for k, vid in enumerate(world.ids)}
        floors = {vid: cap for vid, cap in others[0].items() if cap < vehicle_limits(world, index[vid], settings)[0]}
    if model.lane_speed_limits:
        others.append(lane_speed_holds(world, ctx.movements, memory.options, model.lane_speed_decel, period))
    for caps in others:
        for vid, cap in caps.items():
            holds[vid] = min(cap, holds.get(vid, math.inf))
    return StepHolds(holds, floors, n_pedestrian)


def vehicle_limits(world: World, k: int, settings: GameControllerSettings) -> tuple[float, float, float]:
    """[m/s^2] vehicle k's (hardest braking, strongest acceleration) in the game's bounds, and
    its hardest emergency braking (its vType's emergencyDecel; no harder than the first where
    the World carries none)."""
    game = settings.game
    lo, hi = world.accel_limits(k, game.a_min, game.a_max)
    return lo, hi, min(lo, world.emergency_brake(k, lo))


def exit_holds(world: World, ctx: ControlContext, settings: GameControllerSettings, model: ModelSettings,
               memory: PlanMemory) -> dict[str, float]:
    """[m/s^2] caps that keep vehicles whose exit lane is full at their stop lines."""
    st = settings.safety
    if not st.exit_room:
        return {}
    return exit_room_caps(world, ctx.movements, memory.options, model.vehicle_length,
                          st.exit_min_gap, st.safety_margin, settings.game.comfort_brake,
                          settings.game.a_min, ctx.control_period, st.clear_speed)
