"""Yielding to pedestrians at the crossings of a managed junction: the windows of time in which a
pedestrian and a vehicle are on the vehicle's stretch of a crossing, and the braking that keeps
the vehicle out of it (the ``pedestrians`` rule, rules/pedestrians.py, which states the invariant).

* The vehicle's time over the crossing is its plan's (from its front reaching the zone to its
  front leaving it); where its plan does not reach the crossing, from its earliest arrival (at full
  acceleration); a leaving beyond the plan's end is reckoned on from there, at its speed or, if
  sooner, at full acceleration (:func:`vehicle_window`).
* A pedestrian's runs from its reaching the vehicle's stretch at its speed, or at
  ``pedestrian_speed_high`` if it is slower (a person may speed up), to its leaving it at its
  speed, at least ``pedestrian_speed_low`` (a standing person walks on at that speed); one that
  has passed the stretch, walking away, is clear.
* A vehicle does not enter a crossing that people walk on or towards while its leader stands less
  than ``margin`` past it (it would have to stop on the crossing).
* The vehicle waits at its stop line if it has not reached it, else stops ``pedestrian_margin``
  before the crossing; it brakes from the last moment at which ``brake_from`` [m/s^2] still stops
  it there after one more period at full acceleration (braking at the first sight of a person far
  ahead would have it crawl through the junction).
* If it can no longer stop before the crossing within its own braking but a person may be on its
  stretch while it is, it makes an emergency stop at up to its vType's emergencyDecel at the
  crossing's edge, or at most ``EDGE_DEPTH`` into its zone; a vehicle already in that edge with
  such a person stops there (position noise reads one standing at the edge as inside); deeper in
  the zone it drives on (braking then would leave it standing on the crossing).
"""

from __future__ import annotations

import math
from typing import Mapping

from intersection_cosim.control.base import Walker, World
from intersection_cosim.control.safety.kinematics import occupancy, stopping_acceleration
from intersection_cosim.control.safety.settings import SafetySettings
from intersection_cosim.games.problem import Plan
from intersection_cosim.network.crossings import CrossingZone
from intersection_cosim.network.movements import Movements

STAND_SPEED = 0.1  # [m/s] a vehicle slower than this is standing
STAND_REACH = 5.0  # [m] a vehicle standing this close before where it would stop stays (it does not creep up)
EDGE_DEPTH = 1.5  # [m] past the start of its zone a vehicle with a person in front may still stop (not drive on)


def walker_window(walker: Walker, span: tuple[float, float], settings: SafetySettings) -> tuple[float, float] | None:
    """[s] (from, to): when ``walker`` may be on the stretch ``span`` [m] of its crossing's axis
    (widened by ``pedestrian_clearance``), as the module docstring says; None if it has
    passed it, walking away."""
    lo, hi = span[0] - settings.pedestrian_clearance, span[1] + settings.pedestrian_clearance
    fast = max(walker.speed, settings.pedestrian_speed_high)  # [m/s]
    slow = max(walker.speed, settings.pedestrian_speed_low)  # [m/s]
    p = walker.position
    near, far = (lo, hi) if walker.direction > 0 else (hi, lo)
    to_near, to_far = (near - p) * walker.direction, (far - p) * walker.direction  # [m] ahead of it
    if to_far < 0.0:
        return None  # past the stretch, walking away
    return max(to_near, 0.0) / fast, to_far / slow


def vehicle_window(world: World, k: int, zone: CrossingZone, plan: Plan | None, speed_floor: float,
                   accel: float) -> tuple[float, float]:
    """[s] (from, to): when vehicle k's front is in ``zone`` by its ``plan``. Where the plan does
    not reach it (a vehicle held before the crossing keeps a plan that stops), from the earliest
    (at full acceleration ``accel`` [m/s^2]) from its present state; where the plan ends inside
    it, the leaving is from the plan's end. A vehicle leaves at its speed (at least
    ``speed_floor`` [m/s]) or, if sooner, at full acceleration: one that starts from standing
    drives off, it does not creep over at the floor speed (at 0.1 m/s a crossing's 12 m would
    take two minutes, in which someone always walks onto a busy crossing, and it stood for good).
    """
    if plan is not None:
        t_in, t_out = occupancy(plan, zone.zone_in, zone.zone_out)
        if math.isfinite(t_in):
            if math.isfinite(t_out):
                return t_in, t_out
            rest = max(zone.zone_out - float(plan.positions[-1]), 0.0)  # [m] beyond the horizon
            return t_in, plan.steps * plan.dt + _leave_time(rest, float(plan.speeds[-1]), accel, speed_floor)
    s, v = float(world.s[k]), float(world.v[k])
    d_in, d_out = max(zone.zone_in - s, 0.0), max(zone.zone_out - s, 0.0)  # [m]
    t_in = _time_to(d_in, v, accel) if accel > 0 else d_in / max(v, speed_floor)
    return t_in, _leave_time(d_out, v, accel, speed_floor)


def _leave_time(d: float, v: float, accel: float, speed_floor: float) -> float:
    """[s] to cover ``d`` [m] from speed ``v`` [m/s]: at that speed (at least ``speed_floor``) or,
    if sooner, at constant acceleration ``accel`` [m/s^2]."""
    at_speed = d / max(v, speed_floor)
    return min(at_speed, _time_to(d, v, accel)) if accel > 0 else at_speed


def _time_to(d: float, v: float, accel: float) -> float:
    """[s] to cover ``d`` [m] from speed ``v`` [m/s] at constant acceleration ``accel`` [m/s^2] > 0."""
    return (math.sqrt(v * v + 2.0 * accel * d) - v) / accel


def pedestrian_holds(world: World, movements: Movements, zones: Mapping[str, tuple[CrossingZone, ...]],
                     options: Mapping[str, str], plans: Mapping[str, Plan], settings: SafetySettings,
                     speed_floor: float, limits_of, brake_from: float, period: float,
                     leader_of=None) -> dict[str, float]:
    """[m/s^2] per controlled vehicle that must yield to a pedestrian, or keep a crossing clear
    (module docstring), the acceleration that keeps it out of the crossing; ``limits_of(k)``
    [m/s^2] (hardest braking (< 0), strongest acceleration, hardest emergency braking (< 0)) of
    vehicle k (a hold below the first is an emergency stop), ``speed_floor`` [m/s]
    as in :func:`vehicle_window`, ``brake_from`` [m/s^2] (> 0) and ``period`` [s] as in the
    module docstring; ``leader_of(k, exit_lane)``: ([m] the rear of k's leader in the frame of
    k's path to that exit lane, [m/s] its speed), or None without one. Nothing without people."""
    if not world.walkers or not zones:
        return {}
    by_crossing: dict[str, list[Walker]] = {}
    for w in world.walkers:
        by_crossing.setdefault(w.crossing, []).append(w)
    out = {}
    for k, vid in enumerate(world.ids):
        if world.role[k] == "outside" or world.is_human(k):
            continue
        pid = world.path_ids[k]
        exits = set(world.exit_choices.get(vid, ())) | {options.get(vid, movements.paths[pid].exit_lane)}
        limits = limits_of(k)  # [m/s^2]
        for exit_lane in sorted(exits):
            p = movements.siblings.get((pid, exit_lane), pid)
            lead = leader_of(k, exit_lane) if leader_of is not None else None
            for zone in zones.get(p, ()):
                a = _zone_hold(world, k, zone, by_crossing.get(zone.lane, ()), plans.get(vid), lead,
                               movements.paths[p].s_stop, settings, speed_floor, limits, brake_from, period)
                if a is not None and a < math.inf:
                    out[vid] = min(a, out.get(vid, math.inf))
    return out


def _zone_hold(world: World, k: int, zone: CrossingZone, walkers, plan: Plan | None, lead, s_stop: float,
               settings: SafetySettings, speed_floor: float, limits: tuple[float, float, float], brake_from: float,
               period: float) -> float | None:
    """[m/s^2] vehicle k's hold before one crossing (:func:`_stay_out`, or :func:`_edge_stop`), or
    None where it need not or cannot stay out: it is in the zone (past its edge, or with nobody
    in front), or no person is in its way and the crossing is clear to leave (its leader ``lead``,
    rear [m] and speed [m/s], leaves room behind the crossing or moves on), or it cannot stop."""
    s = float(world.s[k])
    if s >= zone.zone_in:  # in the zone: it drives on, unless it can stop at the edge short of a person
        return _edge_stop(world, k, zone, walkers, plan, settings, speed_floor, limits, period)
    blocked = (lead is not None and lead[0] < zone.zone_out + settings.margin
               and lead[1] < settings.clear_speed and bool(walkers))
    conflict = _conflict(world, k, zone, walkers, plan, settings, speed_floor, limits[1])
    if not (blocked or conflict):
        return None
    v = float(world.v[k])
    a = _stay_out(s, v, s_stop, zone.zone_in, settings, limits[:2], brake_from, period)
    if a is None and conflict:
        a = _edge_stop(world, k, zone, walkers, plan, settings, speed_floor, limits, period)
    return a


def _edge_stop(world: World, k: int, zone: CrossingZone, walkers, plan: Plan | None, settings: SafetySettings,
               speed_floor: float, limits: tuple[float, float, float], period: float) -> float | None:
    """[m/s^2] vehicle k's emergency stop (within ``limits[2]``) for a person in front of it
    (:func:`_conflict` without the time gap): at the crossing's edge, or where it cannot stop there, at most
    ``EDGE_DEPTH`` into its zone; one already in that edge stops now (``period`` [s]). None (it
    drives on) without such a person, deeper in the zone, or if it cannot stop even so. The edge
    is for a vehicle that crept a little into the zone or a position that noise puts there (a V2X
    link's 0.2 m position noise read vehicles standing at the edge as inside, and they drove into
    the person; aiming for the edge's far end, one crept on and noise put it past)."""
    s, v = float(world.s[k]), float(world.v[k])
    if s >= zone.zone_in + EDGE_DEPTH or not _conflict(world, k, zone, walkers, plan, settings, speed_floor, limits[1],
                                                       0.0):
        return None
    if s >= zone.zone_in:  # at the edge: it stops now (standing, it stays), it does not creep on
        return max(limits[2], -v / period)
    for target in (zone.zone_in - 0.05, zone.zone_in + EDGE_DEPTH):
        a = stopping_acceleration(s, v, target)
        if a is not None and a >= limits[2]:
            return a
    return None


def _conflict(world: World, k: int, zone: CrossingZone, walkers, plan: Plan | None, settings: SafetySettings,
              speed_floor: float, accel: float, gap: float | None = None) -> bool:
    """Whether a walker on ``zone``'s crossing may be on the vehicle's stretch within ``gap`` [s]
    (default ``pedestrian_time_gap``) of vehicle k's time over it (:func:`vehicle_window`); with
    ``gap`` 0, whether it may be there while the vehicle is: a person the vehicle would run into,
    not one the gap alone counts."""
    if not walkers:
        return False
    t_in, t_out = vehicle_window(world, k, zone, plan, speed_floor, accel)
    gap = settings.pedestrian_time_gap if gap is None else gap  # [s]
    for w in walkers:
        window = walker_window(w, zone.span, settings)
        if window is not None and window[0] < t_out + gap and t_in < window[1] + gap:
            return True
    return False


def _stay_out(s: float, v: float, s_stop: float, enter: float, settings: SafetySettings,
              limits: tuple[float, float], brake_from: float, period: float) -> float | None:
    """[m/s^2] the acceleration that stops a vehicle at ``s`` [m], ``v`` [m/s] at its stop line
    ``s_stop`` less ``margin`` if it can, else ``pedestrian_margin`` before the crossing
    at ``enter`` [m], else at its edge, with its ``limits`` (braking, acceleration) [m/s^2]:
    inf while it need not brake yet (module docstring); standing at most ``STAND_REACH`` before
    it, it stays; None if it can no longer stop before the crossing."""
    brake, accel = limits
    for target in (s_stop - settings.margin, enter - settings.pedestrian_margin, enter - 0.05):
        if target <= s or target > enter:
            continue
        if v < STAND_SPEED and target - s <= STAND_REACH:
            return max(brake, -v / period)
        a = stopping_acceleration(s, v, target)
        if a is None or a < brake:
            continue
        v1 = v + accel * period  # [m/s] after one more period at full acceleration
        if target - (s + (v + 0.5 * accel * period) * period) > v1 * v1 / (2.0 * brake_from):
            return math.inf
        return a
    return max(brake, -v / period) if v < STAND_SPEED else None
