"""The receiver's Kalman track of a noisy sender (v2x/tracker.py) and what the controller sees
through it (v2x/channel.py)."""

from __future__ import annotations

import numpy as np
import pytest

from intersection_cosim.v2x import Channel, V2XSettings
from intersection_cosim.v2x.tracker import fuse, start, steady_sigma

from tests.v2x.test_channel import PERIOD, PID, truth

SIGMA_S, SIGMA_V, ACCEL_NOISE = 0.65, 0.31, 2.0  # [m], [m/s], [m/s^2]


def motion(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(s [m], v [m/s], a [m/s^2]) every PERIOD: 10 s standing, 4 s at +2.5 m/s^2, 6 s cruising,
    5 s braking at -2 m/s^2, standing (SUMO-like Euler steps of the true motion)."""
    a = np.zeros(n)
    a[100:140], a[200:250] = 2.5, -2.0
    s, v = np.zeros(n), np.zeros(n)
    for k in range(1, n):
        v[k] = max(0.0, v[k - 1] + a[k - 1] * PERIOD)
        s[k] = s[k - 1] + v[k] * PERIOD
    return s, v, a


def tracked(s, v, a, rng, speed_noise=SIGMA_V):
    """The track's position after each message (reads as the channel sends them: v clipped at 0)."""
    zs = s + SIGMA_S * rng.standard_normal(len(s))
    zv = np.maximum(0.0, v + speed_noise * rng.standard_normal(len(s)))
    track, out, sig = start(0.0, zs[0], zv[0], a[0], SIGMA_S, speed_noise), [zs[0]], [SIGMA_S]
    for k in range(1, len(s)):
        track = fuse(track, k * PERIOD, zs[k], zv[k], a[k], SIGMA_S, speed_noise, ACCEL_NOISE)
        out.append(track.s)
        sig.append(track.sigma_s)
    return np.array(out), np.array(sig), zs


def test_a_track_is_far_closer_to_the_truth_than_one_message():
    s, v, a = motion(400)
    rng = np.random.default_rng(7)
    est, sig, zs = tracked(s, v, a, rng)
    late = slice(20, None)  # after the first 2 s
    err, raw = est[late] - s[late], zs[late] - s[late]
    assert np.std(raw) == pytest.approx(SIGMA_S, rel=0.15)
    assert np.sqrt(np.mean(err ** 2)) < 0.45 * np.sqrt(np.mean(raw ** 2))
    bound = 3.0 * steady_sigma(SIGMA_S, SIGMA_V, PERIOD, ACCEL_NOISE)
    assert bound < 3.0 * SIGMA_S / 2
    assert np.mean(np.abs(err) > bound) < 0.01  # the guard's 3-sigma widening holds for 99 % of reads
    assert sig[-1] <= steady_sigma(SIGMA_S, SIGMA_V, PERIOD, ACCEL_NOISE) + 1e-9


def test_a_standing_vehicle_is_not_read_creeping_forward():
    """Speeds read near standstill are clipped at 0 by the sender: fused as they are, they would
    push the track forward (about a third of a metre at these noises); they are not fused."""
    s, v, a = motion(100)  # standing all along
    errors = [tracked(s, v, a, np.random.default_rng(seed))[0][30:].mean() for seed in range(20)]
    assert abs(float(np.mean(errors))) < 0.06


def test_a_noiseless_link_is_taken_as_it_is_and_more_noise_gives_a_wider_sigma():
    t = fuse(start(0.0, 5.0, 2.0, 0.0, 0.0, 0.0), 0.1, 5.3, 2.1, 1.0, 0.0, 0.0, ACCEL_NOISE)
    assert (t.s, t.v, t.a, t.sigma_s) == (5.3, 2.1, 1.0, 0.0)
    assert steady_sigma(0.0, 0.0, PERIOD, ACCEL_NOISE) == 0.0
    sigmas = [steady_sigma(n, 0.3, PERIOD, ACCEL_NOISE) for n in (0.1, 0.3, 0.6, 1.0)]
    assert sigmas == sorted(sigmas) and all(sg < n for sg, n in zip(sigmas, (0.1, 0.3, 0.6, 1.0)))


def test_the_channel_sees_a_vehicle_standing_short_of_its_stop_line_there(movements):
    """1 m of position noise: one message in fifteen puts a vehicle standing 1.5 m short of its
    stop line past it (in the junction); its track (three deviations: 1.3 m) does not."""
    path = movements.paths[PID]
    s_stand = path.s_stop - 1.5  # [m]
    ch = Channel(V2XSettings(position_noise=1.0, speed_noise=0.3), movements, PERIOD, seed=3)
    seen_s, raw_past = [], 0
    for k in range(300):
        w = truth(movements, round(k * PERIOD, 6), s_stand, 0.0)
        ch.uplink(w)
        raw_past += ch._up[-1].s > path.s_stop if ch._up else 0
        seen = ch.observe(w)
        seen_s.append(float(seen.s[0]))
    late = np.array(seen_s[30:])
    assert raw_past > 10  # the messages alone cross the stop line often
    assert late.max() < path.s_stop
    assert abs(late.mean() - s_stand) < 0.2
    assert 3.0 * steady_sigma(1.0, 0.3, PERIOD, 2.0) < 1.5
