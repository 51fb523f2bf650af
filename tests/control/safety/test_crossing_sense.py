"""The crossing sense's geometry and timing (control/safety/crossing_sense.py), without SUMO (sumolib reads one shipped net)."""

import math
from pathlib import Path

import pytest
import sumolib

from intersection_cosim.control.safety.crossing_sense import (Occupation, clearance, crossing, ego_occupation,
                                                              foe_occupation, overlaps, time_to_cover)

GRID = Path(__file__).resolve().parents[3] / "sumo_networks" / "grid3x3" / "grid3x3.net.xml"


def test_crossing_is_found_at_its_arc_lengths_along_both_polylines():
    ego = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)]  # 10 m east, then north
    foe = [(5.0, 5.0), (15.0, 5.0)]  # crosses the northbound leg at (10, 5)
    cr = crossing(ego, foe)
    assert (cr.s_ego, cr.s_foe) == pytest.approx((15.0, 5.0))
    assert cr.angle == pytest.approx(math.pi / 2)
    assert crossing(ego, [(0.0, 3.0), (9.0, 3.0)]) is None  # short of the northbound leg
    oblique = crossing([(0.0, 0.0), (10.0, 0.0)], [(0.0, -5.0), (10.0, 5.0)])
    assert oblique.angle == pytest.approx(math.pi / 4) and oblique.s_ego == pytest.approx(5.0)


def test_two_lanes_meeting_at_their_end_points_cross_there():
    """A merge: both centre lines end at one point (sumolib gives no direction at a polyline's
    end; the crossing takes its last segment's)."""
    c = crossing([(0.0, 0.0), (10.0, 0.0)], [(10.0, -10.0), (10.0, 0.0)])
    assert c.s_ego == pytest.approx(10.0) and c.s_foe == pytest.approx(10.0)
    assert c.angle == pytest.approx(math.pi / 2)
    slanted = crossing([(0.0, 0.0), (10.0, 0.0)], [(0.0, -10.0), (5.0, -5.0), (10.0, 0.0)])
    assert slanted.angle == pytest.approx(math.pi / 4)


def test_two_internal_lanes_of_the_shipped_grid_merging_at_their_end_cross_there():
    """grid_high's junction C2: a left turn and a right turn end at one point of their exit lane
    (the step crashed on this pair at 20 s of grid_high)."""
    net = sumolib.net.readNet(str(GRID), withInternal=True)
    left, right = net.getLane(":C2_1_1").getShape(), net.getLane(":C2_17_0").getShape()
    assert left[-1] == right[-1]
    c = crossing(left, right)
    assert c.s_ego == pytest.approx(net.getLane(":C2_1_1").getLength(), abs=0.5)
    assert 0.0 < c.angle < math.pi / 4


def test_clearance_grows_as_the_paths_turn_parallel_and_is_bounded():
    square = clearance(1.8, 0.65, math.pi / 2)
    assert square == pytest.approx((1.8 + 0.65) / 2)
    assert clearance(1.8, 0.65, math.pi / 6) == pytest.approx(2 * square)
    assert clearance(1.8, 0.65, 1e-6) == 6.0


def test_time_to_cover_accelerates_then_cruises():
    assert time_to_cover(0.0, 5.0, 2.0, 10.0) == 0.0
    assert time_to_cover(4.0, 0.0, 2.0, 10.0) == pytest.approx(2.0)  # 4 = 2 t^2 / 2
    assert time_to_cover(45.0, 0.0, 2.0, 10.0) == pytest.approx(5.0 + 20.0 / 10.0)  # 25 m to 10 m/s, then cruise
    assert time_to_cover(10.0, 5.0, 0.0, 5.0) == pytest.approx(2.0)
    assert time_to_cover(10.0, 0.0, 0.0, 5.0) == math.inf  # standing, not accelerating: never


def test_a_foe_is_taken_at_its_most_dangerous():
    moving = foe_occupation(10.0, 15.0, 5.0, 1.0, 5.0)  # at its top speed: enters in 2 s, leaves in 3 s
    assert (moving.enter, moving.leave) == pytest.approx((2.0, 3.0))
    standing = foe_occupation(6.0, 10.0, 0.0, 1.2, 5.5)  # waiting before the crossing: may start now
    assert standing.enter == pytest.approx(math.sqrt(2 * 6.0 / 1.2)) and standing.leave == math.inf
    assert foe_occupation(6.0, 10.0, 0.0, 0.0, 5.5).enter == math.inf  # one that waits for us stays
    assert foe_occupation(-20.0, -1.0, 5.0, 1.0, 5.0).enter == math.inf  # its rear is past the crossing


def test_occupations_overlap_within_the_buffer_only():
    mine = ego_occupation(20.0, 8.0, 10.0, 2.0, 10.0)
    assert (mine.enter, mine.leave) == pytest.approx((2.0, 2.8))
    assert overlaps(mine, Occupation(3.5, 4.0), 1.0)
    assert not overlaps(mine, Occupation(3.9, 4.5), 1.0)
    assert not overlaps(mine, Occupation(0.0, 0.9), 1.0) and overlaps(mine, Occupation(0.0, 1.1), 1.0)
