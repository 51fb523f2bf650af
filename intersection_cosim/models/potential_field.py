"""Gaussian potential field of a vehicle for collision-risk assessment (paper Eqs. 5-8).

    Gamma = Lambda * exp(-(lateral distance to the predicted path)^2 / (2 sigma^2))      (Eq. 5)

- The predicted path of a vehicle steering delta_f is the circle of radius R = l / tan(delta_f)
  around the turning centre (Eq. 6); the lateral distance of a point (X, Y) is
  | |(X, Y) - (X_c, Y_c)| - |R| |.
- Lambda = a (s - v t_p)^2 for 0 <= s <= v t_p and 0 otherwise, a = a0 exp(kappa) (Eq. 7 as
  we read it: the printed a (s - v t_p) is negative inside the preview length).
  s [m] is the arc length along the predicted path from the vehicle to the point, so the field is
  largest at the vehicle and fades to zero at the preview distance v t_p; nothing lies behind it.
- sigma = (b + c |delta_f|) s + d, d = W / 4 (Eq. 8).
- For |delta_f| < ``settings.straight_steer`` the circle is replaced by its straight-line limit:
  the path is the line through the vehicle along its yaw, s the distance along it, the lateral
  distance the distance from it.

Sign convention: delta_f > 0 steers left (counter-clockwise), like our path curvature, so the
turning centre lies to the *left* of the rear axle: (X_c, Y_c) = rear axle + R (-sin phi, cos phi).
The printed Eq. 6 puts it at rear axle + R (sin phi, -cos phi), i.e. it counts right steer as
positive; the two agree after mirroring, and with |R| in Eq. 5 the field is the same.
Arc lengths are measured from the centre of gravity (its angular position on the circle), so
s = 0 at the vehicle in both forms.

Units: positions [m], angles [rad], v [m/s], t_p [s]; Gamma is in units of a0 * m^2.
"""

from __future__ import annotations

import numpy as np

from intersection_cosim.models.settings import ModelSettings

TWO_PI = 2.0 * np.pi


def field_gain(kappa, settings: ModelSettings):
    """a = a0 exp(kappa) (Eq. 7): a more aggressive vehicle projects a stronger field."""
    return settings.a0 * np.exp(kappa)


def preview_time(kappa, settings: ModelSettings):
    """[s] t_p^i of a vehicle of aggressiveness ``kappa`` [-] (Eq. 7's per-vehicle preview time):
    t_p + t_p_kappa (0.5 - kappa), at least t_p_min; t_p for all when t_p_kappa = 0."""
    if settings.t_p_kappa == 0.0:
        return settings.t_p
    return np.maximum(settings.t_p_min, settings.t_p + settings.t_p_kappa * (0.5 - np.asarray(kappa, float)))


def preview_amplitude(s, v, kappa, settings: ModelSettings):
    """Lambda = a (s - v t_p^i)^2 for 0 <= s <= v t_p^i, else 0 (Eq. 7 as we read it).

    ``s`` [m] arc length ahead of the vehicle along its predicted path, ``v`` [m/s]; t_p^i from
    :func:`preview_time`.
    """
    s = np.asarray(s, float)
    reach = np.asarray(v, float) * preview_time(kappa, settings)  # [m] preview length
    inside = (s >= 0.0) & (s <= reach)
    return np.where(inside, field_gain(kappa, settings) * np.square(s - reach), 0.0)


def field_width(s, delta_f, settings: ModelSettings):
    """[m] sigma = (b + c |delta_f|) s + d with d = W / 4 (Eq. 8); s clipped at 0."""
    d = settings.vehicle_width / 4.0
    return (settings.b + settings.c * np.abs(delta_f)) * np.maximum(s, 0.0) + d


def path_field(s, lateral, v, delta_f, kappa, settings: ModelSettings):
    """Eq. 5 given the arc length ``s`` [m] along and the distance ``lateral`` [m] from the
    vehicle's predicted path: Lambda(s) exp(-lateral^2 / (2 sigma(s)^2)) (Eqs. 5, 7, 8)."""
    sigma = field_width(s, delta_f, settings)
    return preview_amplitude(s, v, kappa, settings) * np.exp(-np.square(lateral) / (2.0 * np.square(sigma)))


def turning_centre(x_g, y_g, yaw, delta_f, settings: ModelSettings):
    """[m] turning centre (X_c, Y_c) and signed radius R = l / tan(delta_f) [m] (Eq. 6).

    The centre is R to the left of the rear axle (see the module docstring for the sign).
    ``delta_f`` must be non-zero.
    """
    radius = settings.wheelbase / np.tan(delta_f)
    x_r = x_g - settings.l_r * np.cos(yaw)  # rear axle
    y_r = y_g - settings.l_r * np.sin(yaw)
    return x_r - radius * np.sin(yaw), y_r + radius * np.cos(yaw), radius


def potential_field_curved(X, Y, x_g, y_g, yaw, v, delta_f, kappa, settings: ModelSettings, s=None):
    """Eq. 5 with the turning circle of Eq. 6 (delta_f must be non-zero). All inputs broadcast.

    ``s`` [m], if given, replaces the arc length from the vehicle to (X, Y) along the circle.
    """
    xc, yc, radius = turning_centre(x_g, y_g, yaw, delta_f, settings)
    r_abs = np.abs(radius)
    lateral = np.abs(np.hypot(X - xc, Y - yc) - r_abs)
    if s is None:
        turn = np.sign(radius)  # +1 counter-clockwise (left), -1 clockwise
        angle_p = np.arctan2(Y - yc, X - xc)
        angle_g = np.arctan2(y_g - yc, x_g - xc)
        s = r_abs * np.mod(turn * (angle_p - angle_g), TWO_PI)
    return path_field(s, lateral, v, delta_f, kappa, settings)


def potential_field_straight(X, Y, x_g, y_g, yaw, v, delta_f, kappa, settings: ModelSettings, s=None):
    """Straight-line limit of Eq. 5 (delta_f -> 0): the predicted path is the line through the
    centre of gravity along the yaw. ``s`` [m], if given, replaces the distance along it."""
    dx, dy = X - x_g, Y - y_g
    cos, sin = np.cos(yaw), np.sin(yaw)
    lateral = np.abs(-sin * dx + cos * dy)
    if s is None:
        s = cos * dx + sin * dy
    return path_field(s, lateral, v, delta_f, kappa, settings)


def potential_field(X, Y, x_g, y_g, yaw, v, delta_f, kappa, settings: ModelSettings, s=None):
    """Potential field Gamma of a vehicle at points (X, Y) [m] (Eqs. 5-8), vectorised.

    Vehicle: centre of gravity (x_g, y_g) [m], yaw [rad], speed v [m/s], front-wheel steer
    delta_f [rad], aggressiveness kappa [-]. All arguments broadcast against each other, so one
    vehicle on a grid of points, or N vehicles each at its own point, are one call. The curved form
    is used for |delta_f| >= settings.straight_steer, the straight-line limit below. ``s`` [m], if
    given, is the arc length along the predicted path to the point (Eqs. 7-8) instead of the one
    measured along the circle / line.
    """
    delta_f = np.asarray(delta_f, float)
    small = np.abs(delta_f) < settings.straight_steer
    safe = np.where(small, np.where(delta_f < 0, -1.0, 1.0) * settings.straight_steer, delta_f)
    curved = potential_field_curved(X, Y, x_g, y_g, yaw, v, safe, kappa, settings, s)
    if not np.any(small):
        return curved
    straight = potential_field_straight(X, Y, x_g, y_g, yaw, v, delta_f, kappa, settings, s)
    return np.where(small, straight, curved)
