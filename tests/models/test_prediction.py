"""Prediction along the paths (Section III-C): the kinematic bicycle (Eqs. 1-4) reduces to it on
a path, and the conflict-point look-ups of vehicle pairs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from intersection_cosim.games.dynamics import rollout
from intersection_cosim.models.cost import time_to_conflict_point
from intersection_cosim.models.prediction import all_pairs, conflict_lookup
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.conflicts import KIND_CODE

CASE1 = ("south_inner_left_inner", "east_inner_left_inner", "west_inner_left_inner")
CASE1_S = np.array([125.0, 132.0, 120.0])  # [m] arc lengths of (2, -25), (18, 2), (-30, -2)
CASE1_V = np.array([5.5, 4.5, 5.0])  # [m/s]


def _bicycle(state, a_x, delta_f, l_f, l_r):
    """d/dt [v_x, yaw, X_g, Y_g] of the kinematic bicycle, Eqs. 1-4 (heading Phi = yaw + beta)."""
    v, yaw = state[0], state[1]
    beta = math.atan(l_r / (l_f + l_r) * math.tan(delta_f))  # Eq. 3
    phi = yaw + beta  # Eq. 4
    return np.array([a_x, v * math.tan(beta) / l_r, v * math.cos(phi) / math.cos(beta),
                     v * math.sin(phi) / math.cos(beta)])


def _integrate_bicycle(state, a_x, delta_f, l_f, l_r, dt, steps):
    """Classical Runge-Kutta over ``steps`` steps of ``dt`` [s]; returns (steps + 1, 4) states."""
    out = [np.asarray(state, float)]
    for _ in range(steps):
        x = out[-1]
        k1 = _bicycle(x, a_x, delta_f, l_f, l_r)
        k2 = _bicycle(x + 0.5 * dt * k1, a_x, delta_f, l_f, l_r)
        k3 = _bicycle(x + 0.5 * dt * k2, a_x, delta_f, l_f, l_r)
        k4 = _bicycle(x + dt * k3, a_x, delta_f, l_f, l_r)
        out.append(x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4))
    return np.array(out)


@pytest.mark.parametrize("a_path", [0.0, 1.2, -1.0])  # [m/s^2] along the path
def test_bicycle_on_a_circular_arc_is_the_path_prediction(a_path):
    """A left turn of radius 12 m: the bicycle with the steer that tracks the arc stays on it, and
    its arc length and speed along it are the path prediction's (games.dynamics.rollout) for
    v = v_x / cos(beta) and a = a_x / cos(beta); at a = 0 it reaches a point d metres ahead after
    TCP = d / v (models.cost.time_to_conflict_point)."""
    m = ModelSettings()
    radius, u0, dt, steps = 12.0, 6.0, 0.01, 250  # [m], [m/s], [s], 2.5 s (braking: stops at 6 s)
    beta = math.asin(m.l_r / radius)  # [rad] sideslip that gives the CG path curvature 1 / radius
    delta_f = math.atan(m.wheelbase / m.l_r * math.tan(beta))  # [rad] Eq. 3 solved for the steer
    assert delta_f == pytest.approx(math.atan(m.wheelbase / radius), abs=0.002)  # network.paths' steer
    # centre of gravity at (radius, 0) heading north (counter-clockwise round the origin)
    state0 = [u0 * math.cos(beta), math.pi / 2 - beta, radius, 0.0]
    states = _integrate_bicycle(state0, a_path * math.cos(beta), delta_f, m.l_f, m.l_r, dt, steps)
    r = np.hypot(states[:, 2], states[:, 3])
    assert r == pytest.approx(radius, abs=1e-6)  # on the arc: no slip relative to the path
    arc = radius * np.unwrap(np.arctan2(states[:, 3], states[:, 2]))  # [m] arc length travelled
    v_path, s_path = rollout(0.0, u0, np.full(steps, a_path), dt)
    assert arc[1:] == pytest.approx(s_path, abs=1e-6)
    assert states[1:, 0] / math.cos(beta) == pytest.approx(v_path, abs=1e-9)
    assert s_path[-1] == pytest.approx(u0 * 2.5 + 0.5 * a_path * 2.5**2)
    if a_path == 0.0:  # the trigger's TCP: 15 m of arc ahead at 6 m/s is reached after 2.5 s
        assert time_to_conflict_point(15.0, u0) == pytest.approx(2.5)
        assert arc[-1] == pytest.approx(15.0, abs=1e-6)


def test_conflict_lookup_and_tcp_for_case1(conflict_table):
    idx = conflict_table.indices(CASE1)
    pc = conflict_lookup(conflict_table, idx)
    # two cross conflicts (V1-V2, V1-V3); the opposite left turners V2-V3 do not meet
    assert list(zip(pc.i.tolist(), pc.j.tolist())) == [(0, 1), (0, 2)]
    assert pc.kind.tolist() == [KIND_CODE["cross"]] * 2
    assert pc.s_cp_i == pytest.approx([146.91, 151.81], abs=0.02)
    assert pc.s_cp_j == pytest.approx([151.81, 146.91], abs=0.02)
    tcp_1 = time_to_conflict_point(pc.s_cp_i - CASE1_S[pc.i], CASE1_V[pc.i])
    tcp_2 = time_to_conflict_point(pc.s_cp_j - CASE1_S[pc.j], CASE1_V[pc.j])
    assert tcp_1 == pytest.approx([21.91 / 5.5, 26.81 / 5.5], abs=0.01)
    assert tcp_2 == pytest.approx([19.81 / 4.5, 26.91 / 5.0], abs=0.01)
    everything = conflict_lookup(conflict_table, idx, conflicting_only=False)
    assert everything.kind.tolist() == [KIND_CODE["cross"], KIND_CODE["cross"], 0]


def test_all_pairs():
    i, j = all_pairs(4)
    assert list(zip(i.tolist(), j.tolist())) == [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)]
    assert all_pairs(4)[0] is i


# ---- human drivers: a vehicle that will not yield

def test_a_human_is_never_predicted_to_brake_and_keeps_its_positive_acceleration_up_to_its_cap():
    from intersection_cosim.models.prediction import human_accelerations

    braking = human_accelerations(v0=8.0, a0=-3.0, a_max=2.5, v_cap=10.0, steps=30, dt=0.1)
    assert np.all(braking == 0.0)  # measured braking is not extrapolated: constant speed
    speeding = human_accelerations(v0=8.0, a0=1.0, a_max=2.5, v_cap=10.0, steps=30, dt=0.1)
    v = 8.0 + np.cumsum(speeding) * 0.1
    assert speeding[0] == pytest.approx(1.0)
    assert v.max() == pytest.approx(10.0) and np.all(v <= 10.0 + 1e-12)  # reaches its cap in 2 s, stays there
    assert np.all(speeding[21:] == 0.0)
    hard = human_accelerations(v0=0.0, a0=5.0, a_max=2.5, v_cap=10.0, steps=5, dt=0.1)
    assert np.all(hard == 2.5)  # clipped at a_max
    standing = human_accelerations(v0=0.0, a0=0.0, a_max=2.5, v_cap=10.0, steps=10, dt=0.1)
    assert np.all(standing == 0.0)  # held at its stop line: predicted to stay
