"""The onboard guard: each commanded vehicle's own last check against the vehicle ahead of it.

A real AV brakes for what its radar sees whatever the intersection manager told it; this is that
layer. It is independent of the decision layer, of V2X and of the controller's bookkeeping: every
SUMO step, for every vehicle a controller commands, the simulator adapter asks SUMO for the nearest
vehicle ahead on the vehicle's route (its own lane and the lanes it drives next, through junctions,
within ``sensor_range``), whatever that vehicle is (tracked by a controller or not, an AV or a
human, a bus, one that just changed into the lane, one whose trip ends there, one making a U-turn,
one another junction commands), and caps the commanded speed by :func:`guard_speed`.

**Invariant.** After every SUMO step a commanded vehicle drives no faster than Krauss' safe speed
behind that leader: braking at its own ``decel`` after one SUMO step of reaction, it stops at least
``margin`` behind the leader's rear however the leader brakes up to the leader's own ``decel``.

**What it assumes.**

* The leader brakes no harder than its vType's ``decel``. SUMO's drivers keep to it except in an
  emergency; an emergency stop of a leader (beyond its ``decel``) is met by the follower braking up
  to its own ``emergency_decel`` (:func:`guard_speed`'s floor), which covers a leader braking up to
  that hard once the follower is at its safe speed.
* The leader is on the vehicle's lanes. A vehicle that cuts in closer than the safe gap (a lane
  change is instantaneous in SUMO's default lane-change model) is braked for from the next SUMO
  step, at most at ``emergency_decel``; the guard cannot prevent another driver's cut-in.
* Crossing and merging traffic inside a junction is not ahead on the vehicle's lanes: the junction
  guard (the controller's safety filter) covers what the controller tracks, and the crossing sense
  (control/safety/crossing_sense.py) the road users no controller commands that are already
  driving through a crossing of the vehicle's path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from intersection_cosim.settings import non_negative, positive


@dataclass(frozen=True)
class OnboardSettings:
    """The onboard guard of every commanded vehicle (``[controller]`` keys ``onboard_*``)."""

    enabled: bool = True  # [-] cap every commanded speed behind the vehicle ahead (false: an ablation)
    sensor_range: float = 150.0  # [m] how far ahead along its route a vehicle sees the vehicle ahead
    margin: float = 0.5  # [m] the guard stops a vehicle at least this far behind its leader's rear
    # the crossing sense (control/safety/crossing_sense.py): road users no controller commands
    # driving through a crossing of the vehicle's path inside the next junction
    crossing: bool = True  # [-] hold a commanded vehicle out of such a crossing (false: an ablation)
    crossing_buffer: float = 1.0  # [s] time kept between their occupations of the crossing
    crossing_lookahead: float = 10.0  # [m] looked ahead beyond the vehicle's braking distance
    crossing_speed: float = 10.0  # [m/s] the speed up to which a waiting vehicle is assumed to accelerate

    def check(self) -> list[tuple[str, str]]:
        return (positive(self, "sensor_range", "crossing_speed")
                + non_negative(self, "margin", "crossing_buffer", "crossing_lookahead"))


def krauss_safe_speed(gap: float, v_leader: float, decel: float, tau: float, leader_decel: float | None = None) -> float:
    """[m/s] Krauss' safe speed behind a leader ``gap`` [m] ahead (bumper to bumper) at
    ``v_leader`` [m/s], for maximum deceleration ``decel`` [m/s^2] and reaction time ``tau`` [s]:
    the speed from which the follower, reacting after ``tau``, stops within the gap plus the
    leader's own braking distance v_L^2 / (2 b_L), the leader braking at ``leader_decel`` [m/s^2]
    (default ``decel``: Krauss' form, -b tau + sqrt((b tau)^2 + v_L^2 + 2 b gap))."""
    b_l = decel if leader_decel is None else leader_decel
    bt = decel * tau
    return -bt + math.sqrt(max(bt * bt + decel / b_l * v_leader * v_leader + 2.0 * decel * max(gap, 0.0), 0.0))


def guard_speed(v: float, target: float, gap: float, v_leader: float, decel: float, leader_decel: float,
                emergency_decel: float, tau: float, margin: float) -> float:
    """[m/s] the speed a vehicle at ``v`` [m/s] commanded to ``target`` [m/s] drives over the next
    ``tau`` [s] behind a leader ``gap`` [m] ahead (bumper to bumper) at ``v_leader`` [m/s]: the
    target, capped by Krauss' safe speed (braking at ``decel``, the leader at ``leader_decel``
    [m/s^2], stopping ``margin`` [m] behind it), never below what braking at
    ``emergency_decel`` [m/s^2] for ``tau`` reaches (the hardest the vehicle can brake)."""
    safe = krauss_safe_speed(gap - margin, v_leader, decel, tau, leader_decel)
    if target <= safe:
        return target
    return max(safe, v - emergency_decel * tau, 0.0)
