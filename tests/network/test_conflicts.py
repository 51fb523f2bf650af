"""Conflict points between movement paths (issue 3, item 3)."""

from __future__ import annotations

import numpy as np
import pytest

from intersection_cosim.network.conflicts import (
    KIND_CODE,
    ConflictTable,
    conflict_point,
    conflict_points,
    load_conflicts,
)

W = 1.8  # [m] vehicle width: centre lines closer than this touch

# Hand count over the 28 paths (7 per arm: left->inner, left->middle, straight on each of the three
# lanes, right->outer, right->middle), i.e. C(28, 2) = 378 unordered pairs of distinct paths:
#
# * Same arm (4 x C(7, 2) = 84 pairs). Paths sharing an approach lane are FOLLOWING: the inner lane
#   has 3 paths (2 lefts + straight) -> 3 pairs, the outer lane 3 (2 rights + straight) -> 3, the
#   middle lane 1 -> 0; 6 per arm, 24 in all. The other 15 per arm (60) run on lanes 4 m apart and
#   turn away from each other: none.
# * Same exit lane from different approaches -> CONFLUENCE, counted per exit road (e.g. west_out):
#   inner lane <- {south left->inner, east straight inner} 1 pair; middle lane <- {south
#   left->middle, east straight middle, north right->middle} 3 pairs; outer lane <- {north
#   right->outer, east straight outer} 1 pair. 5 per exit road, 20 in all: 16 between adjacent
#   arms (4 per arm pair) and 4 between opposite arms (2 per pair: left->middle with the opposite
#   right->middle).
# * Opposite arms (2 pairs of arms x 49), e.g. south/north: each of the 2 south lefts crosses all
#   3 north straights (it sweeps from x = 2 to x = -12 inside the junction) and vice versa: 12
#   CROSS. Opposite lefts pass each other about 4 m apart (paper Case 1: three left turners, "two
#   cross conflicts"): none. Rights stay in their corner: none. 2 confluences, so 35 none.
# * Adjacent arms (4 pairs of arms x 49), e.g. south (northbound) / east (westbound):
#   south lefts x east lefts 4; south left->middle x east straight inner 1 (south left->inner
#   merges with it instead, and stays 4 m from east straight middle); each of the 3 south
#   straights x the 2 east lefts and the 3 east straights 5 each = 15; south straight outer x east
#   right->middle 1 (the right turn sweeps x = 12 -> 6 across x = 10). 21 CROSS. South rights
#   stay in the south-east corner and east rights in the north-east corner away from everything
#   else: none. 4 confluences (south left->inner / east straight inner, south left->middle / east
#   straight middle, south straight outer / east right->outer, south straight middle / east
#   right->middle), so 24 none.
#
# Totals: following 24, confluence 16 + 4 = 20, cross 4 x 21 + 2 x 12 = 108,
# none 60 + 2 x 35 + 4 x 24 = 226; 24 + 20 + 108 + 226 = 378.
HAND_COUNTS = {"none": 226, "following": 24, "cross": 108, "confluence": 20}


@pytest.fixture(scope="module")
def conflicts(net_file):
    return load_conflicts(net_file)


def test_counts_of_each_kind_match_the_hand_count(conflict_table):
    assert conflict_table.counts() == HAND_COUNTS


def test_dict_has_both_orientations_and_self_pairs(conflicts, paths):
    distinct = {frozenset(k) for k in conflicts if k[0] != k[1]}
    assert len(distinct) == 24 + 20 + 108
    for (a, b), cp in conflicts.items():
        assert (cp.path_a, cp.path_b) == (a, b)
        back = conflicts[(b, a)]
        assert (back.kind, back.s_a, back.s_b, back.x, back.y) == (cp.kind, cp.s_b, cp.s_a, cp.x, cp.y)
    for pid, p in paths.items():
        cp = conflicts[(pid, pid)]
        assert cp.kind == "following" and cp.s_a == cp.s_b == pytest.approx(p.length)


def test_adjacent_left_turns_cross(conflicts, paths):
    # Case 1: V1 (south, left) and V2 (east, left).
    cp = conflicts[("south_inner_left_inner", "east_inner_left_inner")]
    assert cp.kind == "cross"
    assert (cp.x, cp.y) == pytest.approx((0.0, -3.43), abs=0.02)
    a, b = paths[cp.path_a], paths[cp.path_b]
    assert a.s_stop < cp.s_a < a.s_exit and b.s_stop < cp.s_b < b.s_exit
    assert cp.s_a == pytest.approx(146.91, abs=0.02) and cp.s_b == pytest.approx(151.81, abs=0.02)
    # by the 90 degree symmetry of the net, V1/V3 meet at the mirror point
    cp13 = conflicts[("south_inner_left_inner", "west_inner_left_inner")]
    assert cp13.kind == "cross" and (cp13.s_a, cp13.s_b) == pytest.approx((cp.s_b, cp.s_a), abs=0.02)
    for ea in ("inner", "middle"):
        for eb in ("inner", "middle"):
            assert conflicts[(f"south_inner_left_{ea}", f"east_inner_left_{eb}")].kind == "cross"


def test_opposite_left_turns_do_not_meet(conflicts, paths):
    # Right-hand traffic: opposing left turners pass in front of each other, about 4 m apart
    # (paper Case 1: V2 east-left and V3 west-left have no conflict).
    for ea in ("inner", "middle"):
        for eb in ("inner", "middle"):
            a, b = f"south_inner_left_{ea}", f"north_inner_left_{eb}"
            assert (a, b) not in conflicts
            pa, pb = paths[a], paths[b]
            ma = (pa.s >= pa.s_stop) & (pa.s <= pa.s_exit)
            mb = (pb.s >= pb.s_stop) & (pb.s <= pb.s_exit)
            gap = np.linalg.norm(pa.xy[ma][:, None] - pb.xy[mb][None], axis=2).min()
            assert 3.5 < gap < 4.5


def test_left_turn_crosses_the_opposing_straights(conflicts, paths):
    for lane in ("inner", "middle", "outer"):
        cp = conflicts[("south_inner_left_inner", f"north_{lane}_straight_{lane}")]
        assert cp.kind == "cross"
        # the crossing lies on both centre lines
        x = {"inner": -2.0, "middle": -6.0, "outer": -10.0}[lane]
        assert cp.x == pytest.approx(x, abs=0.01)
        assert paths[cp.path_a].point_at(cp.s_a) == pytest.approx([cp.x, cp.y], abs=0.02)
        assert paths[cp.path_b].point_at(cp.s_b) == pytest.approx([cp.x, cp.y], abs=0.02)


def test_every_cross_point_is_on_both_centre_lines(conflicts, paths):
    for (a, b), cp in conflicts.items():
        if cp.kind != "cross":
            continue
        pa, pb = paths[a].point_at(cp.s_a), paths[b].point_at(cp.s_b)
        assert np.linalg.norm(pa - pb) < 0.05  # all crossings on this net are real crossings
        assert paths[a].s_stop - 0.5 < cp.s_a < paths[a].s_exit + 0.5


def test_straight_and_right_turn_onto_the_same_lane_merge(conflicts, paths):
    # south straight outer (x = 10) and east right -> outer both end on north_out_0.
    cp = conflicts[("south_outer_straight_outer", "east_outer_right_outer")]
    assert cp.kind == "confluence"
    a, b = paths[cp.path_a], paths[cp.path_b]
    assert a.lanes[-1] == b.lanes[-1] == "north_out_0"
    # the merge point is inside the junction and no later than the exit lane on either path
    assert a.s_stop < cp.s_a <= a.s_exit and b.s_stop <= cp.s_b <= b.s_exit
    # rule: the first point at which the other centre line is closer than a vehicle width
    for path, s, other in ((a, cp.s_a, b), (b, cp.s_b, a)):
        near = np.linalg.norm(other.xy - path.point_at(s), axis=1).min()
        before = np.linalg.norm(other.xy - path.point_at(s - 0.5), axis=1).min()
        assert near == pytest.approx(W, abs=0.05) and before > W
    cp2 = conflicts[("south_middle_straight_middle", "east_outer_right_middle")]
    assert cp2.kind == "confluence"


def test_left_turn_merging_with_a_straight(conflicts, paths):
    cp = conflicts[("south_inner_left_inner", "east_inner_straight_inner")]
    assert cp.kind == "confluence"
    a, b = paths[cp.path_a], paths[cp.path_b]
    # the left turner closes in on the straight lane from the side: within a vehicle width a few
    # metres before the exit
    assert a.s_exit - 10.0 < cp.s_a < a.s_exit and b.s_exit - 10.0 < cp.s_b < b.s_exit
    assert np.linalg.norm(a.point_at(cp.s_a) - b.point_at(cp.s_b)) < 2.5


def test_same_lane_same_movement_is_following(conflicts, paths):
    cp = conflicts[("west_inner_left_inner", "west_inner_left_inner")]
    assert cp.kind == "following" and cp.s_a == pytest.approx(paths["west_inner_left_inner"].length)


def test_shared_stretch_ends_where_the_paths_are_a_vehicle_width_apart(conflicts, paths):
    cp = conflicts[("south_inner_left_inner", "south_inner_straight_inner")]
    assert cp.kind == "following" and cp.s_a == cp.s_b
    a, b = paths[cp.path_a], paths[cp.path_b]
    assert a.s_stop < cp.s_a < a.s_exit  # they part inside the junction
    assert np.linalg.norm(a.point_at(cp.s_a) - b.point_at(cp.s_a)) >= W
    assert np.linalg.norm(a.point_at(cp.s_a - 0.25) - b.point_at(cp.s_a - 0.25)) < W
    assert conflicts[("north_outer_right_outer", "north_outer_straight_outer")].kind == "following"


def test_right_turns_into_different_roads_do_not_conflict(conflicts):
    assert ("south_outer_right_outer", "east_outer_right_outer") not in conflicts
    assert ("south_outer_right_middle", "north_outer_right_middle") not in conflicts
    assert ("west_outer_right_outer", "north_outer_right_middle") not in conflicts


def test_table_matches_dict(conflicts, paths):
    table = ConflictTable.build(paths, conflicts)
    for (a, b), cp in conflicts.items():
        p, q = table.index[a], table.index[b]
        assert table.kind[p, q] == KIND_CODE[cp.kind]
        assert (table.s_a[p, q], table.s_b[p, q], table.x[p, q]) == (cp.s_a, cp.s_b, cp.x)
    assert np.array_equal(table.kind, table.kind.T)
    both = table.kind > 0
    assert np.array_equal(table.s_b[both], table.s_a.T[both])
    assert np.all(np.isnan(table.s_a[~both]))


def test_load_conflicts_is_cached(net_file):
    assert load_conflicts(net_file) is load_conflicts(str(net_file))


def test_wider_vehicles_make_more_conflicts(paths):
    # opposite left turns pass about 4 m apart: a 5 m "width" turns them into a (closest-approach)
    # cross conflict, away from the junction edge
    a, b = paths["south_inner_left_inner"], paths["north_inner_left_inner"]
    assert conflict_point(a, b, 1.8) is None
    cp = conflict_point(a, b, 5.0)
    assert cp is not None and cp.kind == "cross"
    assert np.hypot(cp.x, cp.y) < 1.0
    small = {k: v for k, v in paths.items() if k.startswith("south_inner")}
    assert set(conflict_points(small)) == {(x, y) for x in small for y in small}


def _bodies(path, s_front):
    """trajectories.csv-like rows (x, y, heading) for fronts ``s_front`` on ``path``, headed as
    SUMO heads a vehicle: from its rear point on the centre line 4.5 m back to its front."""
    import pandas as pd

    s = np.asarray(s_front, float)
    xy = path.point_at(s)
    d = xy - path.point_at(s - 4.5)
    return pd.DataFrame({"x": xy[:, 0], "y": xy[:, 1], "heading": np.arctan2(d[:, 1], d[:, 0])})


@pytest.mark.parametrize("a, b", [
    ("west_inner_left_inner", "north_middle_straight_middle"),  # oblique: a left turn across a straight
    ("south_inner_straight_inner", "east_middle_straight_middle"),  # perpendicular straights
    ("north_inner_left_middle", "east_inner_left_inner"),  # two left turns
])
def test_cross_zone_is_where_the_bodies_can_overlap(conflict_table, paths, a, b):
    """Checked against the separating-axis body test of results.metrics (an independent method):
    a body on ``a`` just outside [zone_in, zone_out] overlaps no body anywhere on ``b``; one
    inside the zone overlaps some body on ``b``."""
    import pandas as pd

    from intersection_cosim.results.metrics import body_overlaps

    t = conflict_table
    p, q = t.index[a], t.index[b]
    z_in, z_out = t.zone_in[p, q], t.zone_out[p, q]
    assert z_in < t.s_a[p, q] < z_out
    pb, pa = paths[b], paths[a]
    b_rows = _bodies(pb, np.arange(pb.s_stop - 2.0, pb.s_exit + 6.0, 0.1))

    def overlaps(s_front):
        rows = pd.concat([_bodies(pa, [s_front]), b_rows], ignore_index=True)
        rows["vehicle"] = ["A"] + [f"B{i}" for i in range(len(b_rows))]
        rows["time"] = 0.0
        return any("A" in (u, v) for _, u, v in body_overlaps(rows, 4.5, 1.8))

    assert not overlaps(z_in - 0.5) and not overlaps(z_out + 0.5)
    assert overlaps(0.5 * (z_in + z_out))


def test_oblique_crossings_take_longer_to_clear_than_a_point_and_a_length(conflict_table):
    # The controller once dropped a crossing pair 4.5 m past the point; a left turn's body still
    # covers the other's lane there (a collision at 1800 veh/h). The zones say how far it really is.
    cross = conflict_table.kind == KIND_CODE["cross"]
    past = (conflict_table.zone_out - conflict_table.s_a)[cross]
    assert past.min() > 4.0 and past.max() > 4.5 + 2.0
