"""Kinematic bicycle model of the paper, Eqs. 1-4, vectorised over vehicles.

State ``x = [v_x, yaw, X_g, Y_g]`` (index constants ``V, YAW, X, Y``): longitudinal speed [m/s],
yaw angle phi [rad] (counter-clockwise from east), position of the centre of gravity [m].
Control ``u = [a_x, delta_f]``: longitudinal acceleration [m/s^2], front-wheel steer [rad]
(positive = left, the sign of our path curvature).

Arrays have the state / control on the last axis and broadcast over any leading axes (vehicles,
samples). Eq. 2's position rows use the heading Phi = phi + beta (Eq. 4): ``v_x cos(Phi) /
cos(beta)`` is the speed of the centre of gravity along its direction of travel, which is what
makes the yaw row ``v_x tan(beta) / l_r`` consistent (the printed Eq. 2 writes the yaw symbol in
the position rows; with the heading the model is the standard kinematic bicycle).
"""

from __future__ import annotations

import numpy as np

from intersection_cosim.models.settings import ModelSettings

V, YAW, X, Y = 0, 1, 2, 3  # state indices
ACCEL, STEER = 0, 1  # control indices


def _axles(settings: ModelSettings | None) -> tuple[float, float]:
    settings = settings or ModelSettings()
    return settings.l_f, settings.l_r


def slip_angle(delta_f, l_f, l_r):
    """[rad] sideslip angle beta = atan(l_r / (l_f + l_r) * tan(delta_f)) (Eq. 3)."""
    return np.arctan(np.asarray(l_r) / (np.asarray(l_f) + np.asarray(l_r)) * np.tan(delta_f))


def heading_angle(yaw, delta_f, l_f, l_r):
    """[rad] heading of the centre of gravity's velocity, Phi = phi + beta (Eq. 4)."""
    return np.asarray(yaw) + slip_angle(delta_f, l_f, l_r)


def bicycle_derivative(state, control, settings: ModelSettings | None = None):
    """dx/dt = f(x, u) of the kinematic bicycle (Eqs. 1-2), same shape as ``state``.

    ``state`` (..., 4) = [v_x, yaw, X, Y]; ``control`` (..., 2) = [a_x, delta_f], broadcast.
    """
    l_f, l_r = _axles(settings)
    state = np.asarray(state, float)
    control = np.asarray(control, float)
    v, yaw = state[..., V], state[..., YAW]
    a, delta = control[..., ACCEL], control[..., STEER]
    beta = slip_angle(delta, l_f, l_r)
    phi = yaw + beta  # Eq. 4
    speed = v / np.cos(beta)  # [m/s] speed of the centre of gravity
    return np.stack(np.broadcast_arrays(a, v * np.tan(beta) / l_r, speed * np.cos(phi),
                                        speed * np.sin(phi)), axis=-1)


def step(state, control, dt: float, settings: ModelSettings | None = None, *, clip_speed: bool = True):
    """State after ``dt`` [s] with the control held constant: one classical Runge-Kutta step of
    Eqs. 1-2, exact for constant acceleration on a straight line (degree 2 in t).

    With ``clip_speed`` a braking vehicle stops and does not reverse: a vehicle that would reach
    zero speed within the step is integrated only up to its stopping time v / |a_x| and then
    stands still (so its speed is exactly 0 and it never moves backwards).
    """
    state = np.asarray(state, float)
    control = np.asarray(control, float)
    h = np.asarray(dt, float)
    if clip_speed:
        v, a = np.broadcast_arrays(state[..., V], control[..., ACCEL])
        braking = a < 0.0
        t_stop = np.where(braking, np.maximum(v, 0.0) / np.where(braking, -a, 1.0), np.inf)
        h = np.minimum(h, t_stop)[..., None]
    k1 = bicycle_derivative(state, control, settings)
    k2 = bicycle_derivative(state + 0.5 * h * k1, control, settings)
    k3 = bicycle_derivative(state + 0.5 * h * k2, control, settings)
    k4 = bicycle_derivative(state + h * k3, control, settings)
    out = state + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    if clip_speed:
        out[..., V] = np.maximum(out[..., V], 0.0)
    return out


def rollout(state0, controls, dt: float, settings: ModelSettings | None = None, *, clip_speed: bool = True):
    """Trajectory from ``state0`` under a control sequence (Eqs. 1-4).

    ``state0`` (..., 4); ``controls`` (..., T, 2), one control per step of ``dt`` [s] (leading axes
    broadcast with ``state0``'s). Returns states (..., T + 1, 4), the first being ``state0``.
    """
    state = np.asarray(state0, float)
    controls = np.asarray(controls, float)
    lead = np.broadcast_shapes(state.shape[:-1], controls.shape[:-2])
    state = np.broadcast_to(state, lead + (4,)).copy()
    out = np.empty(lead + (controls.shape[-2] + 1, 4))
    out[..., 0, :] = state
    for k in range(controls.shape[-2]):
        state = step(state, controls[..., k, :], dt, settings, clip_speed=clip_speed)
        out[..., k + 1, :] = state
    return out
