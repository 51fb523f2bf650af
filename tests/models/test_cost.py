"""Running-cost terms, Eqs. 13-24, at hand-computed points."""

from __future__ import annotations

import math

import numpy as np
import pytest

from intersection_cosim.models.cost import (
    efficiency_cost,
    lane_keeping_cost,
    lateral_safety_cost,
    lateral_ttc,
    longitudinal_safety_cost,
    longitudinal_ttc,
    running_cost,
    safety_cost,
    time_to_conflict_point,
)
from intersection_cosim.models.settings import ModelSettings

# hand values for unit safety weights: eps = 0.25 s^2, k_log = k_lat = k_lk = 1 (the default k_lat is 5),
# k_phi = 0.5, k_e = 0.04, v_max = 10
S = ModelSettings(k_lat=1.0)


def test_longitudinal_ttc():
    # Eqs. 16-17: 20 m gap, closing at 10 - 6 = 4 m/s -> 5 s
    assert longitudinal_ttc(20.0, 10.0, 6.0) == pytest.approx(5.0)
    assert longitudinal_ttc(3.0, 7.5, 1.5) == pytest.approx(0.5)
    # not closing: infinite
    assert longitudinal_ttc(20.0, 6.0, 6.0) == math.inf
    assert longitudinal_ttc(20.0, 5.0, 6.0) == math.inf
    assert longitudinal_ttc([20.0, 20.0], [10.0, 5.0], 6.0).tolist() == [5.0, math.inf]


def test_longitudinal_safety_cost():
    # Eq. 15: 1 / (TTC^2 + eps) with gamma_log = 1 while closing (Eq. 18)
    assert longitudinal_safety_cost(20.0, 10.0, 6.0, 0.25) == pytest.approx(1.0 / 25.25)
    assert longitudinal_safety_cost(3.0, 7.5, 1.5, 0.25) == pytest.approx(2.0)
    # zero closing speed: gamma_log = 0, no cost (and no division by zero)
    assert longitudinal_safety_cost(20.0, 6.0, 6.0, 0.25) == 0.0
    assert longitudinal_safety_cost(0.0, 6.0, 6.0, 0.25) == 0.0
    # overlapping bodies (negative gap): TTC 0, the largest cost 1 / eps, closing or not; the cost
    # must not fall as the overlap grows
    assert longitudinal_ttc(-1.0, 7.0, 5.0) == 0.0
    assert longitudinal_safety_cost(-1.0, 7.0, 5.0, 0.25) == pytest.approx(4.0)
    assert longitudinal_safety_cost(-3.0, 5.0, 7.0, 0.25) == pytest.approx(4.0)
    # the leader pulls away: no cost
    assert longitudinal_safety_cost(5.0, 4.0, 6.0, 0.25) == 0.0
    # a vanishing gap while closing: 1 / eps
    assert longitudinal_safety_cost(0.0, 7.0, 6.0, 0.25) == pytest.approx(4.0)


def test_time_to_conflict_point():
    # Eqs. 21-22: distance / speed
    assert time_to_conflict_point(30.0, 6.0) == pytest.approx(5.0)
    assert time_to_conflict_point(21.91, 5.5) == pytest.approx(3.9836, abs=1e-4)
    # a stopped vehicle: speed floored at 0.1 m/s
    assert time_to_conflict_point(2.0, 0.0) == pytest.approx(20.0)
    assert time_to_conflict_point(2.0, 0.0, speed_floor=0.5) == pytest.approx(4.0)
    # past the point: negative
    assert time_to_conflict_point(-3.0, 5.0) == pytest.approx(-0.6)


def test_lateral_ttc_and_cost():
    # Eq. 20: TTC_lat = TCP_i - TCP_j; Eq. 19: 1 / (TTC_lat^2 + eps)
    assert lateral_ttc(5.0, 3.0) == pytest.approx(2.0)
    assert lateral_ttc(3.0, 5.0) == pytest.approx(-2.0)
    assert lateral_safety_cost(5.0, 3.0, 0.25) == pytest.approx(1.0 / 4.25)
    assert lateral_safety_cost(3.0, 5.0, 0.25) == pytest.approx(1.0 / 4.25)
    assert lateral_safety_cost(4.0, 4.0, 0.25) == pytest.approx(4.0)  # simultaneous arrival: 1 / eps
    assert lateral_safety_cost(10.0, 0.5, 1.0) == pytest.approx(1.0 / 91.25)


def test_no_lateral_cost_once_a_vehicle_has_passed_the_conflict_point():
    # i is 3 m past the point (TCP -0.6 s), j is 2 m before it at 4 m/s (TCP 0.5 s)
    tcp_i = time_to_conflict_point(-3.0, 5.0)
    tcp_j = time_to_conflict_point(2.0, 4.0)
    passed = (tcp_i < 0) | (tcp_j < 0)
    assert lateral_safety_cost(tcp_i, tcp_j, 0.25, active=not passed) == 0.0
    # vectorised over a horizon: the cost drops to 0 from the step at which i has passed
    tcp_i = np.array([1.0, 0.5, 0.0, -0.5])
    tcp_j = np.array([1.5, 1.0, 0.5, 0.0])
    cost = lateral_safety_cost(tcp_i, tcp_j, 0.25, active=tcp_i >= 0)
    assert cost == pytest.approx([2.0, 2.0, 2.0, 0.0])


def test_lane_keeping_cost():
    # Eq. 23: k_y dy^2 + k_phi dphi^2
    assert lane_keeping_cost(1.0, 0.2, 0.05, 0.5) == pytest.approx(0.05 + 0.02)
    assert lane_keeping_cost(-2.0, 0.0, 0.05, 0.5) == pytest.approx(0.2)
    assert lane_keeping_cost(0.0, 0.0, 0.05, 0.5) == 0.0


def test_efficiency_cost():
    # Eq. 24: k_e (v - v_max)^2
    assert efficiency_cost(6.0, 10.0, 0.04) == pytest.approx(0.64)
    assert efficiency_cost(10.0, 10.0, 0.04) == 0.0
    assert efficiency_cost(12.0, 10.0, 0.04) == pytest.approx(0.16)


def test_safety_and_running_cost():
    j_log, j_lat, j_lk, j_e = 1.0 / 25.25, 1.0 / 4.25, 0.07, 0.64
    # Eq. 14 with unit weights
    assert safety_cost(j_log, j_lat, j_lk, S) == pytest.approx(j_log + j_lat + j_lk)
    # Eq. 13: (1 - kappa) J_s + kappa J_e
    j_s = j_log + j_lat + j_lk
    assert running_cost(0.5, j_log, j_lat, j_lk, j_e, S) == pytest.approx(0.5 * j_s + 0.5 * j_e)
    assert running_cost(0.0, j_log, j_lat, j_lk, j_e, S) == pytest.approx(j_s)
    assert running_cost(1.0, j_log, j_lat, j_lk, j_e, S) == pytest.approx(j_e)
    assert running_cost(0.8, j_log, j_lat, j_lk, j_e, S) == pytest.approx(0.2 * j_s + 0.8 * j_e)
    # a more aggressive vehicle weighs efficiency more: here J_e > J_s, so J grows with kappa
    costs = [running_cost(k, j_log, j_lat, j_lk, j_e, S) for k in (0.2, 0.5, 0.9)]
    assert costs == sorted(costs)
    # weights apply (Eq. 14)
    from dataclasses import replace

    w = replace(S, k_log=2.0, k_lat=0.0, k_lk=0.5)
    assert safety_cost(j_log, j_lat, j_lk, w) == pytest.approx(2.0 * j_log + 0.5 * j_lk)


def test_the_compiled_terms_are_the_numpy_formulas_bit_for_bit():
    """J_log, J_lat and TCP are compiled ufuncs (models/cost.py): on 10^5 random steps, with
    overlaps, standstills, bool and float weights, their values are those of the numpy formulas
    they replaced, to the last bit."""
    rng = np.random.default_rng(1)
    n, eps = 100_000, 0.05
    gap, v, v_lead = rng.normal(5, 10, n), rng.uniform(0, 15, n), rng.uniform(0, 15, n)
    dv = v - v_lead
    ttc = np.divide(gap, dv, out=np.zeros(n), where=(dv > 0) & (gap >= 0))
    j_log = np.where((dv > 0) | (gap < 0), 1.0 / (np.square(ttc) + eps), 0.0)
    assert np.array_equal(longitudinal_safety_cost(gap, v, v_lead, eps), j_log)
    assert (gap < 0).any() and (dv <= 0).any()
    tcp_i, tcp_j = rng.normal(0, 3, n), rng.normal(0, 3, n)
    weight = rng.uniform(0, 2, n) * (rng.random(n) < 0.5)
    lat = 1.0 / (np.square(tcp_i - tcp_j) + eps)
    assert np.array_equal(lateral_safety_cost(tcp_i, tcp_j, eps, weight), np.where(weight, lat, 0.0) * weight)
    assert np.array_equal(lateral_safety_cost(tcp_i, tcp_j, eps, weight > 0), np.where(weight > 0, lat, 0.0))
    d, speed = rng.normal(0, 20, n), v - 3.0  # some below the floor
    assert np.array_equal(time_to_conflict_point(d, speed, 0.1), d / np.maximum(speed, 0.1))
    assert isinstance(time_to_conflict_point(10.0, 0.0, 0.1), float) and time_to_conflict_point(10.0, 0.0, 0.1) == 100.0
