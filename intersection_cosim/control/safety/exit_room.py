"""Don't block the box: a vehicle enters its junction only if its exit lane has room for it.

Across a network a queue spills back from one junction onto the exit lanes of the one upstream;
a vehicle that entered a junction towards a full exit lane stops inside it and blocks the
crossings of others, whose queues may in turn block the junction it waits for (gridlock).
:func:`exit_room_caps` holds a READY vehicle at its stop line while its exit lane has less than
its length plus ``min_gap`` free by the time it reaches its stop line (the lane's last vehicle
driving on at its speed), counting the vehicles standing inside the junction towards the
same lane and those ahead of it that were let go this step (nearest to its stop line first).
Pure: the free length of each exit lane comes in the World (``World.exit_free``, read by the
simulator adapter).
"""

from __future__ import annotations

from typing import Mapping

from intersection_cosim.control.base import World
from intersection_cosim.control.safety.kinematics import stopping_acceleration
from intersection_cosim.network.movements import Movements


def exit_lane_id(movements: Movements, path_id: str, option: str) -> str:
    """The SUMO lane id of exit lane ``option`` of the movement of ``path_id``."""
    return movements.paths[movements.siblings.get((path_id, option), path_id)].lanes[-1]


def exit_room_caps(world: World, movements: Movements, options: Mapping[str, str], length: float,
                   min_gap: float, margin: float, comfort: float, a_min: float, period: float,
                   standing: float) -> dict[str, float]:
    """[m/s^2] per READY vehicle whose exit lane lacks room: the acceleration that stops it
    ``margin`` [m] before its stop line (see :func:`_hold`: from the last moment braking at
    ``comfort`` [m/s^2] does it; none if it cannot stop there any more braking at ``a_min``
    [m/s^2], or has passed it).

    ``options``: the exit lane each vehicle takes (its path's own if absent); ``length`` [m] the
    vehicle length where the World carries none (else each vehicle's own), ``min_gap`` [m] the
    standstill gap it needs behind the last vehicle,
    ``period`` [s] the control period. A vehicle inside the junction claims room on its exit lane
    only while it is slower than ``standing`` [m/s] (one that drives on will be on the lane, and
    in ``World.exit_free``, before the held one could enter).
    """
    if not world.exit_free:
        return {}
    need = world.lengths(length) + min_gap  # [m] room each vehicle takes on its exit lane
    taken: dict[str, float] = {}  # [m] per exit lane, claimed by vehicles in or let into the junction
    ready = []
    for k, pid in enumerate(world.path_ids):
        path = movements.paths[pid]
        lane = exit_lane_id(movements, pid, options.get(world.ids[k], path.exit_lane))
        if world.role[k] == "passing" and float(world.v[k]) < standing:
            taken[lane] = taken.get(lane, 0.0) + float(need[k])
        elif world.role[k] == "ready" and lane in world.exit_free:
            ready.append((path.s_stop - float(world.s[k]), world.ids[k], k, lane, path.s_stop))
    caps = {}
    for to_stop, vid, k, lane, s_stop in sorted(ready):
        free, v_last = world.exit_free[lane]  # [m], [m/s]
        # the room there will be when it reaches its stop line, the last vehicle driving on as now
        room = free + min(v_last, 1e6) * to_stop / max(float(world.v[k]), 0.5)
        if room - taken.get(lane, 0.0) >= float(need[k]):
            taken[lane] = taken.get(lane, 0.0) + float(need[k])
            continue
        cap = _hold(float(world.s[k]), float(world.v[k]), s_stop, margin, comfort, a_min, period)
        if cap is not None:
            caps[vid] = cap
    return caps


def _hold(s: float, v: float, s_stop: float, margin: float, comfort: float, a_min: float,
          period: float) -> float | None:
    """[m/s^2] stop ``margin`` before ``s_stop`` [m] (at it when already within the margin),
    only once braking at ``comfort`` [m/s^2] would no longer stop it short of there after one
    more period (until then it approaches as planned: the lane may clear); None if it need not
    hold yet or cannot (it would need more than |a_min|, or it is past the line)."""
    target = s_stop - margin if s < s_stop - margin - 0.05 else s_stop - 0.05
    d = target - s  # [m]
    if d <= 0.0:
        return max(a_min, -v / period) if s < s_stop else None
    if d > v * v / (2.0 * comfort) + v * period + 1.0:
        return None
    a = stopping_acceleration(s, v, target)
    return a if a is not None and a >= a_min else None
