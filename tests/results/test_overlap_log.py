"""Our own collision check (results/overlaps.py): each overlap once, from its first check; bodies
on roads that meet at no junction (a bridge over a road) do not overlap."""

import math

import numpy as np

from intersection_cosim.results.overlaps import OverlapLog


def _check(log, time, lanes, junctions=None):
    """Two cars crossing at right angles, their bodies overlapping at the origin."""
    log.check(time, ["a", "b"], np.array([2.0, 0.0]), np.array([0.0, 2.0]), np.array([0.0, math.pi / 2]),
              np.array([4.5, 4.5]), np.array([1.8, 1.8]), lanes, np.array([True, False]), junctions)


def test_an_overlap_is_logged_once_from_its_first_check():
    log = OverlapLog()
    for t in (1.0, 1.1, 1.2):
        _check(log, t, ["e1_0", "e2_0"])
    assert log.rows == [(1.0, "a", "b", "e1_0", "e2_0", True, False)]


def test_bodies_on_roads_without_a_junction_in_common_do_not_overlap():
    """e1 (J1 -> J2) passes over e3 (J3 -> J4): no row; e2 (J2 -> J5) meets e1 at J2: a row."""
    junctions = {"e1_0": frozenset({"J1", "J2"}), "e3_0": frozenset({"J3", "J4"}), "e2_0": frozenset({"J2", "J5"})}
    bridge, meeting = OverlapLog(), OverlapLog()
    _check(bridge, 1.0, ["e1_0", "e3_0"], junctions)
    _check(meeting, 1.0, ["e1_0", "e2_0"], junctions)
    assert bridge.rows == [] and len(meeting.rows) == 1


def _truck_turning_north(log, cars):
    """A 16.25 m truck drives east along y = 0 to the origin, turns north and stops with its front
    at (0, 10); ``cars`` ((id, x, y, heading)) stand there at the last check only."""
    path = [(float(px), 0.0, 0.0) for px in range(-30, 1)] + [(0.0, float(py), math.pi / 2) for py in range(1, 11)]
    for k, (px, py, h) in enumerate(path):
        last = k == len(path) - 1
        extra = cars if last else []
        ids = ["truck", *[c[0] for c in extra]]
        log.check(0.1 * k, ids, np.array([px, *[c[1] for c in extra]]), np.array([py, *[c[2] for c in extra]]),
                  np.array([h, *[c[3] for c in extra]]), np.array([16.25] + [4.5] * len(extra)),
                  np.array([2.6] + [1.8] * len(extra)), ["e_0"] * len(ids), np.array([False] * len(ids)))


def test_a_long_body_bends_along_the_path_its_front_drove():
    """A rigid 16.25 m rectangle at the truck's heading would reach 6 m south of the corner; its
    trailer is in fact on the eastbound road behind the corner."""
    south = OverlapLog()  # a car 4 m south of the corner: in the rigid rectangle, clear of the truck
    _truck_turning_north(south, [("car", 0.5, -4.0, 0.0)])
    assert south.rows == []
    west = OverlapLog()  # a car across the eastbound road 3 m west of the corner: on the trailer
    _truck_turning_north(west, [("car", -3.0, 0.5, math.pi / 2)])
    assert [(r[1], r[2]) for r in west.rows] == [("car", "truck")]
