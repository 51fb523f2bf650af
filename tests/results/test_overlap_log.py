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
