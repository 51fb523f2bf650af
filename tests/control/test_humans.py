"""Human drivers in the game controller: observed, predicted, never players, never capped."""

import dataclasses
import time

import numpy as np

from intersection_cosim.control.base import ControlContext, Decisions
from intersection_cosim.control.game.controller import GameController
from intersection_cosim.control.game.plan_memory import PlanMemory
from intersection_cosim.control.game.players import player
from intersection_cosim.control.game.relations import step_relations
from tests.control.conftest import FilterUnderTest
from intersection_cosim.control.game.settings import PolicySettings
from intersection_cosim.control.safety.settings import SafetySettings
from intersection_cosim.games.problem import Plan
from intersection_cosim.games.settings import ProblemSettings
from intersection_cosim.models.settings import ModelSettings
from tests.control.conftest import make_world

GS = SafetySettings()
PROBLEM = ProblemSettings()
MODEL = ModelSettings()
RANGE = PolicySettings().lane_choice_range  # [m]
LEFT = "west_inner_left_inner"  # eastbound, turning left to the north
STRAIGHT = "north_middle_straight_middle"  # southbound, straight on: the left turn crosses it


def _crossing_world(paths, t, human: bool, d_left: float = 16.0, d_straight: float = 17.5):
    """L (an AV) d_left [m] and S d_straight [m] before their crossing zones, both at 8 m/s;
    S a human driver or an AV."""
    p, q = t.index[LEFT], t.index[STRAIGHT]
    s_l, s_s = t.zone_in[p, q] - d_left, t.zone_in[q, p] - d_straight
    world = make_world(paths, 0.0, [("L", LEFT, s_l, 8.0), ("S", STRAIGHT, s_s, 8.0)])
    return dataclasses.replace(world, human=np.array([False, human])), s_l, s_s


def _filter(world, movements, t, plans, decisions):
    active = {k for k in range(len(world)) if not world.is_human(k)}
    rel = step_relations(world, active, movements, t, MODEL, True, {}, RANGE)
    f = FilterUnderTest(GS, t.s_stop, 0.1)
    return f.apply(world, rel, plans, {}, decisions), f


def test_an_av_yields_to_a_human_it_would_have_gone_before_if_it_were_an_av(paths, movements, conflict_table):
    """L reaches its zone 0.19 s before S. Against an AV S, L ranks first and keeps its plan
    (S yields); against a human S, which the filter cannot make yield, L brakes to stay out and
    nothing is commanded to S."""
    t = conflict_table
    hold = np.zeros(PROBLEM.steps)
    world, s_l, s_s = _crossing_world(paths, t, human=False)
    plans = {"L": Plan.from_accelerations(s_l, 8.0, hold, PROBLEM.dt), "S": Plan.from_accelerations(s_s, 8.0, hold, PROBLEM.dt)}
    d = Decisions(accel={"L": 0.0, "S": 0.0})
    _filter(world, movements, t, plans, d)
    assert d.accel["L"] == 0.0 and d.accel["S"] < 0.0  # AV against AV: S yields

    world, _, _ = _crossing_world(paths, t, human=True)
    d = Decisions(accel={"L": 0.0})
    held, f = _filter(world, movements, t, {"L": plans["L"]}, d)
    assert d.accel["L"] < -1.0 and held == {"L"}  # it stays out of the crossing
    assert "S" not in d.accel and f.filtered == 1


def test_an_av_in_the_junction_drives_on_when_the_human_can_still_stop(paths, movements, conflict_table):
    """L entered the junction first; a human S that can still stop before its crossing ranks behind
    it (SUMO makes it wait): L is not held. The same human, moving so fast that it cannot stop any
    more at |a_min|, ranks first: L is held."""
    t = conflict_table
    world, s_l, s_s = _crossing_world(paths, t, human=True, d_left=3.0, d_straight=30.0)
    world = dataclasses.replace(world, role=["passing", "ready"], v=np.array([4.0, 8.0]))
    hold = np.zeros(PROBLEM.steps)
    plan_l = Plan.from_accelerations(s_l, 4.0, hold, PROBLEM.dt)
    d = Decisions(accel={"L": 0.0})
    active = {0}
    rel = step_relations(world, active, movements, t, MODEL, True, {}, RANGE)
    f = FilterUnderTest(GS, t.s_stop, 0.1)
    f.record_entries(world)
    assert not f.human_committed(world, 1, float(t.zone_in[t.index[STRAIGHT], t.index[LEFT]]))
    f.apply(world, rel, {"L": plan_l}, {}, d)
    assert d.accel["L"] == 0.0  # the human waits, by SUMO's rules

    fast = dataclasses.replace(world, s=np.array([s_l, float(t.zone_in[t.index[STRAIGHT], t.index[LEFT]]) - 9.0]),
                               v=np.array([4.0, 9.0]))
    assert f.human_committed(fast, 1, float(t.zone_in[t.index[STRAIGHT], t.index[LEFT]]))  # 9 m < 0.9 + 10.1 m
    d = Decisions(accel={"L": 0.0})
    rel = step_relations(fast, active, movements, t, MODEL, True, {}, RANGE)
    f.apply(fast, rel, {"L": plan_l}, {}, d)
    assert d.accel["L"] < 0.0


def test_the_controller_never_decides_for_a_human_nor_plays_a_game_with_it(controller, paths, movements,
                                                                            conflict_table):
    """A human next to an AV on crossing paths: the AV gets an acceleration, the human none, no
    game has the human in it (the same pair of AVs plays one)."""
    t = conflict_table
    both_av, _, _ = _crossing_world(paths, t, human=False, d_left=14.0, d_straight=14.0)
    d = controller.decide(both_av, time.perf_counter() + 10.0)
    assert set(d.accel) == {"L", "S"} and d.games >= 1
    controller = GameController("nash")  # a fresh one: the first has S among its vehicles
    controller.setup(ControlContext(movements=movements, model=MODEL, control_period=0.1, settings=None, etm=True))
    mixed, _, _ = _crossing_world(paths, t, human=True, d_left=14.0, d_straight=14.0)
    d = controller.decide(mixed, time.perf_counter() + 10.0)
    assert set(d.accel) == {"L"} and d.games == 0 and not any("S" in p for p in d.pairs)
    assert "S" not in d.exit_lane and "S" not in d.release


def test_an_av_waits_at_its_stop_line_while_a_human_brakes_to_stop_in_its_crossing(paths, movements, conflict_table):
    """S (a human, 8 m/s, 5 m before its zone) is predicted never to brake, so it clears the crossing
    before L (an AV 18 m before its zone) arrives: L keeps its plan. The same S braking at 4.5 m/s^2
    will stop inside the crossing (SUMO holds it there): L is held to stop at its stop line, less the
    margin, instead of entering and stopping short of S inside the junction."""
    t = conflict_table
    world, s_l, s_s = _crossing_world(paths, t, human=True, d_left=18.0, d_straight=5.0)
    p, q = t.index[LEFT], t.index[STRAIGHT]
    assert s_s + 8.0 ** 2 / (2 * 4.5) < t.zone_out[q, p]  # braking, it stops in the crossing
    plans = {"L": Plan.from_accelerations(s_l, 8.0, np.zeros(PROBLEM.steps), PROBLEM.dt)}
    d = Decisions(accel={"L": 0.0})
    held, _ = _filter(world, movements, t, plans, d)
    assert d.accel["L"] == 0.0 and held == frozenset()

    braking = dataclasses.replace(world, a=np.array([0.0, -4.5]))
    d = Decisions(accel={"L": 0.0})
    held, _ = _filter(braking, movements, t, plans, d)
    stop_line = float(t.s_stop[p]) - GS.margin  # [m]
    assert stop_line > s_l
    assert np.isclose(d.accel["L"], -8.0 ** 2 / (2 * (stop_line - s_l))) and held == {"L"}
    assert d.accel["L"] > PROBLEM.a_min


def test_a_triggered_crossing_with_a_human_enters_the_avs_j_lat_with_the_humans_forecast(paths, movements,
                                                                                       conflict_table):
    """L (AV) and S (human) both 14 m before their zones at 8 m/s: the ETM fires, and L's player
    carries S as a crosser: S's forecast (8 m/s held: acceleration 0 measured) from its measured
    state, the conflict point on each path. Between two AVs the same pair is a game, no crosser."""
    t = conflict_table
    memory = PlanMemory(1, 0.1, PROBLEM.steps, PROBLEM.dt, PROBLEM.a_max, MODEL.v_max)
    for human in (True, False):
        world, s_l, s_s = _crossing_world(paths, t, human=human, d_left=14.0, d_straight=14.0)
        active = {k for k in range(len(world)) if not world.is_human(k)}
        rel = step_relations(world, active, movements, t, MODEL, True, {}, RANGE)
        opt = paths[LEFT].exit_lane
        crossers = player(world, 0, opt, rel, memory).crossers
        if not human:
            assert crossers == () and rel.triggered_pairs() == {(0, 1)}
            continue
        assert rel.triggered_pairs() == frozenset()  # no game with a human
        (s_own, s_h, s_pred, v_pred), = crossers
        p, q = t.index[LEFT], t.index[STRAIGHT]
        assert s_own == t.s_a[p, q] and s_h == t.s_a[q, p]
        np.testing.assert_allclose(v_pred, 8.0)
        np.testing.assert_allclose(s_pred, s_s + 8.0 * PROBLEM.dt * np.arange(1, PROBLEM.steps + 1))


def test_an_av_in_the_box_that_cannot_stay_out_of_a_humans_crossing_drives_out_instead_of_stopping_in_it(
        paths, movements, conflict_table):
    """The medium-demand incident (av_share 0.5, seed 1): an AV turning left is 4.1 m before its
    crossing with an oncoming human at 8.15 m/s (it needs 8.3 m to stop at |a_min| = 4 m/s^2); the
    human, 11.6 m before its zone at 9.3 m/s, can no longer stop either and ranks first. Braking
    hard would leave the AV standing in the human's way (SUMO's human brakes for it, then drives
    on into it): it drives out. 15 m before its zone it can still stop short of it, and does."""
    t = conflict_table
    left, straight = "south_inner_left_inner", "north_inner_straight_inner"
    p, q = t.index[left], t.index[straight]
    for to_zone, drives_out in ((4.1, True), (15.0, False)):
        s_av, s_h = t.zone_in[p, q] - to_zone, t.zone_in[q, p] - 11.6
        world = make_world(paths, 10.0, [("L", left, s_av, 8.15), ("H", straight, s_h, 9.3)])
        world = dataclasses.replace(world, human=np.array([False, True]), a=np.array([2.5, 1.7]),
                                    role=["passing", "ready"])
        plan = Plan.from_accelerations(s_av, 8.15, np.full(PROBLEM.steps, 0.5), PROBLEM.dt)
        d = Decisions(accel={"L": 0.5})
        active = {0}
        rel = step_relations(world, active, movements, t, MODEL, True, {}, RANGE)
        f = FilterUnderTest(GS, t.s_stop, 0.1)
        f.record_entries(world)
        f.apply(world, rel, {"L": plan}, {}, d)
        if drives_out:
            assert d.accel["L"] >= GS.clear_accel  # through, at least clear_accel
        else:
            assert d.accel["L"] < -1.0  # stops short of the crossing
        assert "H" not in d.accel


def test_an_av_waits_at_its_stop_line_while_a_human_may_be_held_at_its_waiting_position_in_its_crossing(
        paths, movements, conflict_table):
    """The high-demand lock (av_share 0.5, seed 1): a human turning left from the north (10 m/s,
    not braking yet) is 15 m before its waiting position, where SUMO holds it for the opposing
    stream; standing there its body is inside the crossing with an AV turning left from the west.
    The AV, 8 m before its stop line at 5.5 m/s, would still be in its zone when the human gets
    there: it stops at its stop line (less the margin) instead of entering and standing in the
    human's lane. The same AV 1 m before its stop line at 10 m/s, with the human 40 m back,
    clears its zone before the human arrives: not held. A filter that knows no waiting positions
    holds neither."""
    t = conflict_table
    human, av = "north_inner_left_middle", "west_inner_left_inner"
    h, k = t.index[human], t.index[av]
    s_wait = float(t.s_wait[h])
    assert t.zone_in[h, k] <= s_wait < t.zone_out[h, k]  # its waiting position is in the crossing
    stop_line = float(t.s_stop[k]) - GS.margin  # [m]
    for s_h, s_av, v_av, held_expected in ((s_wait - 15.0, stop_line - 7.0, 5.5, True),
                                           (s_wait - 40.0, float(t.s_stop[k]) - 1.0, 10.0, False)):
        world = make_world(paths, 10.0, [("L", av, s_av, v_av), ("H", human, s_h, 10.0)])
        world = dataclasses.replace(world, human=np.array([False, True]))
        plan = Plan.from_accelerations(s_av, v_av, np.zeros(PROBLEM.steps), PROBLEM.dt)
        rel = step_relations(world, {0}, movements, t, MODEL, True, {}, RANGE)
        for s_wait_known in (t.s_wait, None):
            d = Decisions(accel={"L": 0.0})
            held = FilterUnderTest(GS, t.s_stop, 0.1, s_wait_known).apply(world, rel, {"L": plan}, {}, d)
            if held_expected and s_wait_known is not None:
                assert held == {"L"} and np.isclose(d.accel["L"], -v_av ** 2 / (2 * 7.0))  # stops at its line
            else:
                assert held == frozenset() and d.accel["L"] == 0.0


def test_a_human_at_its_waiting_position_may_start_against_the_streams_its_junction_does_not_watch(
        paths, movements, conflict_table):
    """A human stands at its waiting position turning left from the north. SUMO's internal
    junction there watches the opposing (south) approach lanes only, so SUMO may release it
    while an AV comes straight on from the east: that AV, 12 m before its line at 10 m/s, brakes
    to stop human_margin before their crossing (it cannot make its line any more). An AV from
    the south, which SUMO holds the human for, keeps its speed. A filter that does not know the
    net's waiting positions brakes neither."""
    from intersection_cosim.network.waiting import waiting_watches

    t = conflict_table
    human = "north_inner_left_middle"
    watches = waiting_watches(movements)
    assert watches[human] == {"south_in_0", "south_in_1", "south_in_2"}
    waits = {pid: (paths[pid].s_wait, lanes) for pid, lanes in watches.items()}
    h = t.index[human]
    for other, brakes in (("east_inner_straight_inner", True), ("south_inner_straight_inner", False)):
        k = t.index[other]
        s_av = float(t.s_stop[k]) - 12.0  # [m]
        world = make_world(paths, 10.0, [("H", human, float(t.s_wait[h]) - 0.1, 0.0), ("A", other, s_av, 10.0)])
        world = dataclasses.replace(world, human=np.array([True, False]), role=["passing", "ready"])
        plan = Plan.from_accelerations(s_av, 10.0, np.zeros(PROBLEM.steps), PROBLEM.dt)
        rel = step_relations(world, {1}, movements, t, MODEL, True, {}, RANGE)
        for known in (waits, None):
            f = FilterUnderTest(GS, t.s_stop, 0.1, t.s_wait, known)
            f.record_entries(world)
            d = Decisions(accel={"A": 0.0})
            held = f.apply(world, rel, {"A": plan}, {}, d)
            if brakes and known is not None:
                to_zone = float(t.zone_in[k, h]) - GS.human_margin - s_av  # [m]
                assert held == {"A"} and np.isclose(d.accel["A"], -10.0 ** 2 / (2 * to_zone))
            else:
                assert held == frozenset() and d.accel["A"] == 0.0
