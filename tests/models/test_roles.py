"""Vehicle roles (Section II): ready / passing / outside; host / leading / neighbour / irrelevant."""

from __future__ import annotations

import numpy as np
import pytest

from intersection_cosim.models.roles import (
    HOST,
    IRRELEVANT,
    LEADING,
    NEIGHBOUR_CONFLICT,
    OUTSIDE,
    PASSING,
    READY,
    conflict_type,
    conflict_types,
    relative_roles,
    role,
    role_codes,
    role_codes_from_arc_length,
    role_from_arc_length,
)
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.conflicts import KIND_CODE

S = ModelSettings()  # conflict zone |x|, |y| <= 12 m, clearance 4.5 m
CASE1 = ("south_inner_left_inner", "east_inner_left_inner", "west_inner_left_inner")


def test_role_from_position():
    # Case 1 and Case 2 start points are on incoming lanes
    for x, y in ((2, -25), (18, 2), (-30, -2), (-28, -6), (-6, 25), (-2, 16), (10, -50)):
        assert role(x, y, S) == "ready"
    # Case 2's V4 at (4, 2) is inside the conflict zone
    assert role(4, 2, S) == "passing"
    assert role(12.0, -12.0, S) == "passing"  # the boundary belongs to the zone
    # outgoing lanes: south arm x < 0, east arm y < 0, north arm x > 0, west arm y > 0
    for x, y in ((-2, -25), (30, -6), (10, 40), (-50, 2)):
        assert role(x, y, S) == "outside"


def test_role_codes_vectorised():
    x = np.array([2.0, 4.0, -2.0, 13.0, 13.0])
    y = np.array([-25.0, 2.0, -25.0, 0.5, -0.5])
    assert role_codes(x, y, S).tolist() == [READY, PASSING, OUTSIDE, READY, OUTSIDE]


def test_role_from_arc_length(paths):
    p = paths["south_inner_left_inner"]  # stop line at 138 m, exit lane from 160.72 m
    assert role_from_arc_length(125.0, p) == "ready"
    assert role_from_arc_length(p.s_stop, p) == "passing"
    assert role_from_arc_length(150.0, p) == "passing"
    assert role_from_arc_length(p.s_exit + 0.1, p) == "outside"
    codes = role_codes_from_arc_length(np.array([0.0, 140.0, 170.0]), p.s_stop, p.s_exit)
    assert codes.tolist() == [READY, PASSING, OUTSIDE]
    # agrees with the position-based form along the whole path, away from the zone's boundary
    for s in np.linspace(0.0, p.length, 301):
        x, y = p.point_at(s)
        if abs(abs(x) - 12.0) > 0.3 and abs(abs(y) - 12.0) > 0.3:
            assert role_from_arc_length(s, p) == role(x, y, S)


def test_conflict_types(conflict_table):
    idx = conflict_table.indices(CASE1)
    kinds = conflict_types(conflict_table, idx)
    cross = KIND_CODE["cross"]
    assert kinds.tolist() == [[0, cross, cross], [cross, 0, 0], [cross, 0, 0]]
    assert conflict_type(conflict_table, "south_inner_left_inner", "south_inner_left_inner") == "following"
    assert conflict_type(conflict_table, "south_inner_left_inner", "east_inner_straight_inner") == "confluence"
    assert conflict_type(conflict_table, "east_inner_left_inner", "west_inner_left_inner") is None


def test_relative_roles_case1(conflict_table):
    idx = conflict_table.indices(CASE1)
    roles = relative_roles(conflict_table, idx, np.array([125.0, 132.0, 120.0]), S)
    n, h, i = NEIGHBOUR_CONFLICT, HOST, IRRELEVANT
    assert roles.tolist() == [[h, n, n], [n, h, i], [n, i, h]]
    # V1 has passed the V1-V2 point (146.9 m on its path) by 5 m: no longer V2's neighbour,
    # still V3's (its point with V3 is at 151.8 m)
    roles = relative_roles(conflict_table, idx, np.array([151.9, 140.0, 130.0]), S)
    assert roles.tolist() == [[h, i, n], [i, h, i], [n, i, h]]


def test_relative_roles_following_and_outside(conflict_table):
    p = conflict_table.index["north_middle_straight_middle"]
    q = conflict_table.index["north_inner_left_inner"]
    r = conflict_table.index["north_inner_straight_inner"]
    idx = np.array([p, p, p, q, r])
    s = np.array([100.0, 120.0, 170.0, 130.0, 120.0])  # vehicle 2 is on the exit lane (OV)
    roles = relative_roles(conflict_table, idx, s, S)
    # on the middle lane: 1 leads 0, 2 leads 1 and 0 (same path); 2 is outside: all irrelevant
    assert roles[0].tolist()[:3] == [HOST, LEADING, LEADING]
    assert roles[1].tolist()[:3] == [IRRELEVANT, HOST, LEADING]
    assert roles[2].tolist() == [IRRELEVANT, IRRELEVANT, HOST, IRRELEVANT, IRRELEVANT]
    # inner lane: the left turner (130 m) leads the straight vehicle (120 m) on their shared stretch
    assert roles[4, 3] == LEADING and roles[3, 4] == IRRELEVANT
    # ... until it is more than the clearance past the end of that stretch
    end = conflict_table.s_a[q, r]
    roles = relative_roles(conflict_table, np.array([q, r]), np.array([end + 5.0, 120.0]), S)
    assert roles[1, 0] == IRRELEVANT
    roles = relative_roles(conflict_table, np.array([q, r]), np.array([end + 4.0, 120.0]), S)
    assert roles[1, 0] == LEADING


def test_relative_roles_confluence(conflict_table):
    a = conflict_table.index["south_outer_straight_outer"]
    b = conflict_table.index["east_outer_right_outer"]
    s_a, s_b = conflict_table.s_a[a, b], conflict_table.s_b[a, b]
    idx = np.array([a, b])
    # both before the merge: neighbours
    assert relative_roles(conflict_table, idx, np.array([s_a - 5.0, s_b - 2.0]), S)[0, 1] == NEIGHBOUR_CONFLICT
    # b has merged and is ahead: b leads a, a is irrelevant to b
    roles = relative_roles(conflict_table, idx, np.array([s_a - 5.0, s_b + 2.0]), S)
    assert roles[0, 1] == LEADING and roles[1, 0] == IRRELEVANT


@pytest.mark.parametrize("n", [1, 7])
def test_shapes(conflict_table, n):
    idx = np.arange(n) % len(conflict_table.ids)
    roles = relative_roles(conflict_table, idx, np.full(n, 100.0), S)
    assert roles.shape == (n, n) and np.all(np.diag(roles) == HOST)
