"""Movements of the junctions of real SUMO nets (the nets that ship with the eclipse-sumo package)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sumo
import sumolib

from intersection_cosim.errors import InputError
from intersection_cosim.network.conflicts import KIND_CODE, conflict_points, movement_conflict_table, movement_conflicts
from intersection_cosim.network.junction_net import junction_table, load_movements
from intersection_cosim.network.movements import OUTSIDE, PASSING, READY

SUMO_HOME = Path(sumo.SUMO_HOME)
GAME = SUMO_HOME / "tools" / "game"
REAL = SUMO_HOME / "tools" / "sumolib" / "scenario" / "scenarios" / "RealWorld"
CROSS = GAME / "cross" / "cross.net.xml"
RILSA1 = REAL / "RiLSA_example1" / "net.net.xml"
RILSA2 = REAL / "RiLSA_example2" / "net.net.xml"
CORRIDOR = GAME / "corridor" / "corridor.net.xml"

# cross.net.xml, junction "0": arms 1 (west, eastbound in 1si), 2 (east), 3 (south), 4 (north);
# each approach's connections as SUMO lists them: (from lane, to lane, direction).
CROSS_CONNECTIONS = {
    ("1si_0", "3o_0", "right"), ("1si_1", "2o_0", "straight"), ("1si_2", "4o_0", "left"),
    ("2si_0", "4o_0", "right"), ("2si_1", "1o_0", "straight"), ("2si_2", "3o_0", "left"),
    ("3si_0", "2o_0", "right"), ("3si_0", "4o_0", "straight"), ("3si_1", "1o_0", "left"),
    ("4si_0", "1o_0", "right"), ("4si_0", "3o_0", "straight"), ("4si_1", "2o_0", "left"),
}
LEFT_VS_OPPOSITE_STRAIGHT = (("1si_2>4o_0", "2si_1>1o_0"), ("2si_2>3o_0", "1si_1>2o_0"),
                             ("3si_1>1o_0", "4si_0>3o_0"), ("4si_1>2o_0", "3si_0>4o_0"))


@pytest.fixture(scope="module")
def cross():
    return load_movements(CROSS, ("0",))


def test_cross_has_one_path_per_connection_with_its_direction(cross):
    got = {(p.lane, p.lanes[-1], p.movement) for p in cross.paths.values()}
    assert got == CROSS_CONNECTIONS
    p = cross.paths["1si_2>4o_0"]
    assert (p.id, p.approach, p.lane, p.exit_arm, p.exit_lane, p.junction) == ("1si_2>4o_0", "1si", "1si_2", "4o", "0", "0")


def test_left_turns_run_through_both_internal_lanes(cross):
    net = sumolib.net.readNet(str(CROSS), withInternal=True)
    # SUMO splits each left turn at an internal junction (where it waits for the opposing traffic).
    assert cross.paths["1si_2>4o_0"].junction_lanes == (":0_8_0", ":0_14_0")
    assert cross.paths["3si_1>1o_0"].junction_lanes == (":0_5_0", ":0_13_0")
    assert cross.paths["1si_1>2o_0"].junction_lanes == (":0_7_0",)
    for p in cross.paths.values():
        assert p.approach_lane == p.lane and p.lanes[-1].startswith(p.exit_arm + "_")
        assert 0 < p.s_stop < p.s_exit < p.length
        assert p.s_exit - p.s_stop == pytest.approx(sum(
            sumolib.geomhelper.polyLength([q[:2] for q in net.getLane(ln).getShape()]) for ln in p.junction_lanes),
            rel=1e-3)


def test_single_lane_exits_have_one_option_each(cross):
    for pid, path in cross.paths.items():
        assert cross.options(pid) == ("0",) and cross.sibling(pid, "0") == pid


def test_roles_cover_the_approach_and_every_internal_lane(cross):
    ready = {ln for ln, role in cross.roles.items() if role == READY}
    passing = {ln for ln, role in cross.roles.items() if role == PASSING}
    assert ready == {"1si_0", "1si_1", "1si_2", "2si_0", "2si_1", "2si_2", "3si_0", "3si_1", "4si_0", "4si_1"}
    assert passing == {f":0_{k}_0" for k in range(16)}  # 12 links, 4 of them (the lefts) in two parts
    assert cross.role("4o_0") == OUTSIDE and cross.role("1fi_0") == OUTSIDE


def test_approach_extends_upstream_through_a_lane_split():
    # 1si (137 m) is fed only by m1's internal lanes :m1_1_k, which 1fi_0 feeds all three: a lane
    # split (one lane widening into 1si's three). A 200 m control range takes the internal lane and
    # 1fi_0 before it, so a vehicle bound for junction 0 is seen before the split, not after it.
    short, far = load_movements(CROSS, ("0",), 100.0), load_movements(CROSS, ("0",), 200.0)
    for k in range(3):
        pid = next(p for p in far.paths if p.startswith(f"1si_{k}>"))
        assert short.paths[pid].lanes[0] == f"1si_{k}" and short.paths[pid].stop_index == 1
        assert far.paths[pid].lanes[:3] == ("1fi_0", f":m1_1_{k}", f"1si_{k}") and far.paths[pid].stop_index == 3
        assert far.roles[f":m1_1_{k}"] == READY and far.roles["1fi_0"] == READY
        assert far.paths[pid].s_stop - short.paths[pid].s_stop == pytest.approx(far.paths[pid].lane_starts[2], abs=0.01)
        assert 150.0 < far.paths[pid].s_stop < 200.0
    a, b = far.paths["3si_0>2o_0"], far.paths["3si_0>4o_0"]  # one approach lane, one arc-length origin
    assert a.lanes[:a.stop_index] == b.lanes[:b.stop_index] and a.s_stop == b.s_stop


def test_an_approach_takes_a_lane_split_but_stops_where_the_road_branches():
    from intersection_cosim.network.junction_net import _LaneGraph, _leads_only_to

    def graph(succ: dict[str, set[str]]) -> _LaneGraph:
        pred: dict[str, set[str]] = {}
        for lane, nxt in succ.items():
            for n in nxt:
                pred.setdefault(n, set()).add(lane)
        return _LaneGraph({k: frozenset(v) for k, v in succ.items()}, {k: frozenset(v) for k, v in pred.items()})

    split = graph({"a_0": {":n_0_0", ":n_0_1"}, ":n_0_0": {"b_0"}, ":n_0_1": {"b_1"}})
    fork = graph({"a_0": {":n_0_0", ":n_1_0"}, ":n_0_0": {"b_0"}, ":n_1_0": {"c_0"}})
    assert _leads_only_to(split, "a_0", ":n_0_1") and _leads_only_to(split, ":n_0_1", "b_1")
    assert not _leads_only_to(fork, "a_0", ":n_0_0")  # some of a_0's vehicles turn off onto c


def test_approach_extends_until_the_control_range():
    # grid6: bottom0to0/0 is fed through a chain of unique predecessors longer than 100 m.
    m = load_movements(GAME / "grid6" / "grid6.net.xml", ("0/0",), 100.0)
    extended = [p for p in m.paths.values() if p.stop_index > 1]
    assert extended
    for p in extended:
        assert p.s_stop >= 100.0 - 0.5  # [m] lane starts are rescaled onto the resampled line
        assert p.s_stop - p.lane_starts[1] < 100.0  # one lane less would fall short: no lane too many
    assert any(p.stop_index > 2 for p in extended)


def test_managed_neighbours_are_not_part_of_an_approach():
    m = load_movements(CROSS, ("0", "m1"), 200.0)
    assert m.paths["1si_1>2o_0"].stop_index == 1  # m1's internal lanes pass through a managed junction
    assert m.paths["1si_1>2o_0"].junction == "0" and m.paths["1fi_0>1si_1"].junction == "m1"
    for p in m.paths.values():
        assert all(m.role(ln) == READY for ln in p.lanes[:p.stop_index])
        assert all(m.role(ln) == PASSING for ln in p.junction_lanes)


def test_straight_onto_three_lanes_prefers_the_nearest():
    m = load_movements(CROSS, ("m1",))
    assert m.options("1fi_0>1si_2") == ("0", "1", "2")  # from lane index 0
    assert [m.sibling("1fi_0>1si_0", e) for e in ("0", "1", "2")] == ["1fi_0>1si_0", "1fi_0>1si_1", "1fi_0>1si_2"]


def test_left_turn_onto_two_lanes_prefers_the_leftmost():
    m = load_movements(RILSA2, ("0n",))
    assert m.options("isn_0>mw_0") == ("1", "0") == m.options("isn_0>mw_1")
    assert m.sibling("isn_0>mw_0", "1") == "isn_0>mw_1"
    assert m.paths["isn_0>mw_0"].junction_lanes == (":0n_3_0", ":0n_5_0")


def test_rilsa_siblings_match_the_connections_of_each_lane():
    m = load_movements(RILSA1, ("0",))
    net = sumolib.net.readNet(str(RILSA1))
    assert len(m.paths) == 12 and {p.approach for p in m.paths.values()} == {"em", "nm", "sm", "wm"}
    assert {len(net.getEdge(a).getLanes()) for a in ("em", "nm", "sm", "wm")} == {2}
    for pid, p in m.paths.items():
        lane = net.getLane(p.lane)
        to_lanes = {str(c.getToLane().getIndex()) for c in lane.getOutgoing() if c.getTo().getID() == p.exit_arm}
        assert set(m.options(pid)) == to_lanes
        assert {m.sibling(pid, e) for e in to_lanes} == {f"{p.lane}>{p.exit_arm}_{e}" for e in to_lanes}


def test_left_turns_cross_the_opposite_straights(cross):
    table = movement_conflict_table(cross)
    for left, straight in LEFT_VS_OPPOSITE_STRAIGHT:
        p, q = table.index[left], table.index[straight]
        assert table.kind[p, q] == KIND_CODE["cross"] == table.kind[q, p]
        assert cross.paths[left].s_stop < table.s_a[p, q] < cross.paths[left].s_exit
        assert table.zone_in[p, q] < table.s_a[p, q] < table.zone_out[p, q]
    assert table.counts() == {"none": 36, "following": 2, "cross": 16, "confluence": 12}


def test_every_sumo_foe_pair_is_guarded(cross):
    table = movement_conflict_table(cross)
    assert len(cross.foes) == 2 * 28
    assert all((b, a) in cross.foes for a, b in cross.foes)
    for a, b in cross.foes:
        assert table.kind[table.index[a], table.index[b]] != KIND_CODE["none"], (a, b)


def test_a_foe_pair_without_geometric_conflict_becomes_a_cross_at_the_closest_approach(cross):
    a, b = "1si_0>3o_0", "2si_0>4o_0"  # opposite right turns, far apart: no conflict by geometry
    paths = dict(cross.paths)
    assert (a, b) not in conflict_points(paths)
    guarded = conflict_points(paths, foes=frozenset({(a, b), (b, a)}))[(a, b)]
    pa, pb = paths[a], paths[b]
    assert guarded.kind == "cross" and guarded == conflict_points(paths, foes=frozenset({(a, b)}))[(a, b)]
    assert pa.s_stop - 0.25 <= guarded.s_a <= pa.s_exit + 0.25 and pb.s_stop - 0.25 <= guarded.s_b <= pb.s_exit + 0.25
    gap = np.linalg.norm(pa.point_at(guarded.s_a) - pb.point_at(guarded.s_b))
    sa = pa.s[(pa.s >= pa.s_stop) & (pa.s <= pa.s_exit)]
    sb = pb.s[(pb.s >= pb.s_stop) & (pb.s <= pb.s_exit)]
    closest = np.linalg.norm(pa.point_at(sa)[:, None] - pb.point_at(sb)[None], axis=2).min()
    assert gap == pytest.approx(closest, abs=0.3) and gap > 1.8


def test_rilsa2_foes_the_geometry_misses_are_guarded():
    m = load_movements(RILSA2, ("0n", "0s"))
    plain = conflict_points(dict(m.paths))
    missed = {(a, b) for a, b in m.foes if (a, b) not in plain}
    assert ("em_0>mw_0", "isn_0>mw_1") in missed  # side by side onto mw: SUMO's foes, 3 m apart
    guarded = movement_conflicts(m)
    assert all(guarded[pair].kind == "cross" for pair in missed)


def test_corridor_junctions_are_managed_together():
    table = junction_table(CORRIDOR)
    ids = tuple(table.id)
    assert len(ids) == 3 and table.manageable.all()
    m = load_movements(CORRIDOR, ids)
    assert {p.junction for p in m.paths.values()} == set(ids)
    per = {j: sum(p.junction == j for p in m.paths.values()) for j in ids}
    assert per == {j: int(table.connections[table.id == j].iloc[0]) for j in ids}
    conflicts = movement_conflicts(m)
    assert all(m.paths[a].junction == m.paths[b].junction for a, b in conflicts)
    assert movement_conflict_table(m).counts()["cross"] > 0


OTHER_NETS = (GAME / "grid6" / "grid6.net.xml", GAME / "square" / "square.net.xml",
              REAL / "RiLSA_example2" / "net.net.xml", REAL / "RiLSA_example3" / "net.net.xml",
              REAL / "RiLSA_example4" / "net.net.xml", GAME / "A10KW" / "osm.net.xml", GAME / "bs3d" / "bs.net.xml")


@pytest.mark.parametrize("net_file", OTHER_NETS, ids=lambda p: p.parent.name)
def test_every_manageable_intersection_loads(net_file):
    table = junction_table(net_file)
    ids = tuple(table.id[table.manageable])
    assert ids
    m = load_movements(net_file, ids)
    assert len(m.paths) == int(table.connections[table.manageable].sum())
    for p in m.paths.values():
        assert p.length > p.s_exit >= p.s_stop > 0, p.id
        assert p.lanes[p.stop_index - 1] == p.lane and p.junction in ids
    conflicts = movement_conflict_table(m)
    assert conflicts.ids == tuple(m.paths)
    assert (np.diag(conflicts.kind) == KIND_CODE["following"]).all()
    for a, b in m.foes:
        assert conflicts.kind[conflicts.index[a], conflicts.index[b]] != KIND_CODE["none"]


def test_osm_clusters_are_ordinary_junctions():
    net_file = GAME / "A10KW" / "osm.net.xml"
    table = junction_table(net_file, all_junctions=True)
    clusters = table[table.id.str.startswith("cluster_") & table.manageable]
    assert len(clusters) > 0
    m = load_movements(net_file, tuple(clusters.id))
    assert {p.junction for p in m.paths.values()} == set(clusters.id)


def test_junction_table_lists_intersections_and_why_others_are_not():
    table = junction_table(CROSS)
    assert list(table.columns) == ["id", "type", "arms", "in", "out", "lanes_in", "lanes_out", "connections",
                                   "manageable", "reason"]
    assert table.to_dict("records") == [{"id": "0", "type": "traffic_light", "arms": 4, "in": 4, "out": 4,
                                         "lanes_in": 10, "lanes_out": 4, "connections": 12,
                                         "manageable": True, "reason": ""}]
    every = junction_table(CROSS, all_junctions=True).set_index("id")
    assert len(every) == 9 and not every.loc["1", "manageable"] and "dead end" in every.loc["1", "reason"]
    assert every.loc["m1", "arms"] == 2 and every.loc["m1", "connections"] == 4


def test_drt_rail_junctions_are_refused():
    net_file = GAME / "DRT" / "osm.net.xml"
    every = junction_table(net_file, all_junctions=True)
    rail = every[every.type.isin(["rail_crossing", "rail_signal"])]
    assert len(rail) > 0 and not rail.manageable.any()
    with pytest.raises(InputError, match="rail"):
        load_movements(net_file, (rail.id.iloc[0],))


def test_unknown_junction_names_the_nearest_ids():
    with pytest.raises(InputError) as exc:
        load_movements(CROSS, ("m5",))
    assert exc.value.field == "network.junctions" and exc.value.value == "m5"
    named = exc.value.problem.split("nearest ids: ")[1].split(", ")
    assert len(named) == 3 and set(named) <= {"m1", "m2", "m3", "m4"}  # difflib's three closest, not "0" or "1"
    assert "\n" not in exc.value.one_line()


@pytest.mark.parametrize("jid, words", [("1", "dead end"), (":0_12_0", "junction-internal")])
def test_junctions_that_cannot_be_managed_are_refused(jid, words):
    with pytest.raises(InputError, match=words) as exc:
        load_movements(CROSS, ("0", jid))
    assert exc.value.field == "network.junctions" and exc.value.value == jid


def test_a_junction_without_drivable_connections_is_refused():
    every = junction_table(RILSA2, all_junctions=True)
    walk_only = every[every.reason.str.contains("no connection drivable")]
    assert len(walk_only) > 0
    with pytest.raises(InputError, match="no connection drivable by passenger"):
        load_movements(RILSA2, (walk_only.id.iloc[0],))


def test_missing_net_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        load_movements(tmp_path / "none.net.xml", ("0",))
    bad = tmp_path / "bad.net.xml"
    bad.write_text("<net")
    with pytest.raises(InputError, match="not a readable SUMO net"):
        junction_table(bad)


LEFTHAND_NODES = """<nodes><node id="C" x="0" y="0" type="priority"/><node id="W" x="-100" y="0"/>
<node id="E" x="100" y="0"/><node id="N" x="0" y="100"/><node id="S" x="0" y="-100"/></nodes>"""
LEFTHAND_EDGES = "<edges>" + "".join(
    f'<edge id="{a}_in" from="{a}" to="C" numLanes="2"/><edge id="{a}_out" from="C" to="{a}" numLanes="2"/>'
    for a in "WENS") + "</edges>"
LEFTHAND_CONNECTIONS = """<connections>
<connection from="W_in" to="N_out" fromLane="0" toLane="0"/><connection from="W_in" to="N_out" fromLane="0" toLane="1"/>
<connection from="W_in" to="E_out" fromLane="0" toLane="0"/><connection from="W_in" to="E_out" fromLane="1" toLane="1"/>
<connection from="W_in" to="S_out" fromLane="1" toLane="0"/><connection from="W_in" to="S_out" fromLane="1" toLane="1"/>
</connections>"""


def test_in_a_lefthand_net_the_curb_side_turn_prefers_the_curb_lane(tmp_path):
    """Driving on the left, lane 0 is the curb lane on the left: a left turn (the near side)
    prefers exit lane 0, a right turn (across the oncoming traffic) the median lane, as a right
    turn and a left turn do in a right-hand net."""
    import subprocess

    for name, text in (("n.nod.xml", LEFTHAND_NODES), ("n.edg.xml", LEFTHAND_EDGES), ("n.con.xml", LEFTHAND_CONNECTIONS)):
        (tmp_path / name).write_text(text)
    net = tmp_path / "lh.net.xml"
    subprocess.run([sumolib.checkBinary("netconvert"), "-n", "n.nod.xml", "-e", "n.edg.xml", "-x", "n.con.xml",
                    "--lefthand", "--no-turnarounds", "-o", net.name], cwd=tmp_path, check=True, capture_output=True)
    movements = load_movements(net, ("C",), 80.0)
    exits = {p.movement: movements.exits[p.id] for p in movements.paths.values() if p.approach == "W_in"}
    assert exits["left"] == ("0", "1") and exits["right"] == ("1", "0")
