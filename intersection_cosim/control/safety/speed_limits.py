"""Lane speed limits, enforced: a controlled vehicle enters a lane no faster than its limit.

With ``ModelSettings.lane_speed_limits`` the players plan with the limit in force where they are
as their v_max (control/game/relations.py, :func:`lane_speed_caps`), which J_e only pulls towards
(a plan starting faster may keep its speed). These caps make the limit hold, as SUMO's drivers
keep it: a vehicle that would reach a lane with a lower limit too fast brakes from the last
moment at which ``decel`` [m/s^2] still slows it to the limit at the lane's start, one control
period ahead; on the lane it keeps to the limit (the ``lane_speed_limit`` rule).
"""

from __future__ import annotations

import math
from typing import Mapping

from intersection_cosim.control.base import World
from intersection_cosim.network.movements import Movements
from intersection_cosim.network.paths import MovementPath

SPEED_TOL = 0.05  # [m/s] a vehicle this little above a limit is at it


def lane_speed_holds(world: World, movements: Movements, options: Mapping[str, str], decel: float,
                     period: float) -> dict[str, float]:
    """[m/s^2] per controlled vehicle too fast for a lane limit on its path, the acceleration
    that keeps it; ``period`` [s]. Every exit lane the vehicle may still take counts (the one it
    holds in ``options`` may change up to the junction, and SUMO takes the turn it is given
    then), so the lowest of their limits holds."""
    out = {}
    seen: dict[tuple, tuple[set, float]] = {}  # (path, exit choices, held exit) -> (paths, floor [m/s])
    for k, vid in enumerate(world.ids):
        if world.role[k] == "outside" or world.is_human(k):
            continue
        pid = world.path_ids[k]
        key = (pid, world.exit_choices.get(vid, ()), options[vid] if vid in options else None, vid in options)
        if (hit := seen.get(key)) is None:
            exits = set(world.exit_choices.get(vid, ())) | ({options[vid]} if vid in options else set())
            pids = {movements.siblings.get((pid, o), pid) for o in exits} | {pid}
            # no limit binds a vehicle at most SPEED_TOL above the lowest (limit_acceleration)
            floor = min((limit + SPEED_TOL for p in pids for _, _, limit in movements.paths[p].lane_limits),
                        default=math.inf)
            seen[key] = hit = (pids, floor)
        pids, floor = hit
        if float(world.v[k]) <= floor:
            continue
        cap = min(limit_acceleration(movements.paths[p], float(world.s[k]), float(world.v[k]), decel, period)
                  for p in pids)
        if cap < math.inf:
            out[vid] = cap
    return out


def limit_acceleration(path: MovementPath, s: float, v: float, decel: float, period: float) -> float:
    """[m/s^2] the acceleration that keeps a vehicle at arc length ``s`` [m] and speed ``v`` [m/s]
    within the lane limits of ``path`` (module docstring); inf when none binds."""
    cap = math.inf
    for start, end, limit in path.lane_limits:
        if v <= limit + SPEED_TOL or s >= end:
            continue
        if s >= start:  # on the lane: back to its limit within the period
            cap = min(cap, (limit - v) / period)
            continue
        d = start - s - v * period  # [m] to the lane's start after this period at v
        if d <= (v * v - limit * limit) / (2.0 * decel):
            cap = min(cap, -(v * v - limit * limit) / (2.0 * max(d, 1e-3)))  # over what is left after the period
    return cap
