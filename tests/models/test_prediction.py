"""Model-based prediction (Section III-C), path table look-ups and conflict look-ups."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from intersection_cosim.models.cost import time_to_conflict_point
from intersection_cosim.models.path_table import PathTable
from intersection_cosim.models.prediction import (
    all_pairs,
    conflict_lookup,
    predict_along_paths,
    predict_arc_length,
    predict_free,
    predicted_collision_point,
    preview_times,
)
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.conflicts import KIND_CODE

S = ModelSettings(t_p=3.0)  # t_p = 3 s (the default is 4 s), prediction_dt = 0.1 s
CASE1 = ("south_inner_left_inner", "east_inner_left_inner", "west_inner_left_inner")
CASE1_S = np.array([125.0, 132.0, 120.0])  # [m] arc lengths of (2, -25), (18, 2), (-30, -2)
CASE1_V = np.array([5.5, 4.5, 5.0])  # [m/s]


@pytest.fixture(scope="module")
def table(paths):
    return PathTable.build(paths)


def test_preview_times():
    assert preview_times(3.0, 0.1) == pytest.approx(np.linspace(0, 3, 31))
    assert preview_times(2.0, 0.5) == pytest.approx([0, 0.5, 1.0, 1.5, 2.0])


def test_arc_length_at_constant_acceleration_and_stopping():
    t = np.array([0.0, 1.0, 2.0, 4.0])
    s, v = predict_arc_length([10.0, 0.0], [5.0, 4.0], [1.0, -2.0], t)
    assert s[0] == pytest.approx([10.0, 15.5, 22.0, 38.0])
    assert v[0] == pytest.approx([5.0, 6.0, 7.0, 9.0])
    # braking at 2 m/s^2 from 4 m/s stops after 2 s and 4 m, and stays there
    assert s[1] == pytest.approx([0.0, 3.0, 4.0, 4.0])
    assert v[1] == pytest.approx([4.0, 2.0, 0.0, 0.0])


def test_path_table_matches_movement_path(paths, table):
    rng = np.random.default_rng(1)
    ids = list(paths)
    idx = rng.integers(0, len(ids), 200)
    s = rng.uniform(-5.0, 310.0, 200)
    xy = table.point_at(idx, s)
    heading = table.heading_at(idx, s)
    curv = table.curvature_at(idx, s)
    for k in range(200):
        p = paths[ids[idx[k]]]
        assert xy[k] == pytest.approx(p.point_at(s[k]), abs=1e-9)
        assert heading[k] == pytest.approx(p.heading_at(s[k]), abs=1e-9)
        assert curv[k] == pytest.approx(p.curvature_at(s[k]), abs=1e-9)
    assert table.steer_at(idx, s, 2.7) == pytest.approx(np.arctan(2.7 * curv))
    assert table.indices(CASE1).tolist() == [table.index[p] for p in CASE1]


def test_predict_along_paths_case1(paths, table):
    idx = table.indices(CASE1)
    pred = predict_along_paths(table, idx, CASE1_S, CASE1_V, S)
    assert pred.t == pytest.approx(np.linspace(0.0, 3.0, 31))
    assert pred.xy.shape == (3, 31, 2)
    assert pred.s[:, -1] == pytest.approx(CASE1_S + 3.0 * CASE1_V)
    # V1 drives north on x = 2 for the first 13 m, then is in the junction
    assert pred.xy[0, 0] == pytest.approx([2.0, -25.0], abs=1e-6)
    assert pred.xy[0, 20] == pytest.approx([2.0, -14.0], abs=1e-6)
    p1 = paths[CASE1[0]]
    assert pred.xy[0, -1] == pytest.approx(p1.point_at(125.0 + 16.5), abs=1e-9)
    assert pred.yaw[0, 0] == pytest.approx(math.pi / 2)
    assert pred.delta_f[0, -1] == pytest.approx(p1.steer_at(141.5, S.wheelbase), abs=1e-9)
    # with braking the prediction stops short
    pred_b = predict_along_paths(table, idx, CASE1_S, CASE1_V, S, a=-2.0)
    assert pred_b.s[0, -1] == pytest.approx(125.0 + 5.5**2 / 4.0)
    assert pred_b.v[:, -1] == pytest.approx([0.0, 0.0, 0.0])


def test_free_prediction_straight_and_turning():
    s = replace(S, t_p=3.0)
    state = np.array([[10.0, 0.0, 0.0, 0.0], [8.0, 0.5, 5.0, 5.0]])
    control = np.array([[1.0, 0.0], [0.0, 0.15]])
    pred = predict_free(state, control, s)
    t = pred.t
    # straight line at constant acceleration: the cubic fit is exact
    assert pred.xy[0, :, 0] == pytest.approx(10.0 * t + 0.5 * t**2, abs=1e-9)
    assert pred.xy[0, :, 1] == pytest.approx(np.zeros_like(t), abs=1e-9)
    # constant steer (radius 17.9 m, 77 degrees of turn in 3 s): the cubic follows the rollout to
    # within a few centimetres
    err = np.linalg.norm(pred.xy[1] - pred.states[1, :, 2:], axis=1)
    assert err.max() < 0.05
    assert pred.position([1.5])[:, 0] == pytest.approx(pred.xy[:, 15], abs=1e-9)


def test_predicted_collision_point_of_two_crossing_trajectories():
    t = preview_times(3.0, 0.1)
    xy_i = np.stack([-20.0 + 10.0 * t, np.zeros_like(t)], axis=1)  # eastbound at 10 m/s
    xy_j = np.stack([np.zeros_like(t), -15.0 + 5.0 * t], axis=1)  # northbound at 5 m/s
    cp = predicted_collision_point(t, xy_i, xy_j, 10.0, 5.0, width=1.8)
    assert cp is not None
    # first samples whose distance to the other trajectory is below 1.8 m: x = -1, y = -1.5
    assert (cp.s_i, cp.s_j) == pytest.approx((19.0, 13.5))
    assert (cp.t_i, cp.t_j) == pytest.approx((1.9, 2.7))
    assert (cp.tcp_i, cp.tcp_j) == pytest.approx((1.9, 2.7))
    assert (cp.x, cp.y) == pytest.approx((-0.5, -0.75))
    # parallel trajectories 4 m apart never meet
    assert predicted_collision_point(t, xy_i, xy_i + [0.0, 4.0], 10.0, 10.0, width=1.8) is None


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
