"""SafetyFilter as a unit: crossings, the entry queue, the box rule and its counters."""

import dataclasses

import numpy as np
import pytest

from intersection_cosim.control.base import Decisions
from intersection_cosim.control.game.relations import step_relations
from intersection_cosim.control.safety.kinematics import braking_plan
from tests.control.conftest import FilterUnderTest
from intersection_cosim.games.problem import Plan
from intersection_cosim.control.game.settings import PolicySettings
from intersection_cosim.control.safety.settings import SafetySettings
from intersection_cosim.games.settings import ProblemSettings
from intersection_cosim.models.settings import ModelSettings
from tests.control.conftest import make_world

GS = SafetySettings()
PROBLEM = ProblemSettings()
RANGE = PolicySettings().lane_choice_range  # [m]
MODEL = ModelSettings()
LEFT = "west_inner_left_inner"  # eastbound, turning left to the north
STRAIGHT = "north_middle_straight_middle"  # southbound, straight on: the left turn crosses it


def _deepest_crossing(t):
    past = np.where(t.kind == 2, t.zone_out - t.s_a, -np.inf)
    p, q = np.unravel_index(int(np.argmax(past)), past.shape)
    return int(p), int(q)


def _relations(world, movements, table):
    return step_relations(world, set(range(len(world))), movements, table, MODEL, True, {}, RANGE)


def _entered_in_order(f, paths, vehicles, first):
    """The World of ``vehicles`` (make_world's tuples) at t = 5 s, both in the junction, after
    ``f`` recorded ``first`` entering at t = 1 s and the other at t = 5 s."""
    roles = ["passing" if v[0] == first else "ready" for v in vehicles]
    for time, role in ((1.0, roles), (5.0, ["passing"] * len(vehicles))):
        world = make_world(paths, time, vehicles)
        world.role = role
        f.record_entries(world)
    return world


def _filter_with_entries(paths, conflict_table, veh, entered):
    """A SafetyFilter whose entry queue recorded each of ``veh`` (make_world's tuples) entering at
    ``entered[id]`` [s], in that order (vehicles may share a time)."""
    f = FilterUnderTest(GS, conflict_table.s_stop, 0.1)
    for when in sorted(set(entered.values())):
        world = make_world(paths, when, veh)
        world.role = ["passing" if entered[v[0]] <= when else "ready" for v in veh]
        f.record_entries(world)
    assert f.entered == entered
    return f


def test_two_plans_at_a_crossing_together_one_brakes_to_stop_before_it(paths, movements, conflict_table):
    """Both hold 8 m/s and reach their crossing about together: the one ranked lower (the later
    by time to the zone) cannot stop at its stop line any more and stops 1 m (margin)
    before its zone; the other keeps its plan."""
    t = conflict_table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    s_l, s_s = t.zone_in[p, q] - 16.0, t.zone_in[q, p] - 17.0  # [m] L 2.0 s, S 2.125 s from the zone
    world = make_world(paths, 0.0, [("L", LEFT, s_l, 8.0), ("S", STRAIGHT, s_s, 8.0)])
    hold = np.zeros(PROBLEM.steps)
    plans = {"L": Plan.from_accelerations(s_l, 8.0, hold, PROBLEM.dt), "S": Plan.from_accelerations(s_s, 8.0, hold, PROBLEM.dt)}
    f = FilterUnderTest(GS, t.s_stop, 0.1)
    d = Decisions(accel={"L": 0.0, "S": 0.0})
    held = f.apply(world, _relations(world, movements, t), plans, {}, d)
    assert d.accel["L"] == 0.0
    to_line = float(t.s_stop[q]) - GS.margin - s_s  # [m] 4.25 m: would need -7.5 m/s^2
    assert -8.0 ** 2 / (2 * to_line) < PROBLEM.a_min
    to_zone = float(t.zone_in[q, p]) - GS.margin - s_s  # [m] 16 m: it stops before its zone
    assert d.accel["S"] == pytest.approx(-8.0 ** 2 / (2 * to_zone), rel=1e-9)  # -2 m/s^2
    assert held == {"S"} and f.filtered == 1 and f.cleared == 0


def test_a_vehicle_just_short_of_its_stop_line_stays_out_at_the_line_not_before_the_zone(paths, movements,
                                                                                         conflict_table):
    """S creeps at 0.3 m/s 0.5 m before its stop line (inside ``margin``) and wants to go; L comes
    at 8 m/s and ranks ahead (both plans reach the crossing about 3 s on). S stops at its line (-0.3^2 / (2 x 0.45 m)), not on into the junction
    towards its zone, where the entry queue would rank it ahead of L (cross_2lane: an AV crept in
    so and drove into a human SUMO let go)."""
    t = conflict_table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    s_l, s_s = t.zone_in[p, q] - 20.0, float(t.s_stop[q]) - 0.5  # [m] L 2.5 s from its zone
    assert t.zone_in[q, p] - GS.margin - s_s > 3.0  # [m] room to creep on before the zone
    world = make_world(paths, 0.0, [("L", LEFT, s_l, 8.0), ("S", STRAIGHT, s_s, 0.3)])
    plans = {"L": Plan.from_accelerations(s_l, 8.0, np.zeros(PROBLEM.steps), PROBLEM.dt),
             "S": Plan.from_accelerations(s_s, 0.3, np.full(PROBLEM.steps, 2.5), PROBLEM.dt)}
    f = FilterUnderTest(GS, t.s_stop, 0.1)
    d = Decisions(accel={"L": 0.0, "S": 2.5})
    f.apply(world, _relations(world, movements, t), plans, {}, d)
    assert d.accel["L"] == 0.0
    assert d.accel["S"] == pytest.approx(-0.3 ** 2 / (2 * 0.45), rel=1e-9)


def test_under_position_noise_a_yielding_vehicle_stops_short_of_its_zone_by_the_slack(paths, movements,
                                                                                       conflict_table):
    """The same crossing as above with 0.85 m of gap slack (3 sqrt(2) x 0.2 m of V2X noise): the
    zones widen by it at both ends, so the yielding vehicle stops that much earlier (fokr38 over
    a noisy link: one stopped at the edge of another's zone, read outside it, and was hit)."""
    t = conflict_table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    s_l, s_s = t.zone_in[p, q] - 16.0, t.zone_in[q, p] - 17.0  # [m]
    world = make_world(paths, 0.0, [("L", LEFT, s_l, 8.0), ("S", STRAIGHT, s_s, 8.0)])
    hold = np.zeros(PROBLEM.steps)
    plans = {"L": Plan.from_accelerations(s_l, 8.0, hold, PROBLEM.dt), "S": Plan.from_accelerations(s_s, 8.0, hold, PROBLEM.dt)}
    slack = 3.0 * np.sqrt(2.0) * 0.2  # [m]
    f = FilterUnderTest(GS, t.s_stop, 0.1, gap_slack=slack)
    d = Decisions(accel={"L": 0.0, "S": 0.0})
    relations = _relations(world, movements, t)
    f.apply(world, relations, plans, {}, d)
    to_zone = float(t.zone_in[q, p]) - slack - GS.margin - s_s  # [m]
    assert d.accel["L"] == 0.0 and d.accel["S"] == pytest.approx(-8.0 ** 2 / (2 * to_zone), rel=1e-9)
    assert relations.pairs.zone_i[0, 0] == pytest.approx(_relations(world, movements, t).pairs.zone_i[0, 0])  # not mutated


def test_the_entry_queue_and_the_box_rule(paths, movements, conflict_table):
    """B entered the junction first and stands inside the crossing; its own plan waits. A,
    ranked lower (it entered later), yields before its zone; then B must clear the crossing:
    its acceleration is raised to clear_accel (1 m/s^2), or A and B would wait for each other."""
    t = conflict_table
    p, q = _deepest_crossing(t)
    a_path, b_path = t.ids[p], t.ids[q]
    s_b = 0.5 * (t.zone_in[q, p] + t.zone_out[q, p])  # B in the middle of its zone
    s_a = t.zone_in[p, q] - 3.0  # A 3 m before its zone, inside the junction
    assert s_a > t.s_stop[p]
    f = FilterUnderTest(GS, t.s_stop, 0.1)
    world = _entered_in_order(f, paths, [("A", a_path, s_a, 2.0), ("B", b_path, s_b, 0.0)], first="B")
    assert f.entered == {"B": 1.0, "A": 5.0}
    plans = {"A": Plan.from_accelerations(s_a, 2.0, np.full(PROBLEM.steps, 1.0), PROBLEM.dt),
             "B": Plan.from_accelerations(s_b, 0.0, np.zeros(PROBLEM.steps), PROBLEM.dt)}
    d = Decisions(accel={"A": 1.0, "B": 0.0})
    f.apply(world, _relations(world, movements, t), plans, {}, d)
    assert d.accel["A"] < 0.0  # A yields before its zone
    assert d.accel["B"] == pytest.approx(GS.clear_accel)
    assert f.cleared == 1 and f.filtered == 1
    f.release("A")
    assert f.entered == {"B": 1.0}


def test_a_vehicle_with_weak_brakes_is_guarded_by_its_own_decel(paths, movements, conflict_table):
    """The crossing above: S needs -2 m/s^2 to stop before its zone. With its vType's decel at
    1.5 m/s^2 it cannot, so the filter does not count on it: L, ranked first, yields instead and
    S keeps its plan. Behind a standing leader, a follower at 4 m/s that wants +2.5 m/s^2 gets it
    with the model's 4 m/s^2 braking, and is capped to Krauss' safe speed for b = 2 (+0.47 m/s^2)
    when its vType brakes at 2 m/s^2."""
    t = conflict_table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    s_l, s_s = t.zone_in[p, q] - 16.0, t.zone_in[q, p] - 17.0
    world = make_world(paths, 0.0, [("L", LEFT, s_l, 8.0), ("S", STRAIGHT, s_s, 8.0)])
    world = dataclasses.replace(world, decel=np.array([4.0, 1.5]), accel=np.array([2.5, 2.5]))
    hold = np.zeros(PROBLEM.steps)
    plans = {"L": Plan.from_accelerations(s_l, 8.0, hold, PROBLEM.dt), "S": Plan.from_accelerations(s_s, 8.0, hold, PROBLEM.dt)}
    d = Decisions(accel={"L": 0.0, "S": 0.0})
    held = FilterUnderTest(GS, t.s_stop, 0.1).apply(world, _relations(world, movements, t), plans, {}, d)
    assert d.accel["S"] == 0.0 and d.accel["L"] < 0.0 and held == {"L"}

    lane = "south_middle_straight_middle"
    s_stop = paths[lane].s_stop
    for decel, capped in ((4.0, False), (2.0, True)):
        world = make_world(paths, 0.0, [("lead", lane, s_stop - 30.0, 0.0), ("follow", lane, s_stop - 40.0, 4.0)])
        world = dataclasses.replace(world, decel=np.array([4.0, decel]), accel=np.array([2.5, 2.5]))
        plans = {v: Plan.from_accelerations(float(world.s[k]), float(world.v[k]), hold, PROBLEM.dt)
                 for k, v in enumerate(world.ids)}
        d = Decisions(accel={"lead": 0.0, "follow": 2.5})
        FilterUnderTest(GS, t.s_stop, 0.1).apply(world, _relations(world, movements, t), plans, {}, d)
        gap = 10.0 - MODEL.vehicle_length - GS.margin  # [m]
        v_safe = -decel * 0.1 + np.sqrt((decel * 0.1) ** 2 + 2 * decel * gap)  # [m/s]: 5.6 at b = 4, 4.05 at b = 2
        assert d.accel["follow"] == pytest.approx(min(2.5, (v_safe - 4.0) / 0.1))
        assert (d.accel["follow"] < 1.0) == capped


def test_a_follower_is_capped_at_krauss_safe_speed(paths, movements, conflict_table):
    """A follower 10 m (front to front) behind a standing leader at 8 m/s: its acceleration is
    capped so that its speed next period is v_safe of the 10 - 4.5 - 1 m gap."""
    lane = "south_middle_straight_middle"
    s_stop = paths[lane].s_stop
    world = make_world(paths, 0.0, [("lead", lane, s_stop - 30.0, 0.0), ("follow", lane, s_stop - 40.0, 8.0)])
    f = FilterUnderTest(GS, conflict_table.s_stop, 0.1)
    plans = {v: Plan.from_accelerations(float(world.s[k]), float(world.v[k]), np.zeros(PROBLEM.steps), PROBLEM.dt)
             for k, v in enumerate(world.ids)}
    d = Decisions(accel={"lead": 0.0, "follow": 0.0})
    held = f.apply(world, _relations(world, movements, conflict_table), plans, {}, d)
    b, tau = -PROBLEM.a_min, 0.1
    gap = 10.0 - MODEL.vehicle_length - GS.margin  # [m]
    v_safe = -b * tau + np.sqrt((b * tau) ** 2 + 2 * b * gap)
    assert d.accel["follow"] == pytest.approx(max((v_safe - 8.0) / tau, PROBLEM.a_min))
    assert d.accel["lead"] == 0.0 and held == frozenset()  # behind a leader is not held at a crossing


def test_behind_an_emergency_stop_a_follower_brakes_beyond_its_decel_only_as_hard_as_it_must(
        paths, movements, conflict_table):
    """A leader at 6 m/s makes an emergency stop at 8 m/s^2 (a person in its way: ``floors``); its
    follower, 9 m/s and 2.5 m behind it, cannot stay at Krauss' safe speed with its own 4 m/s^2
    (it would need -32). It brakes beyond its decel, up to its vType's emergencyDecel (9), only
    as hard as Krauss' safe speed for that braking needs (-6.1); without an emergencyDecel it
    keeps its own 4 m/s^2. A follower at 3 m/s, whose own braking suffices, is not touched."""
    lane = "south_middle_straight_middle"
    s_stop = paths[lane].s_stop
    b, b_em, b_lead, tau = 4.0, 9.0, 8.0, 0.1  # [m/s^2], [s]
    hold = np.zeros(PROBLEM.steps)
    out = {}
    for name, v_follow, emergency in (("needs more", 9.0, True), ("needs more, no emergencyDecel", 9.0, False),
                                      ("own braking suffices", 3.0, True)):
        world = make_world(paths, 0.0, [("lead", lane, s_stop - 30.0, 6.0), ("follow", lane, s_stop - 38.0, v_follow)])
        world = dataclasses.replace(world, decel=np.array([b, b]), accel=np.array([2.5, 2.5]),
                                    emergency_decel=np.array([b_em, b_em]) if emergency else None)
        plans = {v: Plan.from_accelerations(float(world.s[k]), float(world.v[k]), hold, PROBLEM.dt)
                 for k, v in enumerate(world.ids)}
        d = Decisions(accel={"lead": -b_lead, "follow": 0.0})
        FilterUnderTest(GS, conflict_table.s_stop, tau).apply(
            world, _relations(world, movements, conflict_table), plans, {}, d, floors={"lead": -b_lead})
        out[name] = d.accel["follow"]
    gap = 8.0 - MODEL.vehicle_length - GS.margin  # [m] bumper to bumper, less the margin

    def v_safe(decel):  # [m/s] Krauss behind a leader braking at b_lead
        return -decel * tau + np.sqrt((decel * tau) ** 2 + decel / b_lead * 6.0 ** 2 + 2 * decel * gap)

    assert (v_safe(b) - 9.0) / tau < -30.0  # its own braking is not enough
    need = (v_safe(b_em) - 9.0) / tau  # [m/s^2]
    assert -b_em < need < -b - 1.0
    assert out["needs more"] == pytest.approx(need)
    assert out["needs more, no emergencyDecel"] == pytest.approx(-b)
    assert out["own braking suffices"] >= -b


def test_the_gap_to_a_leader_allows_for_the_links_position_noise(paths, movements, conflict_table):
    """Under 0.2 m of V2X position noise a follower crawled into its standing leader inside the
    junction (fokr38, 0.2 and 0.7 m/s): the gap it counts on loses 3 sqrt(2) sigma, the error of
    two noisy positions."""
    lane = "south_middle_straight_middle"
    s_stop = paths[lane].s_stop
    world = make_world(paths, 0.0, [("lead", lane, s_stop - 30.0, 0.0), ("follow", lane, s_stop - 37.0, 2.0)])
    plans = {v: Plan.from_accelerations(float(world.s[k]), float(world.v[k]), np.zeros(PROBLEM.steps), PROBLEM.dt)
             for k, v in enumerate(world.ids)}
    b, tau = -PROBLEM.a_min, 0.1
    caps = []
    for slack in (0.0, 3.0 * np.sqrt(2.0) * 0.2):
        f = FilterUnderTest(GS, conflict_table.s_stop, 0.1, gap_slack=slack)
        d = Decisions(accel={"lead": 0.0, "follow": 2.0})
        f.apply(world, _relations(world, movements, conflict_table), plans, {}, d)
        gap = 7.0 - MODEL.vehicle_length - GS.margin - slack  # [m]
        v_safe = -b * tau + np.sqrt((b * tau) ** 2 + 2 * b * gap)
        assert d.accel["follow"] == pytest.approx(min(2.0, (v_safe - 2.0) / tau))
        caps.append(d.accel["follow"])
    assert caps[1] < caps[0] - 1.0  # [m/s^2]


def _chord_heading(path, s, length):
    """[rad] SUMO's heading of a vehicle with its front at ``s`` [m]: rear point to front point."""
    d = path.point_at(s) - path.point_at(s - length)
    return float(np.arctan2(d[1], d[0]))


def _in_the_way(paths, turner, s_turner, crosser, fronts):
    """Whether a body on ``turner`` with its front at ``s_turner`` [m] overlaps one on ``crosser``
    at any of ``fronts`` [m], both headed as SUMO heads them (results.metrics.body_overlaps)."""
    import pandas as pd

    from intersection_cosim.results.metrics import body_overlaps

    length, width = MODEL.vehicle_length, MODEL.vehicle_width
    xy = paths[crosser].point_at(fronts)
    xt, yt = paths[turner].point_at(s_turner)
    n = len(fronts)
    traj = pd.DataFrame({"time": np.tile(np.arange(n, dtype=float), 2), "vehicle": ["S"] * n + ["L"] * n,
                         "x": np.concatenate([xy[:, 0], np.full(n, xt)]), "y": np.concatenate([xy[:, 1], np.full(n, yt)]),
                         "heading": [_chord_heading(paths[crosser], s, length) for s in fronts]
                         + [_chord_heading(paths[turner], s_turner, length)] * n})
    return bool(body_overlaps(traj, length, width))


def test_a_turner_standing_with_its_rear_in_a_crossing_still_holds_the_other(paths, movements, conflict_table):
    """Issue 17 (a collision on the grid): the left turner L entered first and stands where
    SUMO's body (headed along the chord from its rear on the centre line to its front) is just
    still in the way of bodies on the straight path, 0.25 m before it clears. S, approaching
    slowly, must wait at its stop line. With zones from bodies headed along the tangent at the
    front (whose rear swings ~0.8 m further out on a turn), L's zone had ended there: the pair was
    no longer guarded and S drove into L's rear."""
    t = conflict_table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    length = MODEL.vehicle_length
    fronts = np.arange(t.s_stop[q], t.s_exit[q] + length, 0.25)  # [m] S's fronts through the junction
    s_l = float(t.s_a[p, q])  # [m] L's front at the crossing of the centre lines: in the way
    assert _in_the_way(paths, LEFT, s_l, STRAIGHT, fronts)
    while _in_the_way(paths, LEFT, s_l + 0.25, STRAIGHT, fronts):
        s_l += 0.25  # the last front (to 0.25 m) at which L is in S's way
    assert s_l > t.s_a[p, q] + length  # several metres past the crossing point
    s_s = float(t.s_stop[q]) - 3.0  # [m]
    f = FilterUnderTest(GS, t.s_stop, 0.1)
    world = make_world(paths, 5.0, [("L", LEFT, s_l, 0.0), ("S", STRAIGHT, s_s, 2.0)])
    world.role = ["passing", "ready"]
    f.record_entries(world)
    plans = {"L": Plan.from_accelerations(s_l, 0.0, np.zeros(PROBLEM.steps), PROBLEM.dt),
             "S": Plan.from_accelerations(s_s, 2.0, np.full(PROBLEM.steps, 2.5), PROBLEM.dt)}
    d = Decisions(accel={"L": 0.0, "S": 2.5})
    held = f.apply(world, _relations(world, movements, t), plans, {}, d)
    to_line = float(t.s_stop[q]) - GS.margin - s_s  # [m] 2 m
    assert d.accel["S"] == pytest.approx(-2.0 ** 2 / (2 * to_line), rel=1e-9)  # -1 m/s^2, at its line
    assert "S" in held
    assert d.accel["L"] == pytest.approx(GS.clear_accel)  # and L, standing in the crossing, drives out


def test_at_a_merge_a_follower_level_with_a_leader_turning_in_waits(paths, movements, conflict_table):
    """demand_balanced_high (stackelberg, seed 2, 20 ms budget, 123.55 s): the right turner R has
    just passed the point where its path meets the straight path of S, so R leads S into their
    exit lane, but along the paths R's rear is still 2.3 m behind S's front: R's body is swinging
    in. Krauss' safe speed, with the gap clamped at 0 and credit for R's 2.7 m/s, let S go on at
    2.4 m/s^2, and 1.2 s later S's front was 0.3 m into R's rear corner (SUMO did not count it;
    our body check did). S now waits until R is a margin ahead; R goes on."""
    t = conflict_table
    turner, straight = "north_outer_right_outer", "east_outer_straight_outer"
    p, q = t.index[turner], t.index[straight]
    assert t.kind[p, q] == 3  # a confluence: both end on the west exit's outer lane
    s_r, v_r, s_s, v_s = 138.72, 2.70, 156.97, 1.14  # [m], [m/s] as in the run
    assert s_r > t.s_a[p, q] and s_s < t.s_a[q, p]  # R past its merge point, S short of its own
    a_r, a_s = 1.5, 2.43  # [m/s^2] the plans' first accelerations
    # driven on as planned, the two bodies (headed as SUMO heads them) meet within 1.5 s
    times = np.arange(0.0, 1.5, 0.05)
    assert any(_in_the_way(paths, turner, s_r + v_r * x + 0.5 * a_r * x * x, straight,
                           np.array([s_s + v_s * x + 0.5 * a_s * x * x])) for x in times)
    f = _filter_with_entries(paths, t, [("R", turner, s_r, v_r), ("S", straight, s_s, v_s)], {"S": 100.0, "R": 120.0})
    world = make_world(paths, 123.55, [("R", turner, s_r, v_r), ("S", straight, s_s, v_s)])
    world.role = ["passing", "passing"]
    plans = {"R": Plan.from_accelerations(s_r, v_r, np.full(PROBLEM.steps, a_r), PROBLEM.dt),
             "S": Plan.from_accelerations(s_s, v_s, np.full(PROBLEM.steps, a_s), PROBLEM.dt)}
    d = Decisions(accel={"R": a_r, "S": a_s})
    relations = _relations(world, movements, t)
    assert relations.leader_of(world.ids.index("S"), "outer").vehicle == world.ids.index("R")
    f.apply(world, relations, plans, {}, d)
    assert d.accel["S"] < 0.0 and d.accel["R"] == pytest.approx(a_r)


@pytest.mark.parametrize("games, braked", [(frozenset({("L", "S")}), False), (frozenset(), True)])
def test_a_pair_in_a_game_keeps_only_its_share_of_the_time_gap(paths, movements, conflict_table, games, braked):
    """S's plan enters its zone 0.35 s after L's has left it: inside the 0.5 s time_gap,
    outside the 0.2 s (game_gap_share 0.4) a pair keeps that plays its game this step. So the
    filter leaves that pair's plans alone and brakes S when they play none (no trigger, or a
    fallback step); a guarded pair of AVs is an event."""
    from intersection_cosim.control.safety.kinematics import occupancy
    t = conflict_table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    hold = np.zeros(PROBLEM.steps)
    s_l = float(t.zone_in[p, q]) - 4.0  # [m] L 0.5 s from its zone at 8 m/s
    out_l = occupancy(Plan.from_accelerations(s_l, 8.0, hold, PROBLEM.dt), float(t.zone_in[p, q]), float(t.zone_out[p, q]))[1]
    s_s = float(t.zone_in[q, p]) - 8.0 * (out_l + 0.35)  # [m] S enters 0.35 s after L's rear left
    world = make_world(paths, 0.0, [("L", LEFT, s_l, 8.0), ("S", STRAIGHT, s_s, 8.0)])
    plans = {"L": Plan.from_accelerations(s_l, 8.0, hold, PROBLEM.dt), "S": Plan.from_accelerations(s_s, 8.0, hold, PROBLEM.dt)}
    in_s = occupancy(plans["S"], float(t.zone_in[q, p]), float(t.zone_out[q, p]))[0]
    assert 0.2 < in_s - out_l < 0.5
    f = FilterUnderTest(SafetySettings(game_gap_share=0.4), t.s_stop, 0.1)
    d = Decisions(accel={"L": 0.0, "S": 0.0})
    f.apply(world, _relations(world, movements, t), plans, {}, d, games)
    assert d.accel["L"] == 0.0
    assert (d.accel["S"] < -0.5) == braked and f.filtered == int(braked)
    assert f.events == ({("L", "S")} if braked else set())


def test_under_position_noise_a_vehicle_read_inside_the_widened_zone_still_stays_out_of_the_zone(
        paths, movements, conflict_table):
    """Under a link's position noise the zones widen by the slack, and a vehicle read inside the
    widened zone cannot stay out of *that* any more; it can still stay out of the zone itself.
    A entered the junction first and stands 0.5 m short of its crossing zone (0.85 m of slack:
    read inside the widened zone); B entered later and stands in the crossing. A, ranked first
    by the entry queue, must still hold before the zone, not be let drive into B (fokr38 over a
    noisy link: a vehicle stopped short of its zone drove into one standing in the crossing); B,
    waited for, drives out of the crossing."""
    t = conflict_table
    p, q = _deepest_crossing(t)
    a_path, b_path = t.ids[p], t.ids[q]
    s_a = float(t.zone_in[p, q]) - 0.5  # [m] A just short of its zone, inside the junction
    s_b = 0.5 * float(t.zone_in[q, p] + t.zone_out[q, p])  # [m] B in the middle of its zone
    assert s_a > t.s_stop[p]
    slack = 3.0 * np.sqrt(2.0) * 0.2  # [m] > 0.5 m: A's reading is inside the widened zone
    f = FilterUnderTest(GS, t.s_stop, 0.1, gap_slack=slack)
    world = _entered_in_order(f, paths, [("A", a_path, s_a, 0.0), ("B", b_path, s_b, 0.0)], first="A")
    assert f.entered == {"A": 1.0, "B": 5.0}
    plans = {"A": Plan.from_accelerations(s_a, 0.0, np.full(PROBLEM.steps, 1.0), PROBLEM.dt),
             "B": Plan.from_accelerations(s_b, 0.0, np.zeros(PROBLEM.steps), PROBLEM.dt)}
    d = Decisions(accel={"A": 1.0, "B": 0.0})
    f.apply(world, _relations(world, movements, t), plans, {}, d)
    assert d.accel["A"] <= 0.0  # A holds short of the crossing B stands in
    assert d.accel["B"] == GS.clear_accel  # and B, waited for, drives out of it (box_clear)


def test_a_vehicle_held_for_one_crossing_leaves_the_crossing_it_stands_in_and_stops_between_them(
        paths, movements, conflict_table):
    """K stands 0.5 m before the end of its zone with A (139.0-145.5 m on the default net) and
    must stay out of its next zone, with B (from 147.0 m), where B, first into the junction,
    stands. Held where it stood, K blocked A, who waits for it (the cycle of three of
    demand_balanced_high); it now drives on out of A's zone and stops between the two zones (at
    most 1 m/s^2), never entering B's; A then has a free crossing."""
    t = conflict_table
    k_path, a_path, b_path = "north_middle_straight_middle", "east_outer_straight_outer", "east_inner_straight_inner"
    p, qa, qb = t.index[k_path], t.index[a_path], t.index[b_path]
    y_out, x_in = float(t.zone_out[p, qa]), float(t.zone_in[p, qb])  # [m] on K's path
    assert x_in - y_out >= 0.5  # [m] room to stand between the two zones
    s_b = 0.5 * (t.zone_in[qb, p] + t.zone_out[qb, p])  # [m] B in the middle of its zone with K
    s_a = t.zone_in[qa, p] - 3.0  # [m] A 3 m before its zone with K, at 3 m/s (there in 1 s)
    f = FilterUnderTest(GS, t.s_stop, 0.1)
    s_k, v_k = y_out - 0.5, 0.0  # [m], [m/s]
    order = ("B", "K", "A")  # into the junction at t = 0, 1, 2 s
    for step in range(len(order)):
        world = make_world(paths, float(step), [("K", k_path, s_k, v_k), ("A", a_path, s_a, 0.0),
                                                ("B", b_path, s_b, 0.0)])
        world.role = ["passing" if vid in order[:step + 1] else "ready" for vid in world.ids]
        f.record_entries(world)
    assert list(f.entered) == list(order)
    first_accel, track = None, []
    for step in range(60):  # 6 s at the 0.1 s period
        world = make_world(paths, 3.0 + 0.1 * step, [("K", k_path, s_k, v_k), ("A", a_path, s_a, 3.0),
                                                     ("B", b_path, s_b, 0.0)])
        world.role = ["passing"] * 3
        plans = {"K": Plan.from_accelerations(s_k, v_k, np.full(PROBLEM.steps, 1.0), PROBLEM.dt),
                 "A": Plan.from_accelerations(s_a, 3.0, np.zeros(PROBLEM.steps), PROBLEM.dt),
                 "B": Plan.from_accelerations(s_b, 0.0, np.zeros(PROBLEM.steps), PROBLEM.dt)}
        d = Decisions(accel={"K": 1.0, "A": 0.0, "B": 0.0})
        f.apply(world, _relations(world, movements, t), plans, {}, d)
        first_accel = d.accel["K"] if first_accel is None else first_accel
        if step == 0:
            assert d.accel["A"] < 0.0  # A waits for K, who ranks ahead of it
        a = d.accel["K"]
        s_k += v_k * 0.1 + 0.5 * a * 0.01
        v_k = max(v_k + a * 0.1, 0.0)
        track.append(s_k)
    assert 0.0 < first_accel <= GS.clear_accel  # it moves on, gently (it stood still before)
    assert max(track) < x_in  # never into B's zone
    assert y_out < s_k < x_in and v_k < 0.05  # stopped between the two zones


def test_a_vehicle_standing_in_the_first_ones_crossing_goes_before_the_vehicles_it_ranks_behind(
        paths, movements, conflict_table):
    """The cycle of four of demand_balanced_high (stackelberg, seed 5, 392 s), rebuilt: L (in
    first) waits 0.1 m before its zone with T, which stands inside their crossing; T waits 1 m
    before its zone with S (in after L, with T), S for N (inside S's crossing), N for L. T now
    ranks as L, whom it blocks: it is no longer held for S and drives on (its plan, 1.69 m/s^2),
    which clears L's way; S still yields (it can)."""
    t = conflict_table
    veh = [("L", "east_outer_straight_outer", 150.70, 0.0), ("T", "north_inner_left_inner", 142.00, 0.0),
           ("S", "east_middle_straight_middle", 145.49, 0.38), ("N", "south_inner_straight_inner", 158.95, 0.0)]
    entered = {"L": 376.35, "N": 381.35, "S": 384.25, "T": 384.25}  # [s], as in the run
    zone = {(a[0], b[0]): (float(t.zone_in[t.index[a[1]], t.index[b[1]]]), float(t.zone_out[t.index[a[1]], t.index[b[1]]]))
            for a in veh for b in veh if a != b}  # [m] on the first one's path
    assert zone["T", "L"][0] <= 142.0 < zone["T", "L"][1]  # T stands in its crossing with L ...
    assert zone["T", "S"][0] - GS.margin == pytest.approx(142.0)  # ... where it waits for S
    assert zone["L", "T"][0] - 150.70 < GS.margin  # L short of its zone with T
    f = _filter_with_entries(paths, t, veh, entered)  # S and T entered in the same step
    world = make_world(paths, 392.05, veh)
    world.role = ["passing"] * 4
    want = {"L": 2.5, "T": 1.69, "S": 2.5, "N": 2.5}  # [m/s^2] the plans' first accelerations
    plans = {v: Plan.from_accelerations(s, speed, np.full(PROBLEM.steps, want[v]), PROBLEM.dt)
             for v, _p, s, speed in veh}
    d = Decisions(accel=dict(want))
    f.apply(world, _relations(world, movements, t), plans, {}, d)
    assert d.accel["T"] == pytest.approx(1.69)  # T goes: it stood in L's crossing
    assert d.accel["S"] < 0.0 and d.accel["N"] <= 0.0  # S yields to N, N to L
    assert d.accel["L"] <= 0.0  # L waits until T has left their crossing


def test_a_blocker_that_inherits_a_rank_goes_before_the_vehicle_it_blocks_at_a_merge(
        paths, movements, conflict_table):
    """The cycle of three of demand_balanced_high (nash, seed 13, 2000 ms budget, 276 s), rebuilt:
    S (in first) waits 1 m before its crossing with E, inside which E stands; E waits 1 m before
    its crossing with W, inside which W (a left turn to the middle exit) stands; W waits 1 m
    before its merge with S (its game with S says wait: its plan stands). E inherits S's entry
    time and W inherits it from E; on the tie the ids ranked E ahead of W, so E yielded to W as
    the one that could still stay out, and no rule told W, standing in E's crossing, to drive
    out: the three stood for good (103 vehicles never arrived). W now ranks just ahead of E and
    S: E waits for it, W is told to clear E's crossing (the box rule), and S yields at the merge."""
    t = conflict_table
    veh = [("S", "south_middle_straight_middle", 150.0, 0.0), ("W", "west_inner_left_middle", 155.1552, 0.0),
           ("E", "east_inner_straight_inner", 147.0, 0.0)]
    entered = {"S": 262.25, "W": 263.15, "E": 263.75}  # [s], as in the run
    idx = {v: t.index[path] for v, path, _s, _v in veh}
    zone = {(a, b): (float(t.zone_in[idx[a], idx[b]]), float(t.zone_out[idx[a], idx[b]]))
            for a in idx for b in idx if a != b and t.kind[idx[a], idx[b]] == 2}  # [m] cross zones
    assert zone["E", "S"][0] <= 147.0 < zone["E", "S"][1]  # E stands in its crossing with S ...
    assert zone["E", "W"][0] - GS.margin == pytest.approx(147.0)  # ... waiting for W
    assert zone["W", "E"][0] <= 155.1552 < zone["W", "E"][1]  # W stands in its crossing with E
    assert zone["S", "E"][0] - GS.margin == pytest.approx(150.0)  # S waits for E
    assert t.kind[idx["W"], idx["S"]] == 3  # W and S merge into the north exit's middle lane
    f = _filter_with_entries(paths, t, veh, entered)
    world = make_world(paths, 276.05, veh)
    world.role = ["passing"] * 3
    want = {"S": 1.0, "W": 0.0, "E": 1.0}  # [m/s^2] the plans' first accelerations (W's stands)
    plans = {v: Plan.from_accelerations(s, speed, np.full(PROBLEM.steps, want[v]), PROBLEM.dt)
             for v, _p, s, speed in veh}
    d = Decisions(accel=dict(want))
    f.apply(world, _relations(world, movements, t), plans, {}, d)
    assert d.accel["W"] == pytest.approx(GS.clear_accel)  # W drives out of E's crossing
    assert d.accel["S"] <= 0.0 and d.accel["E"] <= 0.0  # S yields to W at the merge, E waits for W


@pytest.mark.parametrize("v_b, a_b, s_b_past_zone, to_line, held", [
    (0.0, 0.0, False, 8.0, True), (0.5, -1.0, False, 8.0, True), (1.8, -1.5, False, 8.0, True),
    (3.0, 0.0, False, 8.0, False), (3.0, -1.5, False, 8.0, False), (0.0, 0.0, True, 8.0, False),
    (0.0, 0.0, False, 30.0, False)])
def test_a_stalled_box_takes_no_new_entrant_into_its_crossings(paths, movements, conflict_table, v_b, a_b,
                                                              s_b_past_zone, to_line, held):
    """stalled_box_hold: B is in the junction 3 m before its zone with A's left turn, standing,
    or braking (a_b [m/s^2]) below clear_speed (1 m/s) now or within stalled_box_lookahead (1 s:
    1.8 m/s at -1.5 m/s^2). A, 8 m before its stop line at 5 m/s, plans to cross before B could:
    the plans alone keep the crossing clear, and with the setting off A keeps its +1 m/s^2. With
    it A waits at its stop line (-5^2 / (2 x 7 m) = -1.79 m/s^2): entering, it could be held
    inside the box in B's way (the third entry closed a cycle); and B, waited for, drives on at
    clear_accel (its own plan, a game's, may wait for A). Once B moves on (3 m/s, 1.5 m/s after
    1 s of braking) or has left its zone, the setting changes nothing; nor while A is 30 m away
    (a stop would need only 0.4 m/s^2, under comfort_brake: the stall may clear first)."""
    t = conflict_table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    s_a = float(t.s_stop[p]) - to_line  # [m]
    s_b = float(t.zone_out[q, p]) + 0.5 if s_b_past_zone else float(t.zone_in[q, p]) - 3.0  # [m]
    assert s_b > t.s_stop[q]
    b_plan = braking_plan(Plan.from_accelerations(s_b, v_b, np.zeros(PROBLEM.steps), PROBLEM.dt), a_b)
    result = {}
    for on in (True, False):
        f = FilterUnderTest(dataclasses.replace(GS, stalled_box_hold=on), t.s_stop, 0.1)
        world = make_world(paths, 1.0, [("A", LEFT, s_a, 5.0), ("B", STRAIGHT, s_b, v_b)])
        world.role, world.a = ["ready", "passing"], np.array([1.0, a_b])
        f.record_entries(world)
        plans = {"A": Plan.from_accelerations(s_a, 5.0, np.full(PROBLEM.steps, 1.0), PROBLEM.dt),
                 "B": b_plan}
        d = Decisions(accel={"A": 1.0, "B": float(b_plan.accelerations[0])})
        out = f.apply(world, _relations(world, movements, t), plans, {}, d)
        result[on] = (d.accel["A"], "A" in out, d.accel["B"])
    if held:
        assert result[False] == (1.0, False, b_plan.accelerations[0])
        stop = to_line - GS.margin  # [m] 7 m
        assert result[True][0] == pytest.approx(-5.0 ** 2 / (2 * stop), rel=1e-9) and result[True][1]
        assert result[True][2] == GS.clear_accel  # B, waited for, drives on (its plan stood)
    else:
        assert result[True] == result[False]


def test_a_stalled_box_does_not_hold_an_entrant_already_inside_a_crossing_zone(paths, movements, conflict_table):
    """demand_balanced_high, nash, seed 2, 150 s, rebuilt: a right turn (R) stands at its stop line
    (137.95 m), already inside its zone of the merge with a straight from the east (E): the
    point 138.2 m less half a width. E, in the junction, stands 0.05 m short of its own zone and
    must wait for R, who cannot stay out. stalled_box_hold must not hold R for the stalled E, or
    each waits for the other for good: R keeps its plan, E is held, as without the setting."""
    t = conflict_table
    e_path, r_path = "east_outer_straight_outer", "north_outer_right_outer"
    s_e, s_r = 157.71, 137.95  # [m], as in the run
    result = {}
    for on in (True, False):
        f = FilterUnderTest(dataclasses.replace(GS, stalled_box_hold=on), t.s_stop, 0.1)
        world = make_world(paths, 1.0, [("E", e_path, s_e, 0.0), ("R", r_path, s_r, 0.0)])
        world.role = ["passing", "ready"]
        f.record_entries(world)
        relations = _relations(world, movements, t)
        (r_in, _r_out), = relations.pairs.zone_j
        (e_in, _e_out), = relations.pairs.zone_i
        assert r_in <= s_r < t.s_stop[t.index[r_path]] and s_e < e_in  # R in its zone, E short of its own
        go = np.full(PROBLEM.steps, 1.5)  # [m/s^2]
        plans = {"E": Plan.from_accelerations(s_e, 0.0, go, PROBLEM.dt), "R": Plan.from_accelerations(s_r, 0.0, go, PROBLEM.dt)}
        d = Decisions(accel={"E": 1.5, "R": 1.5})
        f.apply(world, relations, plans, {}, d)
        result[on] = dict(d.accel)
    assert result[True] == result[False]
    assert result[True]["R"] == 1.5 and result[True]["E"] <= 0.0


def test_a_vehicle_already_in_the_crossing_drives_out_when_neither_can_yield(paths, movements, conflict_table):
    """demand_balanced_high, nash, seed 18, 236.35 s, rebuilt: N (straight from the north, in the
    junction second) has its front 0.77 m short of the end of its zone with E (straight from the
    east, in first), at 2.29 m/s; E, 2 m before its zone at 8 m/s, can no longer stop short of
    it. Neither can yield, and N ranks lower. Held back as hard as it may (-4 m/s^2), N would stop
    inside the zone, 0.17 m short of its end, and E hit it; it drives on out instead (its plan,
    +1.39 m/s^2, stands; at least clear_accel)."""
    t = conflict_table
    n_path, e_path = "north_outer_straight_outer", "east_outer_straight_outer"
    p, q = t.index[n_path], t.index[e_path]
    f = FilterUnderTest(GS, t.s_stop, 0.1)
    veh = [("N", n_path, 144.73, 2.29), ("E", e_path, float(t.zone_in[q, p]) - 2.0, 8.0)]
    for when, roles in ((234.25, ["ready", "passing"]), (234.75, ["passing", "passing"])):
        world = make_world(paths, when, veh)
        world.role = roles
        f.record_entries(world)
    relations = _relations(world, movements, t)
    (n_in, n_out), = relations.pairs.zone_i if relations.rows.vehicle[relations.pairs.ri[0]] == 0 else relations.pairs.zone_j
    assert n_in <= 144.73 and 144.73 + 2.29 ** 2 / 8.0 < n_out  # braking at 4 m/s^2, N would stop inside
    want = {"N": 1.39, "E": 0.0}  # [m/s^2]
    plans = {v: Plan.from_accelerations(s, speed, np.full(PROBLEM.steps, want[v]), PROBLEM.dt) for v, _p, s, speed in veh}
    slow = {"N": Plan.from_accelerations(144.73, 2.29, np.full(PROBLEM.steps, -0.5), PROBLEM.dt), "E": plans["E"]}
    for own, expect in ((plans, 1.39), (slow, GS.clear_accel)):
        d = Decisions(accel={v: float(own[v].accelerations[0]) for v in own})
        f.apply(world, relations, own, {}, d)
        assert d.accel["N"] == pytest.approx(expect) and d.accel["E"] == 0.0


def test_a_vehicle_read_back_before_its_line_while_standing_leaves_the_entry_queue(paths, movements,
                                                                                    conflict_table):
    """H, a human, waits at its stop line; over a noisy link its reading flickers across the line
    once (t = 1 s) before B enters the junction (t = 2 s). Read standing before its line again, H
    leaves the entry queue: B, standing in its crossing with H, is not held for H, who waits for
    it (demand_balanced_high at 0.36 m of noise: 58 of 117 vehicles locked behind such a pair).
    A vehicle read back before its line while moving keeps its place."""
    t = conflict_table
    p, q = _deepest_crossing(t)
    h_path, b_path = t.ids[p], t.ids[q]
    line = float(t.s_stop[p])  # [m]
    s_b = float(t.zone_in[q, p]) - 2.0  # [m] B in the junction, standing short of its zone with H
    assert s_b > t.s_stop[q]
    f = FilterUnderTest(GS, t.s_stop, 0.1)
    # [s], [m], [m/s]: H read creeping at 0.3 m/s (noise), below clear_speed
    for time, s_h, roles in ((1.0, line + 0.2, ["passing", "ready"]), (2.0, line - 0.1, ["ready", "passing"])):
        world = make_world(paths, time, [("H", h_path, s_h, 0.3), ("B", b_path, s_b, 0.0)])
        world.role, world.human = roles, np.array([True, False])
        f.record_entries(world)
    assert f.entered == {"B": 2.0}
    world.a = np.array([2.5, 0.0])  # [m/s^2] H read starting: its forecast enters the crossing
    plans = {"B": Plan.from_accelerations(s_b, 0.0, np.full(PROBLEM.steps, 1.0), PROBLEM.dt)}
    d = Decisions(accel={"B": 1.0})
    f.apply(world, _relations(world, movements, t), plans, {}, d)
    assert d.accel["B"] == pytest.approx(1.0)  # ranked behind B in the junction, H is SUMO's to hold
    moving = make_world(paths, 3.0, [("H", h_path, line - 0.1, 2.0), ("B", b_path, s_b, 0.0)])
    moving.role = ["passing", "passing"]
    f.record_entries(moving)
    moving.role = ["ready", "passing"]
    f.record_entries(moving)
    assert f.entered == {"B": 2.0, "H": 3.0}
