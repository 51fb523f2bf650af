"""The onboard guard of :mod:`~intersection_cosim.control.safety.onboard`, sensed in SUMO.

Every SUMO step the adapter asks SUMO for the nearest vehicle ahead of each commanded vehicle
(``vehicle.getLeader``: along the vehicle's own lanes and the lanes it drives next, through
junctions, within the sensor range), whatever drives that vehicle, and caps the speed command by
:func:`~intersection_cosim.control.safety.onboard.guard_speed`. SUMO measures the leader's
distance from the vehicle's front plus its minGap to the leader's rear; the guard adds the minGap
back, so its gap is bumper to bumper.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType
from typing import Mapping

import libsumo

from intersection_cosim.control.safety.onboard import OnboardSettings, guard_speed

Body = tuple[float, float, float, float, float]  # length [m], width [m], accel, decel, emergency decel [m/s^2]


@dataclass
class OnboardGuard:
    """The guard of every commanded vehicle; ``caps`` counts the SUMO steps x vehicles in which
    it lowered a command."""

    api: ModuleType  # libsumo or traci
    settings: OnboardSettings
    step_length: float  # [s] the guard's reaction time: one SUMO step
    caps: int = 0  # [-]

    def speed(self, vid: str, v: float, target: float, states: Mapping[str, dict], bodies: Mapping[str, Body],
              min_gaps: Mapping[str, float]) -> float:
        """[m/s] the speed vehicle ``vid`` at ``v`` [m/s], commanded to ``target`` [m/s], drives
        over the next SUMO step: ``target`` capped behind the vehicle ahead (``states``: each
        vehicle's subscription results as last read, ``bodies`` per vehicle as read at
        departure, ``min_gaps`` [m] SUMO's minGap per vehicle)."""
        lead = self.api.vehicle.getLeader(vid, self.settings.sensor_range)
        if not lead or not lead[0]:
            return target
        lid, dist = lead
        own, other = bodies[vid], bodies.get(lid)
        v_lead = states[lid][libsumo.VAR_SPEED] if lid in states else self.api.vehicle.getSpeed(lid)  # [m/s]
        lead_decel = other[3] if other is not None else self.api.vehicle.getDecel(lid)  # [m/s^2]
        gap = dist + min_gaps.get(vid, 0.0)  # [m] bumper to bumper
        capped = guard_speed(v, target, gap, v_lead, own[3], lead_decel, max(own[4], own[3]), self.step_length,
                             self.settings.margin)
        if capped < target:
            self.caps += 1
        return capped
