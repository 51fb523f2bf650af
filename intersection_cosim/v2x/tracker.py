"""A Kalman track of one V2X sender along its path: the controller's estimate of where a vehicle is
from its noisy messages (pure numbers).

A message carries the sender's arc length ``s`` [m] and speed ``v`` [m/s] with Gaussian noise
(``[v2x] position_noise``, ``speed_noise``) and its acceleration ``a`` [m/s^2]. Taking each
message at face value makes every position the controller sees as noisy as one message, and the
junction guard must then widen every crossing zone by several of those standard deviations: at
1 m of noise a vehicle standing at its stop line reads as inside a crossing, and the vehicles in
the box wait for it while it waits for them. A track fuses the messages instead, as the
receivers of cooperative-awareness messages do (a constant-acceleration model, Kalman filter):
state (s, v), prediction by the message's acceleration over the time between two messages,
process noise ``accel_noise`` [m/s^2] for the acceleration changing in between, measurement
noise the link's. Its standard deviation of position after a few messages is far below one
message's, and :func:`steady_sigma` gives the value the junction guard may count on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def _transition(dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(F, G) of the constant-acceleration step over ``dt`` [s]: x' = F x + G a."""
    return np.array([[1.0, dt], [0.0, 1.0]]), np.array([0.5 * dt * dt, dt])


@dataclass(frozen=True)
class TrackState:
    """A track's estimate at the stamp of its last fused message."""

    stamp: float  # [s]
    s: float  # [m] arc length along the sender's path
    v: float  # [m/s] (below 0 by noise near standstill: read it as max(v, 0))
    a: float  # [m/s^2] the last message's acceleration
    cov: tuple[float, float, float]  # (var s [m^2], cov s-v [m^2/s], var v [m^2/s^2])

    @property
    def sigma_s(self) -> float:
        """[m] standard deviation of the estimated position."""
        return math.sqrt(max(self.cov[0], 0.0))


def start(stamp: float, s: float, v: float, a: float, position_noise: float, speed_noise: float) -> TrackState:
    """A new track from one message: the message itself, as uncertain as the link."""
    return TrackState(stamp, s, v, a, (position_noise ** 2, 0.0, speed_noise ** 2))


CENSORED = 2.0  # [-] a speed read below this many speed_noise deviations is not fused (see fuse)


def fuse(track: TrackState, stamp: float, s: float, v: float, a: float, position_noise: float,
         speed_noise: float, accel_noise: float) -> TrackState:
    """``track`` predicted to ``stamp`` [s] by its acceleration and corrected by the message (s [m],
    v [m/s], a [m/s^2]). With no noise on the link the message is taken as it is.

    A sender never reports a negative speed (a noisy reading below 0 arrives as 0), so the speeds
    read near standstill are biased upwards; fused, they would show a standing vehicle creeping
    forward. A speed read below ``CENSORED`` standard deviations corrects the position only."""
    if position_noise <= 0.0 and speed_noise <= 0.0:
        return TrackState(stamp, s, v, a, (0.0, 0.0, 0.0))
    dt = max(stamp - track.stamp, 0.0)
    f, g = _transition(dt)
    x = f @ np.array([track.s, track.v]) + g * track.a
    p = np.array([[track.cov[0], track.cov[1]], [track.cov[1], track.cov[2]]])
    p = f @ p @ f.T + np.outer(g, g) * accel_noise ** 2
    with_speed = v >= CENSORED * speed_noise
    h = np.eye(2) if with_speed else np.array([[1.0, 0.0]])
    z = np.array([s, v]) if with_speed else np.array([s])
    r = np.diag([max(position_noise, 1e-6) ** 2, max(speed_noise, 1e-6) ** 2][:len(z)])
    gain = p @ h.T @ np.linalg.inv(h @ p @ h.T + r)
    x = x + gain @ (z - h @ x)
    p = (np.eye(2) - gain @ h) @ p
    p = 0.5 * (p + p.T)
    return TrackState(stamp, float(x[0]), float(x[1]), a, (float(p[0, 0]), float(p[0, 1]), float(p[1, 1])))


def steady_sigma(position_noise: float, speed_noise: float, period: float, accel_noise: float,
                 messages: int = 200) -> float:
    """[m] the standard deviation of position of a track that has fused messages every ``period``
    [s] for a while (the filter's steady state; 0 with a noiseless link), for the worst track: one
    whose speeds are all near standstill, so that only positions are fused. The junction guard
    widens the crossing zones by it in place of one message's noise."""
    if position_noise <= 0.0 and speed_noise <= 0.0:
        return 0.0
    track = start(0.0, 0.0, 0.0, 0.0, position_noise, speed_noise)
    for k in range(1, messages + 1):
        track = fuse(track, k * period, track.s, 0.0, 0.0, position_noise, speed_noise, accel_noise)
    return track.sigma_s
