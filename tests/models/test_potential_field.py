"""Gaussian potential field, Eqs. 5-8 (with our reading of Eq. 7)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from intersection_cosim.models.potential_field import (
    field_width,
    path_field,
    potential_field,
    potential_field_curved,
    potential_field_straight,
    preview_amplitude,
    turning_centre,
)
from intersection_cosim.models.settings import ModelSettings

S = ModelSettings(t_p=3.0, t_p_kappa=0.0)  # a0 = 1, b = 0.1, c = 0.5, t_p = 3 s for every kappa (default 4 s, tilted by kappa), W = 1.8 m (d = 0.45 m), l = 2.7 m


def _grid():
    return np.meshgrid(np.linspace(-10.0, 45.0, 221), np.linspace(-15.0, 15.0, 121))


def test_hand_computed_values():
    # straight: vehicle at the origin heading east, 5 m/s, kappa 0, point (5, 1):
    # s = 5, Lambda = (5 - 15)^2 = 100, sigma = 0.1 * 5 + 0.45 = 0.95
    g = potential_field(5.0, 1.0, 0.0, 0.0, 0.0, 5.0, 0.0, 0.0, S)
    assert g == pytest.approx(100.0 * math.exp(-1.0 / (2 * 0.95**2)))
    # Lambda and sigma alone (Eqs. 7, 8); a = e^kappa
    assert preview_amplitude(4.0, 4.0, 0.5, S) == pytest.approx(math.exp(0.5) * 64.0)
    assert preview_amplitude([-0.1, 12.0, 12.1], 4.0, 0.5, S) == pytest.approx([0.0, 0.0, 0.0])
    assert field_width(10.0, 0.2, S) == pytest.approx((0.1 + 0.5 * 0.2) * 10.0 + 0.45)
    # curved: delta = 0.2, R = 2.7 / tan(0.2) = 13.32 m; a point on the rear-axle circle a quarter
    # turn ahead of the centre of gravity has lateral distance 0 and s = R pi / 2
    xc, yc, r = turning_centre(0.0, 0.0, 0.0, 0.2, S)
    assert (xc, yc, r) == pytest.approx((-1.35, 2.7 / math.tan(0.2), 2.7 / math.tan(0.2)))
    ang_g = math.atan2(0.0 - yc, 0.0 - xc)
    px, py = xc + r * math.cos(ang_g + math.pi / 2), yc + r * math.sin(ang_g + math.pi / 2)
    g = potential_field(px, py, 0.0, 0.0, 0.0, 10.0, 0.2, 0.3, S)
    assert g == pytest.approx(math.exp(0.3) * (r * math.pi / 2 - 30.0) ** 2)


def test_turning_centre_is_left_for_positive_steer():
    # heading north (yaw pi/2): left is west
    xc, yc, r = turning_centre(0.0, 0.0, math.pi / 2, 0.3, S)
    assert xc < 0 and yc == pytest.approx(-1.35) and r > 0
    xc, yc, r = turning_centre(0.0, 0.0, math.pi / 2, -0.3, S)
    assert xc > 0 and r < 0
    assert abs(xc) == pytest.approx(2.7 / math.tan(0.3))


@pytest.mark.parametrize("delta", [0.0, 1e-9, 0.05, 0.3, -0.3, -0.6])
def test_non_negative_everywhere(delta):
    X, Y = _grid()
    for v in (0.0, 3.0, 12.0):
        for kappa in (0.0, 0.5, 1.0):
            g = potential_field(X, Y, 1.0, -2.0, 0.4, v, delta, kappa, S)
            assert np.all(np.isfinite(g)) and np.all(g >= 0.0)
    assert potential_field(X, Y, 1.0, -2.0, 0.4, 8.0, delta, 0.5, S).max() > 0.0


@pytest.mark.parametrize("delta", [0.0, 0.25, -0.25])
def test_falls_with_lateral_distance(delta):
    # at fixed arc length the field is a Gaussian in the distance from the predicted path
    s = np.full(50, 8.0)
    lat = np.linspace(0.0, 6.0, 50)
    g = path_field(s, lat, 8.0, delta, 0.5, S)
    assert np.all(np.diff(g) < 0.0)
    # the same seen in the plane: move sideways from the predicted path at 8 m ahead (straight)
    if delta == 0.0:
        g_xy = potential_field(8.0, lat, 0.0, 0.0, 0.0, 8.0, 0.0, 0.5, S)
        assert g_xy == pytest.approx(g)


@pytest.mark.parametrize("delta", [0.0, 0.2, -0.2])
def test_falls_with_arc_length_and_is_zero_behind_and_beyond(delta):
    v = 6.0
    x_g, y_g, yaw = 2.0, -25.0, math.pi / 2
    s = np.linspace(0.0, v * S.t_p, 40)
    if delta == 0.0:
        X, Y = x_g + 0 * s, y_g + s
    else:
        xc, yc, r = turning_centre(x_g, y_g, yaw, delta, S)
        ang = math.atan2(y_g - yc, x_g - xc) + np.sign(r) * s / abs(r)
        X, Y = xc + abs(r) * np.cos(ang), yc + abs(r) * np.sin(ang)
    g = potential_field(X, Y, x_g, y_g, yaw, v, delta, 0.5, S)
    assert np.all(np.diff(g[:-1]) < 0.0) and g[-1] == pytest.approx(0.0, abs=1e-9)
    assert g[0] == pytest.approx(math.exp(0.5) * (v * S.t_p) ** 2, rel=1e-3)
    # behind the vehicle and beyond the preview length there is no field
    assert potential_field(x_g, y_g - 3.0, x_g, y_g, yaw, v, delta, 0.5, S) == 0.0
    assert potential_field(x_g, y_g + 30.0, x_g, y_g, yaw, v, 0.0, 0.5, S) == 0.0


def test_curved_and_straight_forms_agree_at_the_switch():
    X, Y = np.meshgrid(np.linspace(-5.0, 45.0, 251), np.linspace(-8.0, 8.0, 81))
    for v in (3.0, 10.0, 14.0):
        for sign in (1.0, -1.0):
            delta = sign * S.straight_steer
            args = (1.0, 2.0, 0.3, v, delta, 0.5, S)
            curved = potential_field_curved(X, Y, *args)
            straight = potential_field_straight(X, Y, *args)
            peak = curved.max()
            assert np.abs(curved - straight).max() <= 1e-3 * peak
            big = curved > 0.01 * peak
            assert np.all(np.abs(curved - straight)[big] <= 1e-3 * curved[big])
    # at the old switch of 1e-3 rad the circle has drifted off the tangent line by s^2 / 2R:
    # the forms differ by several per cent, which is why the switch sits at 1e-6 rad
    coarse = replace(S, straight_steer=1e-3)
    c = potential_field_curved(X, Y, 0.0, 0.0, 0.0, 10.0, 1e-3, 0.5, coarse)
    s = potential_field_straight(X, Y, 0.0, 0.0, 0.0, 10.0, 1e-3, 0.5, coarse)
    assert np.abs(c - s).max() > 3e-3 * c.max()


def test_potential_field_switches_forms_by_steer():
    X, Y = _grid()
    tiny = 0.5 * S.straight_steer
    below = potential_field(X, Y, 0.0, 0.0, 0.0, 8.0, tiny, 0.5, S)
    assert below == pytest.approx(potential_field_straight(X, Y, 0.0, 0.0, 0.0, 8.0, tiny, 0.5, S))
    above = potential_field(X, Y, 0.0, 0.0, 0.0, 8.0, 0.1, 0.5, S)
    assert above == pytest.approx(potential_field_curved(X, Y, 0.0, 0.0, 0.0, 8.0, 0.1, 0.5, S))
    # vectorised over vehicles: one point per vehicle, mixed steer
    deltas = np.array([0.0, 0.1, -0.2])
    each = potential_field(np.array([5.0, 5.0, 5.0]), np.array([0.5, 1.0, -1.0]), 0.0, 0.0, 0.0, 8.0,
                           deltas, 0.5, S)
    for k in range(3):
        assert each[k] == pytest.approx(potential_field(5.0, [0.5, 1.0, -1.0][k], 0.0, 0.0, 0.0, 8.0,
                                                        deltas[k], 0.5, S))


@pytest.mark.parametrize("delta", [0.0, 0.2])
def test_grows_with_kappa_and_with_speed(delta):
    X, Y = _grid()
    base = potential_field(X, Y, 0.0, 0.0, 0.0, 6.0, delta, 0.2, S)
    aggressive = potential_field(X, Y, 0.0, 0.0, 0.0, 6.0, delta, 0.8, S)
    on = base > 0
    assert aggressive[on] == pytest.approx(base[on] * math.exp(0.6))
    faster = potential_field(X, Y, 0.0, 0.0, 0.0, 9.0, delta, 0.2, S)
    assert np.all(faster >= base) and np.all(faster[on] > base[on])
    # at a fixed point ahead, the field rises with speed
    speeds = np.linspace(2.0, 14.0, 13)
    g = potential_field(5.0, 0.2, 0.0, 0.0, 0.0, speeds, 0.0, 0.5, S)
    assert np.all(np.diff(g) > 0.0)


def test_explicit_arc_length_overrides_geometry():
    # the ETM evaluates fields at conflict points by path arc length, lateral distance 0
    g = potential_field(0.0, 0.0, 0.0, 0.0, 0.0, 5.0, 0.0, 0.5, S, s=6.0)
    assert g == pytest.approx(math.exp(0.5) * (6.0 - 15.0) ** 2)
    assert path_field(6.0, 0.0, 5.0, 0.3, 0.5, S) == pytest.approx(g)
