"""step_relations: rows, leaders and lateral pairs of one step, and which pairs play."""

import dataclasses

import pytest

from intersection_cosim.control.game.relations import step_relations
from intersection_cosim.models.settings import ModelSettings
from tests.control.conftest import make_world

MODEL = ModelSettings()
LEFT = "west_inner_left_inner"  # eastbound, turning left to the north
STRAIGHT = "north_middle_straight_middle"  # southbound, straight on: the left turn crosses it
LANE = "south_middle_straight_middle"
RANGE = 30.0  # [m] lane_choice_range


def _crossing_world(paths, t, before_l=16.0, before_s=17.0):
    p, q = t.index[LEFT], t.index[STRAIGHT]
    return make_world(paths, 0.0, [("L", LEFT, t.s_a[p, q] - before_l, 8.0),
                                   ("S", STRAIGHT, t.s_a[q, p] - before_s, 8.0)])


def test_a_risky_crossing_plays_with_the_trigger_and_without_it(paths, movements, conflict_table):
    t = conflict_table
    world = _crossing_world(paths, t)
    rel = step_relations(world, {0, 1}, movements, t, MODEL, True, {}, RANGE)
    (lat,) = rel.lateral
    p, q = t.index[LEFT], t.index[STRAIGHT]
    assert lat.kind == "cross" and lat.live and lat.play
    assert (lat.s_i, lat.s_j) == pytest.approx((t.s_a[p, q], t.s_a[q, p]))
    assert lat.zone_i == pytest.approx((t.zone_in[p, q], t.zone_out[p, q]))
    assert rel.triggered_pairs() == {(0, 1)} and rel.leaders == {}
    calm = dataclasses.replace(MODEL, gamma_sf=1e12)  # the trigger never fires
    (lat,) = step_relations(world, {0, 1}, movements, t, calm, True, {}, RANGE).lateral
    assert lat.live and not lat.play
    (lat,) = step_relations(world, {0, 1}, movements, t, calm, False, {}, RANGE).lateral  # ETM off
    assert lat.play


def test_a_crossing_is_live_until_clearance_and_guarded_until_the_zone_is_left(paths, movements, conflict_table):
    t = conflict_table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    past = MODEL.conflict_clearance + 0.5  # [m] past the point: no game any more
    if t.zone_out[p, q] - t.s_a[p, q] > past:
        (lat,) = step_relations(_crossing_world(paths, t, -past), {0, 1}, movements, t, MODEL, True, {}, RANGE).lateral
        assert not lat.live and not lat.play
    gone = -(t.zone_out[p, q] - t.s_a[p, q]) - 0.1  # front past the zone: cleared
    assert step_relations(_crossing_world(paths, t, gone), {0, 1}, movements, t, MODEL, True, {}, RANGE).lateral == ()


def test_a_follower_on_the_same_lane_gets_its_nearest_leader(paths, movements, conflict_table):
    s_stop = paths[LANE].s_stop
    world = make_world(paths, 0.0, [("far", LANE, s_stop - 20.0, 8.0), ("near", LANE, s_stop - 45.0, 8.0),
                                    ("follow", LANE, s_stop - 60.0, 8.0)])
    rel = step_relations(world, {0, 1, 2}, movements, conflict_table, MODEL, True, {}, RANGE)
    lead = rel.leader_of(2, paths[LANE].exit_lane)
    assert lead.vehicle == 1 and lead.gap == pytest.approx(15.0) and lead.offset == pytest.approx(0.0)
    assert rel.leader_of(1, paths[LANE].exit_lane).vehicle == 0
    assert rel.leader_of(0, paths[LANE].exit_lane) is None and rel.lateral == ()


def test_a_vehicle_chooses_among_exit_lanes_only_near_its_stop_line(paths, movements, conflict_table):
    pid = "north_inner_left_inner"
    s_stop = paths[pid].s_stop
    for before, held, expected in ((RANGE - 1.0, {}, ("inner", "middle")), (RANGE + 1.0, {"V": "middle"}, ("middle",)),
                                   (RANGE + 1.0, {}, ("inner",))):
        world = make_world(paths, 0.0, [("V", pid, s_stop - before, 8.0)])
        world.exit_choices["V"] = ("inner", "middle")
        rel = step_relations(world, {0}, movements, conflict_table, MODEL, True, held, RANGE)
        assert rel.rows.option == expected
        assert rel.rows.path == tuple(movements.sibling(pid, o) for o in expected)
        assert [rel.row_of[(0, o)] for o in expected] == list(range(len(expected)))


def test_a_vehicle_alone_has_no_leader_and_no_pair_in_the_shape_the_pairs_of_two_have(paths, movements,
                                                                                     conflict_table):
    """One vehicle, its two exit-lane rows: no pair (the shortcut for a junction holding one
    vehicle), with the columns, dtypes and shapes of the pairs of two vehicles that cleared."""
    t = conflict_table
    alone = step_relations(make_world(paths, 0.0, [("L", LEFT, 20.0, 8.0)]), {0}, movements, t, MODEL, True, {},
                           RANGE)
    gone = -(t.zone_out[t.index[LEFT], t.index[STRAIGHT]] - t.s_a[t.index[LEFT], t.index[STRAIGHT]]) - 0.1
    cleared = step_relations(_crossing_world(paths, t, gone), {0, 1}, movements, t, MODEL, True, {}, RANGE).pairs
    assert alone.leaders == {} and len(alone.pairs) == 0 and alone.lateral == ()
    for name in ("ri", "rj", "cross", "s_i", "s_j", "live", "play", "zone_i", "zone_j", "human", "human_j"):
        mine, theirs = getattr(alone.pairs, name), getattr(cleared, name)
        assert (mine.dtype, mine.shape) == (theirs.dtype, theirs.shape), name


def test_two_guests_coming_to_the_junction_are_a_guarded_pair_that_never_plays(paths, movements, conflict_table):
    """Vehicles other junctions command (World.guest, role ready) over a crossing: the filter
    must keep them apart, so their pair is guarded (not played: neither is this junction's); a
    guest that has left (role outside) and one of the junction's own vehicles pairs as before."""
    import numpy as np

    t = conflict_table
    world = _crossing_world(paths, t)
    guests = dataclasses.replace(world, guest=np.array([True, True]))
    (lat,) = step_relations(guests, set(), movements, t, MODEL, True, {}, RANGE).lateral
    assert lat.kind == "cross" and not lat.live and not lat.play
    gone = dataclasses.replace(guests, role=["outside", "ready"])
    assert step_relations(gone, set(), movements, t, MODEL, True, {}, RANGE).lateral == ()
    assert step_relations(world, set(), movements, t, MODEL, True, {}, RANGE).lateral == ()  # no guest, nobody's


def test_two_guests_on_one_path_are_not_leader_and_follower(paths, movements, conflict_table):
    """Guests sit on the path at minus their distance along their own routes to its start, so two
    that come from different lanes of the junction before would be put one behind the other on a
    lane neither has reached (on ingolstadt21 a guest 1.5 m "behind" another, which stood at the
    other lane's stop line, was held for good by the Krauss cap, and held that one in turn). Two
    guests get no leader relation; a guest behind one of the junction's own vehicles, and two own
    vehicles, keep theirs."""
    import numpy as np

    t = conflict_table
    world = make_world(paths, 0.0, [("A", LANE, -12.5, 0.0), ("B", LANE, -14.0, 0.5)])
    own = step_relations(world, {0, 1}, movements, t, MODEL, True, {}, RANGE)
    assert [(world.ids[int(own.rows.vehicle[r])], world.ids[lead.vehicle]) for r, lead in own.leaders.items()] == [("B", "A")]
    guests = dataclasses.replace(world, guest=np.array([True, True]))
    assert step_relations(guests, set(), movements, t, MODEL, True, {}, RANGE).leaders == {}
    mixed = make_world(paths, 0.0, [("A", LANE, 5.0, 0.0), ("B", LANE, -10.0, 5.0)])
    mixed = dataclasses.replace(mixed, guest=np.array([False, True]))
    rel = step_relations(mixed, {0}, movements, t, MODEL, True, {}, RANGE)
    assert [(mixed.ids[int(rel.rows.vehicle[r])], mixed.ids[lead.vehicle]) for r, lead in rel.leaders.items()] == [("B", "A")]
