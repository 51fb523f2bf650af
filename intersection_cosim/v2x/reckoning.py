"""Motion along a path over an interval: dead reckoning and the worst-case reach (pure numbers).

Positions are arc lengths ``s`` [m] along a vehicle's movement path, speeds [m/s] along it.
"""

from __future__ import annotations

import math
from typing import NamedTuple


def dead_reckon(s: float, v: float, a: float, age: float) -> tuple[float, float]:
    """(s [m], v [m/s]) ``age`` [s] after a state (s, v, a [m/s^2]) at constant acceleration,
    clipped at v >= 0: s + v*age + a*age^2/2 while the speed stays positive, then standing."""
    if age <= 0.0:
        return s, v
    if a < 0.0 and v + a * age < 0.0:
        return s + v * v / (-2.0 * a), 0.0
    return s + v * age + 0.5 * a * age * age, v + a * age


class Reach(NamedTuple):
    """Where a vehicle can be ``age`` after a known state, within its physical limits."""

    s_lo: float  # [m] braking as hard as it can (to a stop)
    s_hi: float  # [m] accelerating as hard as it can (up to its top speed)
    v_lo: float  # [m/s]
    v_hi: float  # [m/s]


def reach(s: float, v: float, age: float, max_accel: float, max_decel: float, max_speed: float) -> Reach:
    """The interval a vehicle at (s [m], v [m/s]) can reach in ``age`` [s] with accelerations in
    [-max_decel, max_accel] [m/s^2] and speeds in [0, max_speed] [m/s]."""
    age = max(age, 0.0)
    s_lo, v_lo = dead_reckon(s, v, -max_decel, age)
    v = min(v, max_speed)
    t_top = (max_speed - v) / max_accel  # [s] until top speed
    if age <= t_top:
        s_hi, v_hi = s + v * age + 0.5 * max_accel * age * age, v + max_accel * age
    else:
        s_hi = s + v * t_top + 0.5 * max_accel * t_top * t_top + max_speed * (age - t_top)
        v_hi = max_speed
    return Reach(s_lo, s_hi, v_lo, v_hi)


def tolerances(position_noise: float, speed_noise: float, dt: float) -> tuple[float, float]:
    """(position [m], speed [m/s]) slack of the plausibility check between two messages ``dt`` [s]
    apart: 0.5 m / 0.5 m/s for SUMO's step discretisation plus three standard deviations of the
    difference of two noisy values (and of the speed's noise carried over dt)."""
    k = 3.0 * math.sqrt(2.0)
    return 0.5 + k * (position_noise + speed_noise * dt), 0.5 + k * speed_noise
