"""Gamma_cp (Eq. 9) and the event-triggered mechanism (Eq. 39)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from intersection_cosim.models.risk import (
    collision_point_risk,
    event_trigger,
    following_risk,
    gamma_cp,
)
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.conflicts import KIND_CODE

# hand values below are for t_p = 3 s (the default is 4 s); a0 = 1, gamma_sf = 40, clearance 4.5 m
S = ModelSettings(t_p=3.0, t_p_kappa=0.0)  # one preview for every kappa (the default tilts it by kappa)
A5 = math.exp(0.5)  # field gain a at kappa = 0.5
CASE1 = ("south_inner_left_inner", "east_inner_left_inner", "west_inner_left_inner")
CASE1_S = np.array([125.0, 132.0, 120.0])  # [m] (2, -25), (18, 2), (-30, -2) on their paths
CASE1_V = np.array([5.5, 4.5, 5.0])  # [m/s]
KAPPA_A = np.array([0.5, 0.5, 0.5])


def test_gamma_cp_is_the_sum_of_the_fields():
    assert gamma_cp([3.0, 4.5]) == pytest.approx(7.5)
    assert gamma_cp(np.array([[1.0, 2.0], [3.0, 4.0]])) == pytest.approx([4.0, 6.0])


def test_collision_point_risk_hand_values():
    # i: 10 m at 5 m/s (TCP 2 s); j: 12 m at 4 m/s (TCP 3 s). When i is at the point j is
    # 12 - 4 * 2 = 4 m before it: Gamma_j = a (4 - 12)^2; i has passed when j arrives.
    assert collision_point_risk(10.0, 5.0, 0.5, 12.0, 4.0, 0.5, S) == pytest.approx(A5 * 64.0)
    # symmetric in the pair
    assert collision_point_risk(12.0, 4.0, 0.5, 10.0, 5.0, 0.5, S) == pytest.approx(A5 * 64.0)
    # simultaneous arrival: both full fields a (v t_p)^2
    assert collision_point_risk(10.0, 5.0, 0.5, 8.0, 4.0, 0.0, S) == pytest.approx(A5 * 225.0 + 144.0)
    # a vehicle occupying the point (up to the clearance past it) counts as being at it
    assert collision_point_risk(-2.0, 5.0, 0.5, 6.0, 4.0, 0.5, S) == pytest.approx(A5 * (6.0 - 12.0) ** 2)


def test_collision_point_risk_falls_with_the_time_gap():
    # j arrives 0 .. 3 s after i (both within t_p): Gamma = a v_j^2 (t_p - gap)^2
    gap = np.linspace(0.1, 2.9, 15)
    g = collision_point_risk(np.full(15, 0.0), 5.0, 0.5, 5.0 * gap, 5.0, 0.5, S)
    assert g == pytest.approx(A5 * 25.0 * (3.0 - gap) ** 2)
    assert np.all(np.diff(g) < 0)


def test_no_predicted_collision_when_far_away_or_past():
    # j is more than v t_p from the point: its trajectory over t_p does not reach it
    assert collision_point_risk(1.0, 5.0, 0.5, 15.5, 5.0, 0.5, S) == 0.0
    assert collision_point_risk(1.0, 5.0, 1.0, 40.0, 13.0, 1.0, S) == 0.0
    # i has passed the point by more than the clearance (4.5 m)
    assert collision_point_risk(-4.6, 5.0, 0.5, 2.0, 5.0, 0.5, S) == 0.0
    # a stopped vehicle 5 m before the point does not reach it within t_p
    assert collision_point_risk(5.0, 0.0, 0.5, 2.0, 5.0, 0.5, S) == 0.0


def test_following_risk():
    # follower at 8 m/s, 10 m behind: a (10 - 24)^2
    assert following_risk(10.0, 8.0, 0.5, S) == pytest.approx(A5 * 196.0)
    assert following_risk(25.0, 8.0, 0.5, S) == 0.0


def _case1(conflict_table, t, v=CASE1_V, kappa=KAPPA_A, settings=S):
    idx = conflict_table.indices(CASE1)
    return event_trigger(conflict_table, idx, CASE1_S + v * t, v, kappa, settings)


@pytest.mark.parametrize("t_p, gammas", [(3.0, (222.7, 255.9)), (4.0, (428.5, 502.5))])
def test_case1a_triggers_as_the_vehicles_near_the_conflict_zone(conflict_table, t_p, gammas):
    # Constant speeds. V1 reaches the V1-V2 point 0.42 s before V2 and the V1-V3 point 0.51 s
    # before V3. The opposite left turners V2, V3 never form a pair. t_p = 4 s is the default.
    settings = replace(S, t_p=t_p)
    start = _case1(conflict_table, 0.0, settings=settings)
    assert list(zip(start.i.tolist(), start.j.tolist())) == [(0, 1), (0, 2)]
    assert start.kind.tolist() == [KIND_CODE["cross"]] * 2
    assert not start.trigger.any()  # V2 is 4.4 s, V3 5.4 s from their points: beyond t_p
    fired = {}
    for t in np.arange(0.0, 8.0, 0.1):
        r = _case1(conflict_table, t, settings=settings)
        for n in range(len(r.i)):
            if r.trigger[n] and (int(r.i[n]), int(r.j[n])) not in fired:
                fired[(int(r.i[n]), int(r.j[n]))] = (t, float(r.tcp_i[n]), float(r.tcp_j[n]),
                                                      float(r.gamma_cp[n]))
    assert set(fired) == {(0, 1), (0, 2)}
    for pair, later_v in (((0, 1), 4.5), ((0, 2), 5.0)):
        t, tcp_1, tcp_other, gamma = fired[pair]
        # fires once the later vehicle is within t_p of the point, V1 then ~t_p - 0.5 s from it
        assert tcp_other == pytest.approx(t_p, abs=0.1) and tcp_1 == pytest.approx(t_p - 0.5, abs=0.15)
        assert 0.3 < tcp_other - tcp_1 < 0.6
        assert gamma == pytest.approx(A5 * later_v**2 * (t_p - (tcp_other - tcp_1)) ** 2, rel=1e-6)
    assert fired[(0, 1)][3] == pytest.approx(gammas[0], abs=0.5)
    assert fired[(0, 2)][3] == pytest.approx(gammas[1], abs=0.5)
    # still triggered as V1 enters the point ...
    r = _case1(conflict_table, 4.0, settings=settings)
    assert r.trigger.tolist() == [True, True]
    # ... and off for V1-V2 once V1 is more than the clearance past it
    r = _case1(conflict_table, 5.0, settings=settings)
    assert r.trigger.tolist() == [False, True]
    assert not _case1(conflict_table, 6.5, settings=settings).trigger.any()


def test_no_trigger_when_one_vehicle_is_beyond_its_preview(conflict_table):
    idx = conflict_table.indices(CASE1)
    # V1 1 s from the V1-V2 point (146.91 m on its path, 151.81 m on V2's) and 1.9 s from the
    # V1-V3 point (151.81 m on V1's path, 146.91 m on V3's); V2 and V3 just beyond v t_p
    s = np.array([146.91 - 5.5, 151.81 - 4.5 * 3.0 - 0.5, 146.91 - 5.0 * 3.0 - 0.5])
    r = event_trigger(conflict_table, idx, s, CASE1_V, KAPPA_A, S)
    assert r.gamma_cp.tolist() == [0.0, 0.0] and not r.trigger.any()
    # cautious (kappa 0.2) vs aggressive (0.9) second vehicle: the field of the later vehicle
    # scales with exp(kappa)
    s2 = np.array([146.91 - 5.5, 151.81 - 4.5 * 1.5, 146.91 - 5.0 * 2.0])
    low = event_trigger(conflict_table, idx, s2, CASE1_V, np.array([0.5, 0.2, 0.2]), S)
    high = event_trigger(conflict_table, idx, s2, CASE1_V, np.array([0.5, 0.9, 0.9]), S)
    assert high.gamma_cp == pytest.approx(low.gamma_cp * math.exp(0.7))


def test_following_pairs_on_one_lane(conflict_table):
    path = conflict_table.index["south_middle_straight_middle"]
    idx = np.array([path, path, path])
    s = np.array([100.0, 110.0, 200.0])
    v = np.array([8.0, 6.0, 8.0])
    r = event_trigger(conflict_table, idx, s, v, KAPPA_A, S)
    assert r.kind.tolist() == [KIND_CODE["following"]] * 3
    assert r.leader_follower.all()
    # vehicle 0 is 10 m behind vehicle 1 at 8 m/s: a (10 - 24)^2, triggers; the others are far
    assert r.gamma_cp == pytest.approx([A5 * 196.0, 0.0, 0.0])
    assert r.trigger.tolist() == [True, False, False]
    assert r.triggered_pairs.tolist() == [[0, 1]]


def test_confluence_becomes_following_after_the_merge(conflict_table):
    a, b = "south_outer_straight_outer", "east_outer_right_outer"
    idx = conflict_table.indices([a, b])
    pa, pb = idx
    s_cp_a, s_cp_b = conflict_table.s_a[pa, pb], conflict_table.s_b[pa, pb]
    # b has passed the merge point by 3 m, a is 7 m before it: a follows b with a 10 m gap
    r = event_trigger(conflict_table, idx, np.array([s_cp_a - 7.0, s_cp_b + 3.0]),
                      np.array([6.0, 5.0]), np.array([0.5, 0.5]), S)
    assert r.kind.tolist() == [KIND_CODE["confluence"]] and r.leader_follower.tolist() == [True]
    assert r.gamma_cp == pytest.approx([A5 * (10.0 - 18.0) ** 2])
    # before the merge it is an arrival-time conflict like a crossing: both 1 s from the point,
    # so both full fields a (v t_p)^2 add up
    r = event_trigger(conflict_table, idx, np.array([s_cp_a - 6.0, s_cp_b - 5.0]),
                      np.array([6.0, 5.0]), np.array([0.5, 0.5]), S)
    assert r.leader_follower.tolist() == [False]
    assert r.gamma_cp == pytest.approx([A5 * (18.0**2 + 15.0**2)])


def test_paths_that_do_not_meet_never_trigger(conflict_table):
    idx = conflict_table.indices(["east_inner_left_inner", "west_inner_left_inner",
                                  "south_outer_right_outer", "north_outer_right_outer"])
    # all four 1 s before the centre of the junction at once
    s = conflict_table.s_stop[idx] + 12.0 - 5.0
    r = event_trigger(conflict_table, idx, s, np.full(4, 5.0), np.full(4, 1.0), S)
    assert len(r.i) == 0 and r.trigger.shape == (0,) and r.triggered_pairs.shape == (0, 2)


def test_a_cautious_vehicle_previews_further_by_t_p_kappa():
    # t_p^i = t_p + t_p_kappa (0.5 - kappa) (Eq. 7's per-vehicle preview): j arrives second, 18 m
    # at 4 m/s (TCP 4.5 s), beyond t_p = 4 s; i 10 m at 5 m/s (TCP 2 s)
    tilted = replace(ModelSettings(), t_p=4.0, t_p_kappa=4.0)
    flat = replace(tilted, t_p_kappa=0.0)
    assert collision_point_risk(10.0, 5.0, 0.5, 18.0, 4.0, 0.5, tilted) == 0.0  # moderate: 4 s
    assert collision_point_risk(10.0, 5.0, 0.5, 18.0, 4.0, 0.5, flat) == 0.0
    # cautious j (kappa 0.2): t_p^j = 5.2 s; j's field where i is at the point, s = 18 - 4 * 2 = 10 m
    cautious = collision_point_risk(10.0, 5.0, 0.5, 18.0, 4.0, 0.2, tilted)
    assert cautious == pytest.approx(math.exp(0.2) * (10.0 - 4.0 * 5.2) ** 2)
    assert cautious > tilted.gamma_sf  # the cautious vehicle's game is played
    assert collision_point_risk(10.0, 5.0, 0.5, 18.0, 4.0, 0.2, flat) == 0.0  # t_p_kappa 0: not
    # an aggressive j (kappa 0.9) previews 2.4 s: a 2 s-away pair it no longer sees at 4.5 s ...
    assert collision_point_risk(6.0, 5.0, 0.5, 10.0, 4.0, 0.9, tilted) == 0.0
    # ... that a moderate one does (TCP 2.5 s <= 4 s)
    assert collision_point_risk(6.0, 5.0, 0.5, 10.0, 4.0, 0.5, tilted) > 0.0
    # never below t_p_min
    floor = replace(tilted, t_p_kappa=40.0, t_p_min=1.0)
    assert collision_point_risk(1.0, 5.0, 0.9, 1.5, 4.0, 0.9, floor) > 0.0  # TCPs 0.2 / 0.375 s within 1 s
