"""Kinematic bicycle model, Eqs. 1-4, against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.models.vehicle import (
    V,
    X,
    Y,
    YAW,
    bicycle_derivative,
    heading_angle,
    rollout,
    slip_angle,
    step,
)

S = ModelSettings()  # l_f = l_r = 1.35 m, l = 2.7 m


def test_slip_and_heading_angles():
    # Eq. 3 with l_r / l = 1/2: beta = atan(tan(delta) / 2)
    assert slip_angle(0.2, 1.35, 1.35) == pytest.approx(math.atan(math.tan(0.2) / 2))
    assert slip_angle(0.0, 1.35, 1.35) == 0.0
    assert slip_angle(-0.2, 1.0, 2.0) == pytest.approx(-math.atan(2 / 3 * math.tan(0.2)))
    assert heading_angle(1.0, 0.2, 1.35, 1.35) == pytest.approx(1.0 + math.atan(math.tan(0.2) / 2))


def test_derivative_hand_values():
    # v = 10 m/s, yaw = 0, delta = 0.2: beta = 0.1007 rad, yaw rate = 10 tan(beta) / 1.35
    beta = math.atan(math.tan(0.2) / 2)
    d = bicycle_derivative([10.0, 0.0, 0.0, 0.0], [1.5, 0.2], S)
    assert d == pytest.approx([1.5, 10 * math.tan(beta) / 1.35, 10.0, 10 * math.tan(beta)])


def test_straight_line_at_constant_acceleration_is_exact():
    v0, a, yaw, t_end, dt = 5.0, 1.5, 0.3, 3.0, 0.1
    n = int(round(t_end / dt))
    traj = rollout([v0, yaw, 1.0, 2.0], np.tile([a, 0.0], (n, 1)), dt, S)
    t = np.arange(n + 1) * dt
    dist = v0 * t + 0.5 * a * t**2
    assert traj[:, V] == pytest.approx(v0 + a * t, abs=1e-12)
    assert traj[:, YAW] == pytest.approx(np.full_like(t, yaw), abs=1e-12)
    assert traj[:, X] == pytest.approx(1.0 + dist * math.cos(yaw), abs=1e-9)
    assert traj[:, Y] == pytest.approx(2.0 + dist * math.sin(yaw), abs=1e-9)


@pytest.mark.parametrize("delta", [0.2, -0.35])
def test_constant_steer_drives_a_circle_of_radius_l_over_tan_delta(delta):
    v, yaw0, dt, n = 8.0, 0.7, 0.01, 600
    traj = rollout([v, yaw0, 3.0, -4.0], np.tile([0.0, delta], (n, 1)), dt, S)
    radius = S.wheelbase / math.tan(delta)  # signed: > 0 turns left
    rear = traj[:, X:] - S.l_r * np.stack([np.cos(traj[:, YAW]), np.sin(traj[:, YAW])], axis=1)
    centre = rear[0] + radius * np.array([-math.sin(yaw0), math.cos(yaw0)])
    # the rear axle runs on the circle of radius l / tan(delta), the centre of gravity on the
    # concentric circle of radius sqrt(R^2 + l_r^2)
    assert np.linalg.norm(rear - centre, axis=1) == pytest.approx(np.full(n + 1, abs(radius)), rel=1e-8)
    assert np.linalg.norm(traj[:, X:] - centre, axis=1) == pytest.approx(
        np.full(n + 1, math.hypot(radius, S.l_r)), rel=1e-8)
    # yaw rate v tan(beta) / l_r (Eq. 2)
    rate = v * math.tan(slip_angle(delta, S.l_f, S.l_r)) / S.l_r
    assert traj[-1, YAW] - yaw0 == pytest.approx(rate * n * dt, rel=1e-10)


def test_vectorised_over_vehicles_matches_one_by_one():
    states = np.array([[5.0, 0.0, 0.0, 0.0], [8.0, 1.0, 10.0, -3.0], [2.0, -2.0, -5.0, 4.0]])
    controls = np.array([[1.0, 0.1], [-2.0, -0.2], [0.5, 0.0]])
    together = step(states, controls, 0.1, S)
    for k in range(3):
        assert together[k] == pytest.approx(step(states[k], controls[k], 0.1, S))
    seq = np.repeat(controls[:, None, :], 20, axis=1)  # (3, 20, 2)
    traj = rollout(states, seq, 0.1, S)
    assert traj.shape == (3, 21, 4)
    assert traj[1, -1] == pytest.approx(rollout(states[1], seq[1], 0.1, S)[-1])


def test_braking_stops_and_does_not_reverse():
    traj = rollout([3.0, 0.0, 0.0, 0.0], np.tile([-2.0, 0.0], (30, 1)), 0.1, S)
    assert traj[:, V].min() == 0.0
    assert traj[-1, X] == pytest.approx(3.0**2 / (2 * 2.0), abs=0.05)  # stopping distance v^2 / 2a
    assert np.all(np.diff(traj[:, X]) >= 0)
