"""A safety filter on the game controller's accelerations (not in the paper).

The paper's running cost makes collisions expensive, not impossible: J_lat and J_log are bounded
by 1 / eps, so two aggressive players (Case 1 D) can find an equilibrium in which both cross the
conflict point at nearly the same time, and an aggressive follower can plan into its leader. SUMO
itself never lets that happen to its own vehicles (its safe-speed and right-of-way checks, which
the controller switches off). This filter is the controller's equivalent, applied after the
games; it only ever *lowers* an acceleration, and only when the plans of this step would collide:

* **Crossings.** For each cross / confluence pair, each vehicle's planned occupancy of the
  crossing is the interval from its front reaching the zone's start to its front passing the
  zone's end. For cross pairs the zone is the conflict table's body-overlap stretch
  (``zone_in``, ``zone_out``: where the body overlaps the area the other's bodies sweep); for
  confluence pairs it is ``s_cp - W/2`` to ``s_cp + W/2 + L`` (after the merge the pair is a
  following pair). If the two intervals come closer than ``safety_time_gap``, one of the two
  yields, by one priority order so that waits cannot form a cycle (vehicles stopped in each
  other's zones, a deadlock): a vehicle inside the junction ranks by when it entered it (first
  in, first out), ahead of every vehicle not yet in; among those, the one that would reach the
  crossing first ranks higher (by default at its current speed: the smaller time to the
  crossing, the paper's rule for the Stackelberg leader, except that a pair that played its
  game keeps the game's order, by its plans; ``GameSettings.yield_order = "plan"`` ranks every
  pair by this step's plans). The lower-ranked one yields if it can still stay out of
  its zone: it brakes to stop ``safety_margin`` before it (a = -v^2 / 2d, at most |a_min|), or at its stop
  line if it has not reached it (as in AIM, a vehicle enters only to clear: one stopped inside
  the junction before one crossing may block another). Else the higher-ranked one yields if it
  can; else both are in (or committed) and the lower-ranked one holds back as hard as it may
  while the other clears the crossing. A pair is guarded until one of the two has left its
  zone. Vehicles braked in a first pass are checked again with their braking plan, so a vehicle
  made to stop is seen by the other crossings it now blocks.
* **Leaders.** A follower's acceleration is capped by the safe speed of Krauss' car-following
  model (SUMO's default): v_safe = -b tau + sqrt((b tau)^2 + v_L^2 + 2 b (gap - margin)), with
  b = |a_min| and tau = the control period, so it can always stop behind a leader that brakes as
  hard as it can.
"""

from __future__ import annotations

import math

import numpy as np

from intersection_cosim.games.problem import Plan


def occupancy(plan: Plan, enter: float, leave: float) -> tuple[float, float]:
    """[s] (enter, leave): when the planned front reaches arc length ``enter`` and when it passes
    ``leave`` [m] (a crossing's zone of the conflict table); ``inf`` where that is beyond the
    plan's horizon, 0 where it is already there."""
    pos = plan.positions  # non-decreasing: plans keep v >= 0
    k_in, k_out = pos.searchsorted((enter, leave))  # first samples at or past each point
    return _first_reach(pos, int(k_in), enter, plan.dt), _first_reach(pos, int(k_out), leave, plan.dt)


def _first_reach(pos: np.ndarray, k: int, target: float, dt: float) -> float:
    """[s] when ``pos`` (sampled every ``dt``) reaches ``target``, ``pos[k]`` its first sample at
    or past it, linearly interpolated."""
    if k == 0:
        return 0.0
    if k >= len(pos):
        return math.inf
    p0, p1 = float(pos[k - 1]), float(pos[k])
    return dt * (k - 1 + (target - p0) / max(p1 - p0, 1e-9))


def stopping_acceleration(s: float, v: float, stop_at: float) -> float | None:
    """[m/s^2] constant acceleration that stops from speed ``v`` [m/s] at arc length ``stop_at``
    [m], or None if the vehicle is already there."""
    d = stop_at - s
    if d <= 0.0:
        return None
    return -v * v / (2.0 * d)


def braking_plan(plan: Plan, accel: float) -> Plan:
    """``plan`` from its start state with constant acceleration ``accel`` [m/s^2] (< 0) until it
    stops, then standing: what a vehicle the filter brakes will do if nothing changes."""
    v0 = float(plan.speeds[0])
    n, dt = plan.steps, plan.dt
    if accel >= 0.0:
        a = np.full(n, float(accel))
    else:
        t_stop = v0 / -accel  # [s]
        k = np.arange(n) * dt
        a = accel * np.clip((t_stop - k) / dt, 0.0, 1.0)  # the last step ends exactly at v = 0
    return Plan.from_accelerations(float(plan.positions[0]), v0, a, dt)


def krauss_safe_speed(gap: float, v_leader: float, decel: float, tau: float) -> float:
    """[m/s] Krauss' safe speed behind a leader ``gap`` [m] ahead (bumper to bumper) at
    ``v_leader`` [m/s], for maximum deceleration ``decel`` [m/s^2] and reaction time ``tau`` [s]."""
    bt = decel * tau
    return -bt + math.sqrt(max(bt * bt + v_leader * v_leader + 2.0 * decel * max(gap, 0.0), 0.0))
