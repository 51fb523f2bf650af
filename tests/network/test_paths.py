"""Movement paths read from the SUMO net (issue 3, item 2)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sumolib

from intersection_cosim.network.spec import ARMS, LANE_INDEX, LANE_USE, exit_arm

WHEELBASE = 2.7  # [m] l = l_f + l_r of the default vehicle


@pytest.fixture(scope="module")
def net(net_file):
    return sumolib.net.readNet(str(net_file), withInternal=True)


def _circle_curvature(xy: np.ndarray) -> float:
    """[1/m] 1 / radius of the least-squares (Kasa) circle through the points."""
    x, y = xy[:, 0], xy[:, 1]
    a = np.c_[2 * x, 2 * y, np.ones_like(x)]
    cx, cy, c = np.linalg.lstsq(a, x**2 + y**2, rcond=None)[0]
    return 1.0 / math.sqrt(c + cx**2 + cy**2)


def test_one_path_per_allowed_movement_and_exit_lane(paths):
    expected = {f"{arm}_{lane}_{move}_{exit_lane}" for arm in ARMS for lane, moves in LANE_USE.items()
                for move, exits in moves.items() for exit_lane in exits}
    assert set(paths) == expected
    assert len(paths) == 28


def test_paths_start_and_end_on_their_lanes(paths, net):
    for p in paths.values():
        first = f"{p.approach}_in_{LANE_INDEX[p.lane]}"
        last = f"{exit_arm(p.approach, p.movement)}_out_{LANE_INDEX[p.exit_lane]}"
        assert p.lanes[0] == first and p.lanes[-1] == last
        assert all(ln.startswith(":C_") for ln in p.junction_lanes) and p.junction_lanes
        assert p.xy[0] == pytest.approx(net.getLane(first).getShape()[0][:2], abs=1e-6)
        assert p.xy[-1] == pytest.approx(net.getLane(last).getShape()[-1][:2], abs=1e-6)


def test_stop_line_and_exit_at_the_junction_edge(paths):
    # The junction is the square |x|, |y| <= 12 m; stop lines 12 m from the centre.
    p = paths["south_inner_left_inner"]
    assert p.point_at(p.s_stop) == pytest.approx([2.0, -12.0], abs=1e-3)  # resampled at 0.25 m
    assert p.point_at(p.s_exit) == pytest.approx([-12.0, 2.0], abs=1e-3)
    q = paths["east_middle_straight_middle"]
    assert q.point_at(q.s_stop) == pytest.approx([12.0, 6.0], abs=1e-6)
    assert q.s_exit - q.s_stop == pytest.approx(24.0, abs=1e-6)


def test_length_is_the_sum_of_sumolib_lane_lengths(paths, net):
    for p in paths.values():
        reported = sum(net.getLane(ln).getLength() for ln in p.lanes)
        assert p.length == pytest.approx(reported, rel=0.01)
        assert p.s_stop == pytest.approx(net.getLane(p.lanes[0]).getLength(), rel=0.01)
        assert p.s[-1] == pytest.approx(p.length)
        assert np.all(np.diff(p.s) > 0)


def test_heading_turns_by_a_quarter_for_turns_and_not_for_straights(paths):
    for p in paths.values():
        turn = p.heading_at(p.length) - p.heading_at(0.0)
        expected = {"left": math.pi / 2, "right": -math.pi / 2, "straight": 0.0}[p.movement]
        assert turn == pytest.approx(expected, abs=1e-6)
        # the integral of the curvature over the junction (with the smoothing tails) is the turn
        m = (p.s > p.s_stop - 5.0) & (p.s < p.s_exit + 5.0)
        assert np.trapezoid(p.curvature[m], p.s[m]) == pytest.approx(expected, abs=0.03)


def test_curvature_sign_and_straight_lanes(paths):
    for p in paths.values():
        mid = 0.5 * (p.s_stop + p.s_exit)
        if p.movement == "left":
            assert p.curvature_at(mid) > 0.03
        elif p.movement == "right":
            assert p.curvature_at(mid) < -0.03
        else:
            assert np.max(np.abs(p.curvature)) < 1e-9
        # on the approach lane, away from the junction, every path is straight
        assert abs(p.curvature_at(p.s_stop - 10.0)) < 1e-9


@pytest.mark.parametrize("pid", ["south_inner_left_inner", "east_inner_left_middle",
                                 "north_outer_right_middle"])
def test_curvature_matches_a_circle_fit_along_the_turn(paths, pid):
    # SUMO's turn shapes are not single arcs (curvature rises and falls along them), so fit a
    # circle locally: to the centre line within +-2 m of a quarter, half and three quarters of the
    # turn, and compare with the path's curvature there.
    p = paths[pid]
    for frac in (0.25, 0.5, 0.75):
        s0 = p.s_stop + frac * (p.s_exit - p.s_stop)
        window = np.abs(p.s - s0) <= 2.0
        assert abs(p.curvature_at(s0)) == pytest.approx(_circle_curvature(p.xy[window]), rel=0.10)


def test_left_turn_curvature_is_close_to_a_circle_of_the_junction_corner(paths):
    # The inner left turn goes from (2, -12) to (-12, 2): a quarter circle about (-12, -12) would
    # have radius 14 m (curvature 0.071 1/m); SUMO's shape is tighter in the middle.
    p = paths["south_inner_left_inner"]
    m = (p.s >= p.s_stop) & (p.s <= p.s_exit)
    assert _circle_curvature(p.xy[m]) == pytest.approx(0.084, abs=0.005)
    assert np.mean(p.curvature[m]) == pytest.approx(math.pi / 2 / (p.s_exit - p.s_stop), rel=0.05)


def test_steer_is_atan_of_wheelbase_times_curvature(paths):
    p = paths["south_inner_left_inner"]
    s = np.linspace(p.s_stop, p.s_exit, 7)
    assert p.steer_at(s, WHEELBASE) == pytest.approx(np.arctan(WHEELBASE * p.curvature_at(s)))
    mid = 0.5 * (p.s_stop + p.s_exit)
    assert p.steer_at(mid, WHEELBASE) == pytest.approx(math.atan(WHEELBASE * 0.098), abs=0.01)
    assert paths["south_middle_straight_middle"].steer_at(mid, WHEELBASE) == pytest.approx(0.0, abs=1e-9)


def test_project_finds_case1_start_points(paths):
    # Case 1: V1 (2, -25) on the south inner lane is 13 m before the stop line.
    s, dist = paths["south_inner_left_inner"].project(2.0, -25.0)
    assert s == pytest.approx(125.0, abs=1e-6) and dist == pytest.approx(0.0, abs=1e-6)
    s, dist = paths["east_inner_left_inner"].project(18.0, 3.0)
    assert s == pytest.approx(132.0, abs=1e-6) and dist == pytest.approx(1.0, abs=1e-6)


def test_lane_at_maps_arc_length_to_sumo_lanes(paths):
    p = paths["south_inner_left_inner"]
    assert p.lane_at(10.0) == ("south_in_2", pytest.approx(10.0))
    lane, pos = p.lane_at(p.s_stop + 1.0)
    assert lane == p.junction_lanes[0] and pos == pytest.approx(1.0, abs=1e-6)
    lane, pos = p.lane_at(p.s_exit + 5.0)
    assert lane == "west_out_2" and pos == pytest.approx(5.0, abs=1e-6)
