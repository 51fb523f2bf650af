"""crossing_order's blocks: a vehicle waiting for one crossing never stands in another of its
crossings, so no vehicle it blocks there can close a cycle of waits."""

import numpy as np
import pytest

from intersection_cosim.control.base import Decisions
from intersection_cosim.control.game.relations import step_relations
from intersection_cosim.control.game.settings import PolicySettings
from intersection_cosim.control.safety.kinematics import CREEP_CLEARANCE, PlanEnds, block_starts, past_horizon
from intersection_cosim.control.safety.settings import SafetySettings
from intersection_cosim.games.problem import Plan
from intersection_cosim.games.settings import ProblemSettings
from intersection_cosim.models.settings import ModelSettings
from tests.control.conftest import FilterUnderTest, make_world

GS = SafetySettings()
PROBLEM = ProblemSettings()
MODEL = ModelSettings()
RANGE = PolicySettings().lane_choice_range  # [m]


def test_zones_that_overlap_or_leave_no_room_between_them_chain_into_one_block():
    rows = np.array([0, 0, 0, 1, 1, 0, 2])
    z_in = np.array([10.0, 14.0, 30.0, 5.0, 7.0, 13.0, np.inf])  # [m]
    z_out = np.array([13.0, 20.0, 35.0, 6.9, 8.0, 15.0, np.inf])  # [m]
    starts = block_starts(rows, z_in, z_out, 2.0 * CREEP_CLEARANCE)
    # row 0: 10-13, 13-15 and 14-20 chain, 30-35 stands alone; row 1: 0.1 m between, no room
    assert starts.tolist() == [10.0, 10.0, 30.0, 5.0, 5.0, 10.0, np.inf]
    rooms = block_starts(rows, z_in, np.array([13.0, 20.0, 35.0, 6.7, 8.0, 15.0, np.inf]), 2.0 * CREEP_CLEARANCE)
    assert rooms[4] == 7.0  # 0.3 m between: a vehicle can stand there


def test_an_entry_past_the_horizon_is_taken_on_only_where_the_plan_reaches_the_zones_block():
    """Pair 0: i's plan ends at 5 m, 2 m/s after 3 s, inside the block from 4 m of its zone at
    9-12 m: it enters at 3 + 4 / 2 = 5 s; j, moving at 4 m/s at its plan's end inside its zone,
    leaves it at 3 + 2 / 4 = 3.5 s. Pair 1: i's block starts at 6 m, beyond its plan: unchanged.
    Pair 2: i ends standing in its block: it enters at clear speed 1 m/s and may stay (inf)."""
    inf = np.inf
    times = (np.array([inf, inf, inf]), np.array([inf, inf, inf]), np.array([1.0, 1.0, 1.0]), np.array([inf, inf, inf]))
    zone_i = np.array([[9.0, 12.0]] * 3)  # [m]
    zone_j = np.array([[20.0, 25.0]] * 3)  # [m]
    end_i = PlanEnds(np.array([5.0, 5.0, 5.0]), np.array([2.0, 2.0, 0.0]), np.full(3, 3.0))
    end_j = PlanEnds(np.array([23.0, 23.0, 23.0]), np.array([4.0, 4.0, 4.0]), np.full(3, 3.0))
    in_i, out_i, in_j, out_j = past_horizon(times, zone_i, zone_j, end_i, end_j, np.array([4.0, 6.0, 4.0]),
                                            np.full(3, inf), 1.0)
    assert in_i.tolist() == [5.0, inf, 7.0]
    assert out_i.tolist() == [3 + 7 / 2, inf, inf]
    assert out_j.tolist() == [3.5, inf, 3.5]
    assert in_j.tolist() == [1.0, 1.0, 1.0]


def test_a_vehicle_waiting_for_a_crossing_never_stands_in_the_crossing_that_overlaps_it(paths, movements,
                                                                                     conflict_table):
    """X (eastbound straight) crawls 0.2 m past its stop line. Its zone with W (southbound,
    139.0-145.5 m on X's path) overlaps its zone with Z (from 143.0 m), and Z, first into the
    junction, crawls through it at 1 m/s. Told to stop 1 m before Z's zone, X would stand at 142 m inside W's
    crossing, where W (which may already wait for Z) would have to wait for X: a cycle. X can
    still stop before W's zone, so it now waits there; both pass within 16 s and never occupy
    their crossing at once."""
    t = conflict_table
    x_path, w_path, z_path = "west_outer_straight_outer", "north_outer_straight_outer", "north_middle_straight_middle"
    x, w, z = t.index[x_path], t.index[w_path], t.index[z_path]
    a_in, a_out = float(t.zone_in[x, w]), float(t.zone_out[x, w])  # [m] on X's path
    b_in, b_out = float(t.zone_in[x, z]), float(t.zone_out[x, z])  # [m]
    assert a_in < b_in - GS.margin < a_out  # 1 m before Z's zone lies inside W's
    z_in, z_out = float(t.zone_in[z, x]), float(t.zone_out[z, x])  # [m] on Z's path
    s = {"X": float(t.s_stop[x]) + 0.2, "Z": z_in - 2.0, "W": float(t.zone_in[w, x]) - 30.0}  # [m]
    v = {"X": 1.0, "Z": 1.0, "W": 0.0}  # [m/s]; W stands 30 m before its zone
    want = {"X": 1.0, "Z": 0.0, "W": 0.0}  # [m/s^2] the plans
    paths_of = {"X": x_path, "W": w_path, "Z": z_path}
    f = FilterUnderTest(GS, t.s_stop, 0.1)
    for when, inside in ((0.0, {"Z"}), (1.0, {"Z", "X"})):
        world = make_world(paths, when, [(vid, paths_of[vid], s[vid], v[vid]) for vid in ("X", "W", "Z")])
        world.role = ["passing" if vid in inside else "ready" for vid in world.ids]
        f.record_entries(world)
    stood_in_w, both_in = [], []
    for step in range(160):  # 16 s at the 0.1 s period
        world = make_world(paths, 2.0 + 0.1 * step, [(vid, paths_of[vid], s[vid], v[vid]) for vid in ("X", "W", "Z")])
        world.role = ["passing", "ready", "passing"]
        plans = {vid: Plan.from_accelerations(s[vid], v[vid], np.full(PROBLEM.steps, want[vid]), PROBLEM.dt)
                 for vid in want}
        d = Decisions(accel=dict(want))
        relations = step_relations(world, set(range(len(world))), movements, t, MODEL, True, {}, RANGE)
        f.apply(world, relations, plans, {}, d)
        for vid in ("X", "Z"):
            a = d.accel[vid]
            s[vid] += v[vid] * 0.1 + 0.5 * a * 0.01
            v[vid] = max(v[vid] + a * 0.1, 0.0)
        if a_in <= s["X"] < a_out and v["X"] < 0.05:  # [m/s] it stands there
            stood_in_w.append(round(s["X"], 2))
        if b_in <= s["X"] < b_out and z_in <= s["Z"] < z_out:
            both_in.append(step)
        print("TRACE", step, round(s["X"],2), round(v["X"],2), round(s["Z"],2), d.accel["X"])
    assert stood_in_w == []  # X never stood in W's crossing
    assert both_in == []  # X and Z never in their crossing at once
    assert s["X"] > b_out and s["Z"] > z_out  # both passed


def test_a_vehicle_whose_horizon_reaches_a_block_but_not_its_crossing_waits_before_the_block(paths, movements,
                                                                                              conflict_table):
    """X (eastbound straight) crawls at 1 m/s up to its stop line; its 3 s plan reaches its zone with
    W (139.0-145.5 m), the start of a block, but not its zone with Z inside it (from 143.0 m), which
    Z, first into the junction, crawls through at 1 m/s. Had X entered the block, its horizon would
    have seen Z's crossing only from inside W's and braked for it there (on the old code from
    139.06 m on, down to 0.55 m/s; with Z slower it stands there, where W would have to wait for it:
    the start of a cycle). Its entry into Z's crossing is taken on past the horizon at its
    final speed, so it waits before the block, and both pass within 30 s."""
    t = conflict_table
    x_path, w_path, z_path = "west_outer_straight_outer", "north_outer_straight_outer", "north_middle_straight_middle"
    x, w, z = t.index[x_path], t.index[w_path], t.index[z_path]
    a_in, a_out = float(t.zone_in[x, w]), float(t.zone_out[x, w])  # [m] on X's path
    b_in, b_out = float(t.zone_in[x, z]), float(t.zone_out[x, z])  # [m]
    assert a_in < b_in < a_out  # one block
    z_in, z_out = float(t.zone_in[z, x]), float(t.zone_out[z, x])  # [m] on Z's path
    s = {"X": float(t.s_stop[x]) - 1.0, "Z": z_in - 1.0, "W": float(t.zone_in[w, x]) - 30.0}  # [m]
    v = {"X": 1.0, "Z": 0.5, "W": 0.0}  # [m/s]
    want = {"X": 0.3, "Z": 0.0, "W": 0.0}  # [m/s^2] the plans
    reach = s["X"] + v["X"] * PROBLEM.horizon + 0.5 * want["X"] * PROBLEM.horizon ** 2  # [m]
    assert a_in <= reach < b_in  # the first plan reaches the block, not Z's crossing
    paths_of = {"X": x_path, "W": w_path, "Z": z_path}
    f = FilterUnderTest(GS, t.s_stop, 0.1)
    braked_in_block, both_in = [], []
    for step in range(300):  # 30 s at the 0.1 s period
        world = make_world(paths, 0.1 * step, [(vid, paths_of[vid], s[vid], v[vid]) for vid in ("X", "W", "Z")])
        world.role = ["passing" if s["X"] >= float(t.s_stop[x]) else "ready", "ready", "passing"]
        f.record_entries(world)
        plans = {vid: Plan.from_accelerations(s[vid], v[vid], np.full(PROBLEM.steps, want[vid]), PROBLEM.dt)
                 for vid in want}
        d = Decisions(accel=dict(want))
        relations = step_relations(world, set(range(len(world))), movements, t, MODEL, True, {}, RANGE)
        f.apply(world, relations, plans, {}, d)
        if a_in <= s["X"] < b_out and d.accel["X"] < 0.0:
            braked_in_block.append(round(s["X"], 2))
        for vid in ("X", "Z"):
            a = d.accel[vid]
            s[vid] += v[vid] * 0.1 + 0.5 * a * 0.01
            v[vid] = max(v[vid] + a * 0.1, 0.0)
        if b_in <= s["X"] < b_out and z_in <= s["Z"] < z_out:
            both_in.append(step)
    assert braked_in_block == []  # X never had to slow down for Z inside W's crossing
    assert both_in == []  # X and Z never in their crossing at once
    assert s["X"] > b_out and s["Z"] > z_out  # both passed
