"""The onboard guard's second sense: road users whose path crosses the commanded vehicle's inside
its next junction and that no controller commands or tracks (a cyclist on a bicycle lane the
controller does not manage, a vehicle on no managed movement path, one another junction released).

A real AV sees a cyclist crossing in front of it when it turns; the junction controller's safety
filter only sees the road users on the movement paths it manages. This check, run by the simulator
adapter for every commanded vehicle every SUMO step (sim/onboard.py), reads SUMO's junction
model: the lanes inside the junction that SUMO lists as foes of the vehicle's lanes there
(``lane.getInternalFoes``) with the road users on them, the crossing point of each pair of centre
lines, and SUMO's junction foes of the vehicle (``vehicle.getJunctionFoes``) with who must yield.

**Rule.** The vehicle must let such a road user pass if it is already on a foe lane inside the
junction (SUMO's drivers do not stop for a vehicle that must yield to them once they have
entered), or if SUMO gives it the right of way over the vehicle. Its occupation of the crossing
runs from its front reaching ``clearance`` before the crossing point, as early as accelerating
allows, to its rear leaving ``clearance`` after it, as late as keeping its speed gives; the
vehicle's from its front reaching the crossing (accelerating from its speed at ``accel``) to its
rear leaving it. If the two come within ``buffer`` [s] of each other, the vehicle is held to a
speed from which it stops ``margin`` before the crossing (the Krauss cap of
:func:`~intersection_cosim.control.safety.onboard.guard_speed` behind a standing obstacle there).

**What it assumes.** Centre lines that cross (paths that only merge into one lane are the leader
guard's once they share a lane); road users that keep their speed through the crossing; a road user
standing inside the junction may start at any moment unless SUMO has it yield to the vehicle or the
vehicle is inside the junction too (SUMO holds a driver at an internal stop for a vehicle on a foe
lane inside the junction), one standing before the junction waits (SUMO's drivers start only once
the junction lets them, and a moving one counts again: otherwise a vehicle and a road user that
waits for a third one that waits for the vehicle lock each other); a commanded vehicle that can no
longer stop before the crossing is not capped (it is committed too, and braking in the crossing
would block it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sumolib import geomhelper

Point = tuple[float, float]


@dataclass(frozen=True)
class Crossing:
    """Where two lanes' centre lines cross: at ``s_ego`` [m] along the first, ``s_foe`` [m] along
    the second, at ``angle`` [rad] between them (0 to pi/2)."""

    s_ego: float
    s_foe: float
    angle: float


def crossing(ego: list[Point], foe: list[Point]) -> Crossing | None:
    """The first crossing of polyline ``foe`` along polyline ``ego`` [m] (None: they do not
    cross), by sumolib's polyline geometry."""
    hits = geomhelper.intersectsAtLengths2D(ego, foe)
    if not hits:
        return None
    s_ego = min(hits)  # [m]
    s_foe = geomhelper.polygonOffsetWithMinimumDistanceToPoint(geomhelper.positionAtShapeOffset(ego, s_ego), foe)
    turn = abs(_rotation(ego, s_ego) - _rotation(foe, s_foe)) % math.pi
    return Crossing(s_ego, s_foe, min(turn, math.pi - turn))


def _rotation(shape: list[Point], s: float) -> float:
    """[rad] the direction of polyline ``shape`` at ``s`` [m]; at (or past) its end that of its last
    segment (sumolib's rotationAtShapeOffset has none there, and two lanes meeting at their end
    points, as at a merge, cross there)."""
    rotation = geomhelper.rotationAtShapeOffset(shape, s)
    if rotation is None:
        (x0, y0), (x1, y1) = shape[-2], shape[-1]
        rotation = math.atan2(y1 - y0, x1 - x0)
    return rotation


def clearance(width_ego: float, width_foe: float, angle: float, most: float = 6.0) -> float:
    """[m] how far before (and after) a crossing point a body of ``width_ego`` [m] first touches
    (last touches) the path of one of ``width_foe`` [m] crossing it at ``angle`` [rad]; at most
    ``most`` [m] (nearly parallel paths)."""
    return min((width_ego + width_foe) / 2.0 / max(math.sin(angle), 1e-3), most)


def time_to_cover(distance: float, v: float, accel: float, v_max: float) -> float:
    """[s] the time to drive ``distance`` [m] from ``v`` [m/s] accelerating at ``accel`` [m/s^2]
    up to ``v_max`` [m/s] (0 if ``distance`` <= 0; without acceleration at ``v``: never if it
    stands)."""
    if distance <= 0:
        return 0.0
    if accel <= 0:
        return distance / v if v > 1e-9 else math.inf
    v_top = max(v_max, v, 0.1)
    t_top = max(v_top - v, 0.0) / accel  # [s] until v_max
    d_top = v * t_top + 0.5 * accel * t_top * t_top  # [m] covered until then
    if d_top >= distance:
        return (-v + math.sqrt(v * v + 2.0 * accel * distance)) / accel
    return t_top + (distance - d_top) / v_top


@dataclass(frozen=True)
class Occupation:
    """When a body is in a crossing: from ``enter`` to ``leave`` [s] from now."""

    enter: float
    leave: float


def foe_occupation(to_entry: float, to_exit: float, v: float, accel: float, v_max: float) -> Occupation:
    """A committed road user at ``v`` [m/s] whose front is ``to_entry`` [m] from the crossing's
    entry and whose rear is ``to_exit`` [m] from its exit, taken at its most dangerous: it enters
    as early as accelerating at ``accel`` [m/s^2] up to ``v_max`` [m/s] lets it, and leaves as
    late as keeping its speed does (never, if it stands: it may stay)."""
    if to_exit <= 0:
        return Occupation(math.inf, math.inf)  # past it
    enter = time_to_cover(to_entry, v, accel, v_max)
    return Occupation(enter, to_exit / v if v > 0.1 else math.inf)


def ego_occupation(to_entry: float, through: float, v: float, accel: float, v_max: float) -> Occupation:
    """The commanded vehicle's: ``to_entry`` [m] from the crossing's entry, ``through`` [m] from
    there until its rear leaves; accelerating at ``accel`` [m/s^2] up to ``v_max`` [m/s]."""
    enter = time_to_cover(to_entry, v, accel, v_max)
    return Occupation(enter, enter + through / max(min(v + accel * enter, max(v_max, v)), 0.1))


def overlaps(a: Occupation, b: Occupation, buffer: float) -> bool:
    """Whether two occupations of one crossing come within ``buffer`` [s] of each other."""
    return a.enter < b.leave + buffer and b.enter < a.leave + buffer
