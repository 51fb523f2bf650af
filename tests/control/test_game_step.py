"""The game controller's step: crossings guarded until cleared, the anytime step, solo re-planning."""

import dataclasses
import time

import numpy as np
import pytest

from intersection_cosim.control.game import solo as solo_module
from intersection_cosim.games import solo_batch
from intersection_cosim.network.movements import paper_movements
from intersection_cosim.control.base import ControlContext
from intersection_cosim.control.game.controller import GameController
from intersection_cosim.control.game.plan_memory import GameKey, PlanMemory
from intersection_cosim.control.game.players import leader_trajectory
from intersection_cosim.control.game.relations import step_relations
from intersection_cosim.control.safety.kinematics import occupancy
from intersection_cosim.control.game.settings import GameControllerSettings, PolicySettings
from intersection_cosim.control.safety.settings import SafetySettings
from intersection_cosim.models.settings import ModelSettings
from tests.control.conftest import make_world

LEFT = "west_inner_left_inner"  # eastbound, turning left to the north
STRAIGHT = "north_middle_straight_middle"  # southbound, straight on: the left turn crosses it


def _world(paths, t, vehicles):
    """vehicles: (id, path id, s [m], v [m/s])."""
    return make_world(paths, t, vehicles)


def _nash_controller(paths, net_file, model: ModelSettings | None = None,
                     settings: GameControllerSettings | None = None) -> GameController:
    """A Nash controller on the default net (ETM on, 0.1 s period), like the ``controller``
    fixture but with the given model and controller settings."""
    c = GameController("nash")
    c.setup(ControlContext(movements=paper_movements(net_file), model=model or ModelSettings(),
                           control_period=0.1, settings=settings, etm=True))
    return c


def test_a_crossing_is_guarded_until_the_turning_body_has_cleared_it(controller, paths):
    """The crossing whose zone reaches farthest past its point: the first vehicle stands
    0.5 m past conflict_clearance (4.5 m), so no game any more, but its body still covers the
    other's lane for a few metres. The second, planning to drive on at 8 m/s and 1.5 s from the
    zone, must be braked by the safety filter to stop before it."""
    t = controller.table
    past = np.where(t.kind == 2, t.zone_out - t.s_a, -np.inf)
    p, q = np.unravel_index(int(np.argmax(past)), past.shape)
    first, second = t.ids[p], t.ids[q]
    s_first = t.s_a[p, q] + controller.model.conflict_clearance + 0.5
    assert t.zone_out[p, q] - s_first > 2.5  # [m] still to go before its body is out
    s_second = t.zone_in[q, p] - 12.0
    world = _world(paths, 0.0, [("A", first, s_first, 0.0), ("B", second, s_second, 8.0)])
    world.role[0] = "passing"
    d = controller.decide(world, time.perf_counter() + 10.0)
    assert d.games == 0
    margin = controller.settings.safety.margin
    assert d.accel["B"] == pytest.approx(-8.0 ** 2 / (2 * (12.0 - margin)), rel=1e-6)  # -2.9 m/s^2


def test_without_time_left_games_are_deferred_and_the_last_plans_kept(controller, paths):
    t = controller.table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    world = _world(paths, 1.0, [("L", LEFT, t.s_a[p, q] - 16.0, 8.0), ("S", STRAIGHT, t.s_a[q, p] - 17.0, 8.0)])
    d = controller.decide(world, time.perf_counter() + 10.0)
    assert d.games == 1 and d.deferred == 0
    planned = {v: controller.memory.plans[v] for v in ("L", "S")}
    # next period, moved as planned, but the deadline has already passed: nothing is solved
    s_next = [float(planned[v].positions[1]) for v in ("L", "S")]
    v_next = [float(planned[v].speeds[1]) for v in ("L", "S")]
    world = _world(paths, 1.1, [("L", LEFT, s_next[0], v_next[0]), ("S", STRAIGHT, s_next[1], v_next[1])])
    filtered = controller.diagnostics().safety_interventions
    d = controller.decide(world, time.perf_counter() - 1.0)
    assert d.games == 0 and d.deferred == 1
    for v in ("L", "S"):
        kept = float(planned[v].accelerations[1])  # the plan shifted by one period
        assert d.accel[v] <= kept + 1e-12
    assert controller.diagnostics().safety_interventions > filtered or all(
        d.accel[v] == pytest.approx(float(planned[v].accelerations[1])) for v in ("L", "S"))


LANE = "south_middle_straight_middle"  # northbound, straight on: a leader and its follower


def _watch_solo_solves(monkeypatch, seen) -> None:
    """Call ``seen(problem, result)`` for every solo problem the controller solves from now on
    (they are solved in batches: games.solo_batch.solo_responses)."""
    real = solo_batch.solo_responses  # the solver itself, never a watcher installed before

    def watching(problems, *a, **k):
        results = real(problems, *a, **k)
        for problem, result in zip(problems, results):
            seen(problem, result)
        return results

    monkeypatch.setattr(solo_module, "solo_responses", watching)


def _count_solo_solves(monkeypatch) -> list[str]:
    """The names of the players of every solo solve the controller makes from now on."""
    calls = []
    _watch_solo_solves(monkeypatch, lambda problem, result: calls.append(problem.players[0].name))
    return calls


def test_a_solo_follower_solves_again_only_when_its_leader_prediction_moves(controller, paths, monkeypatch):
    calls = _count_solo_solves(monkeypatch)
    s_stop = paths[LANE].s_stop

    def world_at(t, s_lead, v_lead, s_follow, v_follow):
        return _world(paths, t, [("lead", LANE, s_lead, v_lead), ("follow", LANE, s_follow, v_follow)])

    def as_planned(t, lead_slower=0.0):
        """Both vehicles where their plans put them one period on; the leader ``lead_slower``
        [m/s] slower than planned."""
        lead, follow = controller.memory.plans["lead"], controller.memory.plans["follow"]
        return world_at(t, float(lead.positions[1]), float(lead.speeds[1]) - lead_slower,
                        float(follow.positions[1]), float(follow.speeds[1]))

    d = controller.decide(world_at(0.0, s_stop - 60.0, 8.0, s_stop - 80.0, 8.0), time.perf_counter() + 10.0)
    assert d.games == 0 and calls.count("follow") == 1
    # solo vehicles are solved together (Jacobi): at step 0 the follower saw its leader coasting,
    # at step 1 it sees the leader's first plan, a moved prediction -> it solves again
    controller.decide(as_planned(0.1), time.perf_counter() + 10.0)
    assert calls.count("follow") == 2
    # both moved exactly as planned: the follower's problem is the same one, later -> reused
    controller.decide(as_planned(0.2), time.perf_counter() + 10.0)
    assert calls.count("follow") == 2
    # the leader is suddenly 2 m/s slower than its plan said: its prediction moved -> solve again
    controller.decide(as_planned(0.3, lead_slower=2.0), time.perf_counter() + 10.0)
    assert calls.count("follow") == 3


def _deepest_crossing(t):
    past = np.where(t.kind == 2, t.zone_out - t.s_a, -np.inf)
    p, q = np.unravel_index(int(np.argmax(past)), past.shape)
    return int(p), int(q)


def test_a_vehicle_before_the_junction_waits_at_its_stop_line(controller, paths):
    """The first vehicle stands in the crossing (it needs about 2.5 s to clear it from rest); the
    second, 10 m before its stop line at 8 m/s, would arrive before that: it brakes to stop at
    the line (less the margin), not at its zone inside the junction, where it could block
    another crossing."""
    t = controller.table
    p, q = _deepest_crossing(t)
    first, second = t.ids[p], t.ids[q]
    s_stop = float(t.s_stop[q])
    assert t.zone_in[q, p] > s_stop  # the zone lies inside the junction
    world = _world(paths, 0.0, [("A", first, t.s_a[p, q], 0.0), ("B", second, s_stop - 10.0, 8.0)])
    world.role[0] = "passing"
    d = controller.decide(world, time.perf_counter() + 10.0)
    margin = controller.settings.safety.margin
    assert d.accel["B"] == pytest.approx(-8.0 ** 2 / (2 * (10.0 - margin)), rel=1e-6)  # -3.6 m/s^2


def test_two_vehicles_stopped_in_each_others_zones_do_not_drive_off_together(controller, paths):
    """Both stand inside the crossing (neither can stop before it any more) and both plans drive
    off: exactly one is held in place, the other clears the crossing."""
    t = controller.table
    p, q = _deepest_crossing(t)
    a_path, b_path = t.ids[p], t.ids[q]
    s_a = 0.5 * (t.zone_in[p, q] + t.s_a[p, q])
    s_b = 0.5 * (t.zone_in[q, p] + t.s_a[q, p])
    world = _world(paths, 0.0, [("A", a_path, s_a, 0.0), ("B", b_path, s_b, 0.0)])
    world.role = ["passing", "passing"]
    d = controller.decide(world, time.perf_counter() + 10.0)
    moving = sorted(v for v in ("A", "B") if d.accel[v] > 1e-9)
    held = sorted(v for v in ("A", "B") if abs(d.accel[v]) <= 1e-9)
    assert len(moving) == 1 and len(held) == 1, d.accel


def test_a_vehicle_that_left_the_junction_still_guards_its_rear(controller, paths):
    """S's front has passed the junction exit (SUMO drives it again, no plan of ours), but its
    rear is still in the crossing: E, standing before its zone with a plan to drive off, must
    wait (a collision at 1800 veh/h unbalanced, seed 2, t = 97.45 s)."""
    t = controller.table
    cross = np.argwhere((t.kind == 2) & (t.zone_out > t.s_exit[:, None] + 1.0))
    q, p = (int(x) for x in cross[0])  # S on path q, E on path p
    s_path, e_path = t.ids[q], t.ids[p]
    s_s = float(t.s_exit[q]) + 0.5  # front just out of the junction
    assert s_s < t.zone_out[q, p]
    s_e = float(t.zone_in[p, q]) - 1.0
    world = _world(paths, 3.0, [("E", e_path, s_e, 0.0), ("S", s_path, s_s, 5.0)])
    world.role = ["passing" if s_e > t.s_stop[p] else "ready", "outside"]
    d = controller.decide(world, time.perf_counter() + 10.0)
    assert "S" not in d.accel
    assert d.accel["E"] <= 1e-9


def test_a_leader_on_a_parting_path_stops_counting_past_the_shared_stretch(controller, paths):
    """Two left turns from one approach lane, to the inner and to the middle exit lane (Case 2's
    V4 and V3). The leader drives slowly 8 m ahead. Its predicted positions count for the
    follower only while its rear is on the shared stretch: past it, a follower on the other
    branch is free (far away), one on the same branch is not."""
    t = controller.table
    inner, middle = "north_inner_left_inner", "north_inner_left_middle"
    p, q = t.index[inner], t.index[middle]
    assert t.kind[p, q] == 1  # following: they share the approach lane
    end = float(t.s_a[p, q])  # [m] where the two centre lines are a vehicle width apart
    s_lead = end - 2.0
    for follower_path, parted in ((middle, True), (inner, False)):
        world = _world(paths, 0.0, [("LEAD", inner, s_lead, 4.0), ("F", follower_path, s_lead - 8.0, 8.0)])
        relations = step_relations(world, {0, 1}, controller.ctx.movements, controller.table, controller.model, True, {},
                                   30.0)
        lead = relations.leader_of(1, world.exit_choices["F"][0])
        assert lead.vehicle == 0
        s_pred, _v = leader_trajectory(world, lead, PlanMemory(1, 0.1, 30, 0.1, 2.5, 13.89))  # no plans: coasting
        clear_at = end + controller.model.conflict_clearance  # [m] its rear past the end
        beyond = s_pred > clear_at
        assert beyond.any() and not beyond.all()  # it gets there within the horizon
        coasting = s_lead + 4.0 * 0.1 * np.arange(1, 31)  # [m] constant 4 m/s
        if parted:
            assert np.all(s_pred[beyond] > coasting[beyond] + 1e3)
            assert np.allclose(s_pred[~beyond], coasting[~beyond])
        else:
            assert np.allclose(s_pred, coasting)


def test_a_leader_prediction_that_moved_where_j_log_is_zero_does_not_trigger_a_solve(controller, paths,
                                                                                     monkeypatch):
    """The follower is slower than its leader all along its plan (J_log is zero); the leader then
    drives 1 m/s faster than its plan said. Its prediction moved by far more than
    solo_leader_tol, but only away from the follower: the follower's problem is unchanged where
    it has a cost, so its plan is reused, shifted."""
    calls = _count_solo_solves(monkeypatch)
    s_stop = paths[LANE].s_stop

    def world_at(t, s_lead, v_lead, s_follow, v_follow):
        return _world(paths, t, [("lead", LANE, s_lead, v_lead), ("follow", LANE, s_follow, v_follow)])

    controller.decide(world_at(0.0, s_stop - 60.0, 12.0, s_stop - 80.0, 7.0), time.perf_counter() + 10.0)
    assert calls.count("follow") == 1
    lead, follow = controller.memory.plans["lead"], controller.memory.plans["follow"]
    assert np.all(follow.speeds < lead.speeds)  # never closing in: J_log is zero along the plan
    w = world_at(0.1, float(lead.positions[1]), float(lead.speeds[1]) + 1.0,
                 float(follow.positions[1]), float(follow.speeds[1]))
    controller.decide(w, time.perf_counter() + 10.0)
    assert calls.count("follow") == 1  # reused
    # a leader that drops below the follower's planned speed makes J_log active: solve again
    lead, follow = controller.memory.plans["lead"], controller.memory.plans["follow"]
    w = world_at(0.2, float(lead.positions[1]), float(follow.speeds[1]) - 2.0,
                 float(follow.positions[1]), float(follow.speeds[1]))
    controller.decide(w, time.perf_counter() + 10.0)
    assert calls.count("follow") == 2


def test_a_capped_solo_solve_goes_on_at_the_next_period(paths, net_file, monkeypatch):
    """Real-time iteration: with solo_max_iter = 1 a follower closing fast on a slow leader does
    not converge in one SQP step; it applies that plan and solves again (from it) at the next
    period, until it has converged: a step that moved its plan less than nash_tol (with
    solo_reuse_residual 0, so that nash_tol alone decides)."""

    c = _nash_controller(paths, net_file, settings=GameControllerSettings(
        policy=PolicySettings(solo_max_iter=1, solo_reuse_residual=0.0)))
    solves = []  # (control step, status, iterations) of the follower's solo solves
    step = 0

    def recording(problem, result):
        if problem.players[0].name == "follow":
            moved = result.residuals[-1] if result.residuals else 0.0
            solves.append((step, "converged" if result.status == "converged" or moved < c.settings.solver.nash_tol
                           else result.status, result.iterations))

    _watch_solo_solves(monkeypatch, recording)
    path = LANE
    s_stop = paths[path].s_stop
    world = _world(paths, 0.0, [("lead", path, s_stop - 60.0, 3.0), ("follow", path, s_stop - 75.0, 9.0)])
    for step in range(12):  # converged at step 8 (it sees its leader's plans one period late)
        c.decide(world, time.perf_counter() + 10.0)
        lead, follow = c.memory.plans["lead"], c.memory.plans["follow"]
        world = _world(paths, 0.1 * (step + 1), [
            ("lead", path, float(lead.positions[1]), float(lead.speeds[1])),
            ("follow", path, float(follow.positions[1]), float(follow.speeds[1]))])
    assert solves[0] == (0, "iteration cap", 1)  # one SQP step, not converged, applied
    assert all(it == 1 for _, _, it in solves)  # never more than solo_max_iter per period
    assert any(st == "converged" for _, st, _ in solves)
    steps = [n for n, _, _ in solves]
    for n, st, _ in solves[:-1]:
        if st != "converged":
            assert n + 1 in steps  # an unconverged plan is never reused: the next period solves
    last = max(n for n, st, _ in solves if st == "converged")
    assert last + 1 not in steps  # a converged one is reused


@pytest.mark.parametrize("order", ["tcp", "plan"])
def test_yield_order_decides_who_waits_at_a_crossing(paths, net_file, order):
    """Case 1 A in miniature: A is nearer its crossing in time at its current speed (tcp), B is
    slower but its plan accelerates harder and reaches the crossing first (plan). With the
    default order ("tcp", the paper's leader rule) B waits at its stop line; with "plan", A does."""
    # the trigger off (gamma_sf huge): no game, only the solo plans and the filter decide
    model = ModelSettings(gamma_sf=1e12)
    c = _nash_controller(paths, net_file, model, GameControllerSettings(safety=SafetySettings(yield_order=order)))
    t = c.table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    zone_a, zone_b = float(t.zone_in[p, q]), float(t.zone_in[q, p])
    # A: 14 m from its zone at 7 m/s (2.0 s); B: 9 m from its zone at 4 m/s (2.25 s), but B's
    # solo plan accelerates from far below v_max and gets there first within the horizon
    world = _world(paths, 0.0, [("A", LEFT, zone_a - 14.0, 7.0), ("B", STRAIGHT, zone_b - 9.0, 4.0)])
    world.kappa[:] = (0.1, 1.0)
    d = c.decide(world, time.perf_counter() + 10.0)
    assert d.games == 0
    plan_a, plan_b = c.memory.plans["A"], c.memory.plans["B"]
    t_a, t_b = occupancy(plan_a, zone_a, zone_a + 1.0)[0], occupancy(plan_b, zone_b, zone_b + 1.0)[0]
    assert t_b < t_a  # by the plans, B is first ...
    assert 14.0 / 7.0 < 9.0 / 4.0  # ... by the current speeds, A is
    waits = "B" if order == "tcp" else "A"
    goes = "A" if waits == "B" else "B"
    assert d.accel[waits] < 0.0 < d.accel[goes]
    assert d.accel[goes] == pytest.approx(float(c.memory.plans[goes].accelerations[0]))  # not filtered


def _weak_lateral_controller(paths, net_file):
    """A Nash controller whose games weigh J_lat lightly (k_lat = 1): their plans pass a crossing
    closer than time_gap, which the filter must then enforce (at the default k_lat the
    yielding player already brakes at a_min in its equilibrium plan). The pair keeps the whole
    gap (game_gap_share 1): at the default share its plans would be far enough apart."""
    full_gap = GameControllerSettings(safety=SafetySettings(game_gap_share=1.0))
    return _nash_controller(paths, net_file, ModelSettings(k_lat=1.0), full_gap)


def _pair_a_game_lets_pass_first(paths, net_file):
    """A (left turn, 8 m from its zone at 4 m/s) and B (straight on, 12 m at 7 m/s), whose game
    lets A pass first; returns the controller, the world and the two zones [m]."""
    controller = _weak_lateral_controller(paths, net_file)
    t = controller.table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    zone_a = (float(t.zone_in[p, q]), float(t.zone_out[p, q]))
    zone_b = (float(t.zone_in[q, p]), float(t.zone_out[q, p]))
    world = _world(paths, 0.0, [("A", LEFT, zone_a[0] - 8.0, 4.0), ("B", STRAIGHT, zone_b[0] - 12.0, 7.0)])
    world.kappa[:] = (0.8, 0.85)  # both bold: the game has them enter 0.01 s apart, A first
    return controller, world, zone_a, zone_b


def test_the_filter_enforces_a_games_passing_order_instead_of_overruling_it(paths, net_file):
    """B is nearer the crossing in time at its current speed (1.71 s against A's 2.0 s), but the
    pair's game lets A pass first, and its plans still pass within time_gap. The filter
    keeps the game's order (for a pair without a game it would rank B first): A drives its
    equilibrium plan, B brakes below its own."""
    controller, world, zone_a, zone_b = _pair_a_game_lets_pass_first(paths, net_file)
    d = controller.decide(world, time.perf_counter() + 10.0)
    assert d.games == 1
    plan_a, plan_b = controller.memory.plans["A"], controller.memory.plans["B"]
    (in_a, out_a), (in_b, _) = occupancy(plan_a, *zone_a), occupancy(plan_b, *zone_b)
    assert 12.0 / 7.0 < 8.0 / 4.0 and in_a < in_b  # TCP order B, A; the game's order A, B
    assert in_b < out_a + controller.settings.safety.time_gap  # too close: the filter must order them
    assert d.accel["A"] == pytest.approx(float(plan_a.accelerations[0]))  # A goes as the game says
    assert d.accel["B"] < float(plan_b.accelerations[0]) - 1.0  # B is held back


def test_a_vehicle_inside_the_junction_keeps_its_queue_priority_against_a_game(paths, net_file):
    """As above, but B (whose game lets A pass first) entered the junction already. The queue
    rule (first in, first out) outranks the game's order: letting the game's order win lets A
    into a crossing ahead of a vehicle that entered before it, and when the pair's trigger goes
    off the queue order returns with both committed (at 1800 veh/h that closed a cycle of waits
    through the queues behind them). A waits, B drives its plan."""
    controller, world, zone_a, zone_b = _pair_a_game_lets_pass_first(paths, net_file)
    world.role[1] = "passing"
    d = controller.decide(world, time.perf_counter() + 10.0)
    assert d.games == 1 and "B" in controller.safety.entered
    plan_a, plan_b = controller.memory.plans["A"], controller.memory.plans["B"]
    (in_a, out_a), (in_b, _) = occupancy(plan_a, *zone_a), occupancy(plan_b, *zone_b)
    assert in_a < in_b < out_a + controller.settings.safety.time_gap  # the game's order, too close
    assert d.accel["B"] == pytest.approx(float(plan_b.accelerations[0]))  # B goes: it is inside
    assert d.accel["A"] < float(plan_a.accelerations[0]) - 1.0  # A waits against its game's plan


def test_a_new_game_starts_from_the_plans_its_players_drive(controller, paths, monkeypatch):
    """A game with no usable plans of its own (its last solve older than half the horizon)
    starts from the plans its players drive, shifted by one period."""
    t = controller.table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    zone_a, zone_b = float(t.zone_in[p, q]), float(t.zone_in[q, p])
    world = _world(paths, 0.0, [("A", LEFT, zone_a - 8.0, 4.0), ("B", STRAIGHT, zone_b - 12.0, 7.0)])
    assert controller.decide(world, time.perf_counter() + 10.0).games == 1
    (key,) = [k for k in controller.memory.keys() if isinstance(k, GameKey)]
    too_late = _world(paths, 2.0, [("A", LEFT, zone_a - 2.0, 4.0), ("B", STRAIGHT, zone_b - 2.0, 7.0)])
    assert controller.memory.warm_start(key, too_late.time) is None  # 20 periods > half of 30 steps
    starts = []
    real = controller.solver.equilibrium
    recording = lambda problem, *a, warm_start=None, **k: (  # noqa: E731
        starts.append(warm_start), real(problem, *a, warm_start=warm_start, **k))[1]
    monkeypatch.setattr(controller, "solver", dataclasses.replace(controller.solver, equilibrium=recording))
    driven = {v: controller.memory.shifted(controller.memory.plans[v]) for v in ("A", "B")}
    controller.decide(too_late, time.perf_counter() + 10.0)
    assert len(starts) == 1 and starts[0] is not None
    for v, plan in zip(("A", "B"), starts[0]):
        assert np.allclose(plan.accelerations, driven[v].accelerations)


def test_a_vehicle_the_filter_holds_keeps_its_solo_plan_until_it_is_due(paths, net_file, monkeypatch):
    """A vehicle the safety filter held back is off its own plan by the filter's doing, not
    because its problem changed: it keeps its plan (re-anchored at its measured state) instead
    of solving again every period, until free_resolve_steps is due; one that left its plan
    without being held solves again at once."""
    calls = _count_solo_solves(monkeypatch)
    model = ModelSettings(gamma_sf=1e12)  # no game: the solo plans and the filter decide
    # (nor does the filter's hold make the pair play: PolicySettings.filter_event off)
    no_event = GameControllerSettings(policy=PolicySettings(filter_event=False))
    c = _nash_controller(paths, net_file, model, no_event)
    t = c.table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    zone_a, zone_b = float(t.zone_in[p, q]), float(t.zone_in[q, p])

    def step(time_s, s_a, v_a, s_b, v_b):
        w = _world(paths, time_s, [("A", LEFT, s_a, v_a), ("B", STRAIGHT, s_b, v_b)])
        return c.decide(w, time.perf_counter() + 10.0)

    d = step(0.0, zone_a - 14.0, 7.0, zone_b - 9.0, 4.0)  # as in the yield_order test: B waits
    assert d.games == 0 and d.accel["B"] < float(c.memory.plans["B"].accelerations[0]) - 1.0
    assert calls.count("B") == 1
    for n in range(1, 6):  # B follows the filter's braking, A its own plan
        a, b = c.memory.plans["A"], c.memory.plans["B"]
        v_b = max(float(b.speeds[0]) + d.accel["B"] * 0.1, 0.0)
        s_b = float(b.positions[0]) + 0.5 * (float(b.speeds[0]) + v_b) * 0.1
        d = step(0.1 * n, float(a.positions[1]), float(a.speeds[1]), s_b, v_b)
        assert d.accel["B"] < float(c.memory.plans["B"].accelerations[0]), n  # still held
    # reused for free_resolve_steps - 1 periods, then solved again
    assert calls.count("B") == 1 + 6 // c.settings.policy.free_resolve_steps
    # A pushed off its plan (not by the filter) solves again at once
    before = calls.count("A")
    a = c.memory.plans["A"]
    step(0.6, float(a.positions[1]), float(a.speeds[1]) - 1.0, s_b, v_b)
    assert calls.count("A") == before + 1



@pytest.mark.parametrize("event", [True, False])
def test_a_pair_the_filter_held_plays_its_game_from_the_next_step(paths, net_file, event):
    """PolicySettings.filter_event: Gamma_cp never fires (Gamma_sf huge), so the first step has
    no game and the filter holds B back for A; from the next step the pair plays its game (and
    keeps playing it), so its margin comes from the game's trade-off; with the event off it
    never does."""
    model = ModelSettings(gamma_sf=1e12)
    c = _nash_controller(paths, net_file, model, GameControllerSettings(policy=PolicySettings(filter_event=event)))
    t = c.table
    zone_a, zone_b = float(t.zone_in[t.index[LEFT], t.index[STRAIGHT]]), float(t.zone_in[t.index[STRAIGHT], t.index[LEFT]])
    w = _world(paths, 0.0, [("A", LEFT, zone_a - 14.0, 7.0), ("B", STRAIGHT, zone_b - 9.0, 4.0)])
    d = c.decide(w, time.perf_counter() + 10.0)
    assert d.games == 0 and d.accel["B"] < float(c.memory.plans["B"].accelerations[0]) - 1.0  # held
    games = []
    for n in (1, 2):
        w = _world(paths, 0.1 * n, [("A", LEFT, zone_a - 14.0 + 0.7 * n, 7.0), ("B", STRAIGHT, zone_b - 9.0 + 0.35 * n, 3.5)])
        games.append(c.decide(w, time.perf_counter() + 10.0).pairs)
    assert games == ([[("A", "B")], [("A", "B")]] if event else [[], []])

@pytest.mark.parametrize("slow", [True, False])
def test_a_filter_event_ends_for_a_pair_that_crawls_inside_the_box(paths, net_file, slow):
    """PolicySettings.filter_event keeps a held pair's game on; once both are in the junction
    and one of them is slower than clear_speed (1 m/s) the event is dropped, so the forced game
    cannot keep two vehicles in the box planning to crawl for each other (that locked
    demand_balanced_high, stackelberg, seed 7: 40 of 123 arrived with game_gap_share 0.4; with
    the event alone 13 vehicles stood in the box at 150 s). Both still at speed, it plays on."""
    model = ModelSettings(gamma_sf=1e12)  # Gamma_cp never fires: only the event makes the pair play
    c = _nash_controller(paths, net_file, model, GameControllerSettings(policy=PolicySettings(filter_event=True)))
    t = c.table
    zone_a, zone_b = float(t.zone_in[t.index[LEFT], t.index[STRAIGHT]]), float(t.zone_in[t.index[STRAIGHT], t.index[LEFT]])
    w = _world(paths, 0.0, [("A", LEFT, zone_a - 14.0, 7.0), ("B", STRAIGHT, zone_b - 9.0, 4.0)])
    c.decide(w, time.perf_counter() + 10.0)  # the filter holds B back for A: the event
    s_in = (paths[LEFT].s_stop + 0.5, paths[STRAIGHT].s_stop + 0.5)  # [m] just past their stop lines
    assert s_in[0] < zone_a and s_in[1] < zone_b  # in the junction, not yet in the crossing
    v_b = 0.5 if slow else 3.0  # [m/s]
    games = []
    for n in (1, 2, 3):
        w = _world(paths, 0.1 * n, [("A", LEFT, s_in[0] + 0.1 * n, 2.0), ("B", STRAIGHT, s_in[1] + 0.05 * n, v_b)])
        w.role = ["passing", "passing"]
        games.append(c.decide(w, time.perf_counter() + 10.0).pairs)
    # the first step in the box still plays (the event came from the approach); then it ends if B crawls
    assert games == ([[("A", "B")], [], []] if slow else [[("A", "B")]] * 3)


@pytest.mark.parametrize("hold", [True, False])
def test_a_pair_whose_entrant_waits_for_a_stalled_box_stops_its_forced_game(paths, net_file, hold):
    """The filter's event makes A and B play (Gamma_cp never fires). Then B stands in the
    junction short of their crossing and A nears its stop line: SafetySettings.stalled_box_hold
    keeps A at its line, and from the next step the pair no longer plays: A must wait whatever
    the game says (in a jam such games were a third of the QPs). Without the hold the event
    keeps the game on."""
    model = ModelSettings(gamma_sf=1e12)
    settings = GameControllerSettings(policy=PolicySettings(filter_event=True),
                                      safety=SafetySettings(stalled_box_hold=hold))
    c = _nash_controller(paths, net_file, model, settings)
    t = c.table
    zone_a, zone_b = float(t.zone_in[t.index[LEFT], t.index[STRAIGHT]]), float(t.zone_in[t.index[STRAIGHT], t.index[LEFT]])
    w = _world(paths, 0.0, [("A", LEFT, zone_a - 14.0, 7.0), ("B", STRAIGHT, zone_b - 9.0, 4.0)])
    c.decide(w, time.perf_counter() + 10.0)  # the filter holds B back for A: the event
    s_b = paths[STRAIGHT].s_stop + 0.5  # [m] B in the junction, short of its zone
    s_a = paths[LEFT].s_stop - 4.0  # [m] A 4 m before its stop line at 3 m/s
    assert s_b < zone_b
    games, accel = [], []
    for n in (1, 2, 3):
        w = _world(paths, 0.1 * n, [("A", LEFT, s_a + 0.1 * n, 3.0), ("B", STRAIGHT, s_b, 0.0)])
        w.role = ["ready", "passing"]
        d = c.decide(w, time.perf_counter() + 10.0)
        games.append(d.pairs)
        accel.append(d.accel["A"])
    if hold:
        assert games == [[("A", "B")], [], []]  # the event's game at once, then none
        assert max(accel) < -0.5  # A stops at its line (about -1.3 m/s^2 over 3.5 m)
    else:
        assert games == [[("A", "B")]] * 3


def test_a_step_reports_the_qps_it_solved(controller, paths, monkeypatch):
    """Decisions.qp_solves (steps.csv's load-free measure of the work) is the number of QPs the
    step solved: one per SQP step of every best response of its games and solo vehicles."""
    from intersection_cosim.games import qp as qp_module

    calls = []
    real = qp_module.QPWorkspace.solve
    monkeypatch.setattr(qp_module.QPWorkspace, "solve", lambda self, *a, **k: (calls.append(1), real(self, *a, **k))[1])
    t = controller.table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    world = _world(paths, 1.0, [("L", LEFT, t.s_a[p, q] - 16.0, 8.0), ("S", STRAIGHT, t.s_a[q, p] - 17.0, 8.0)])
    d = controller.decide(world, time.perf_counter() + 10.0)
    assert d.games == 1 and d.iterations >= 1
    assert d.qp_solves == len(calls) >= 2 * d.iterations  # two players' best responses per iteration
    world.role = ["outside", "outside"]
    assert controller.decide(world, time.perf_counter() + 10.0).qp_solves == 0


def test_a_solo_vehicle_displaced_from_its_plan_beyond_solo_position_tol_solves_again(paths, net_file,
                                                                                        monkeypatch):
    """The reuse test compares the measured position with the shifted plan's: within
    solo_position_tol (0.5 m) the plan is kept (re-anchored), beyond it the vehicle solves again."""
    calls = _count_solo_solves(monkeypatch)
    c = _nash_controller(paths, net_file)
    tol = c.settings.policy.solo_position_tol  # [m]
    s_stop = paths[LANE].s_stop

    def step(t, offset):
        """Both vehicles where their plans put them, the follower ``offset`` [m] ahead of it."""
        lead, follow = c.memory.plans["lead"], c.memory.plans["follow"]
        w = _world(paths, t, [("lead", LANE, float(lead.positions[1]), float(lead.speeds[1])),
                              ("follow", LANE, float(follow.positions[1]) + offset, float(follow.speeds[1]))])
        c.decide(w, time.perf_counter() + 10.0)

    c.decide(_world(paths, 0.0, [("lead", LANE, s_stop - 60.0, 8.0), ("follow", LANE, s_stop - 80.0, 8.0)]),
             time.perf_counter() + 10.0)
    step(0.1, 0.0)  # the follower sees its leader's first plan (solo vehicles are solved together)
    solved = calls.count("follow")
    step(0.2, 0.6 * tol)  # within the tolerance: kept
    assert calls.count("follow") == solved
    step(0.3, 2.0 * tol)  # beyond it: solved again
    assert calls.count("follow") == solved + 1


def _capped_follower_solves(paths, net_file, monkeypatch, policy: PolicySettings) -> list[int]:
    """The control steps (of 8) at which a follower closing fast on a slow leader solves alone."""
    c = _nash_controller(paths, net_file, settings=GameControllerSettings(policy=policy))
    steps, now = [], [0]
    _watch_solo_solves(monkeypatch, lambda problem, result: steps.append(now[0])
                       if problem.players[0].name == "follow" else None)
    s_stop = paths[LANE].s_stop
    world = _world(paths, 0.0, [("lead", LANE, s_stop - 60.0, 3.0), ("follow", LANE, s_stop - 75.0, 9.0)])
    for n in range(8):
        now[0] = n
        c.decide(world, time.perf_counter() + 10.0)
        lead, follow = c.memory.plans["lead"], c.memory.plans["follow"]
        world = _world(paths, 0.1 * (n + 1), [("lead", LANE, float(lead.positions[1]), float(lead.speeds[1])),
                                              ("follow", LANE, float(follow.positions[1]), float(follow.speeds[1]))])
    return steps


def test_solo_reuse_residual_lets_a_nearly_settled_capped_plan_be_kept(paths, net_file, monkeypatch):
    """A capped SQP step that moved the plan less than solo_reuse_residual counts as converged:
    the next period keeps the plan instead of iterating on. With a residual nothing reaches
    (0: nash_tol only) the follower iterates every period until it converges; with one every
    step is under, it solves only when free_resolve_steps is due."""
    strict = _capped_follower_solves(paths, net_file, monkeypatch,
                                     PolicySettings(solo_max_iter=1, solo_reuse_residual=0.0, free_resolve_steps=5))
    loose = _capped_follower_solves(paths, net_file, monkeypatch,
                                    PolicySettings(solo_max_iter=1, solo_reuse_residual=100.0, free_resolve_steps=5))
    # step 1: every follower sees its leader's first plan (solo vehicles are solved together, each
    # against the plans of the last step) and solves again
    assert strict[:3] == [0, 1, 2]  # unconverged at step 1: solved again at once
    assert loose == [0, 1, 6]  # kept for free_resolve_steps - 1 periods, then solved again
    assert len(loose) < len(strict)


@pytest.mark.parametrize("hold_gap, v_slow, plays", [(6.0, 3.0, True), (0.0, 3.0, False), (6.0, 1.0, False)])
def test_a_pair_keeps_its_game_while_the_yielder_is_beyond_its_preview(paths, net_file, hold_gap, v_slow, plays):
    """PolicySettings.trigger_hold_gap, the ETM's hysteresis: the pair plays at the first step
    (Gamma_cp > Gamma_sf); at the next the straight-on vehicle has slowed to v_slow 17 m from
    the point, its TCP (5.7 s at 3 m/s) beyond its preview t_p (4 s at kappa 0.5), so Gamma_cp
    is 0. Held, the pair plays on while the TCPs differ by less than 6 s (5.7 - 1.9 = 3.8 s); not
    held (0) it stops, the yielder then planning alone; 17 s at 1 m/s (15 s apart) ends it too."""
    c = _nash_controller(paths, net_file, settings=GameControllerSettings(policy=PolicySettings(trigger_hold_gap=hold_gap)))
    t = c.table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    first = c.decide(_world(paths, 1.0, [("L", LEFT, t.s_a[p, q] - 16.0, 8.0), ("S", STRAIGHT, t.s_a[q, p] - 17.0, 8.0)]),
                     time.perf_counter() + 10.0)
    assert first.pairs == [("L", "S")]
    world = _world(paths, 1.1, [("L", LEFT, t.s_a[p, q] - 15.2, 8.0), ("S", STRAIGHT, t.s_a[q, p] - 17.0, v_slow)])
    d = c.decide(world, time.perf_counter() + 10.0)
    assert d.pairs == ([("L", "S")] if plays else [])


_KERNEL_PROBE = """
import json, sys, time
import numpy as np
from intersection_cosim.control.base import ControlContext
from intersection_cosim.control.game.controller import GameController
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.build import build_network
from intersection_cosim.network.movements import paper_movements
from intersection_cosim.network.paths import load_paths
from tests.control.test_relations_vectorised import _random_world

def loaded():
    out = {}
    for name, mod in list(sys.modules.items()):
        if name.startswith("intersection_cosim."):
            for attr, f in vars(mod).items():
                if hasattr(f, "py_func") and hasattr(f, "signatures"):
                    out[name + "." + attr] = len(f.signatures)
    return out

net = build_network(sys.argv[1])
c = GameController("nash")
c.setup(ControlContext(movements=paper_movements(net), model=ModelSettings(), control_period=0.1,
                       settings=None, etm=True))
before = loaded()
for seed in range(3):
    c.decide(_random_world(load_paths(net), np.random.default_rng(seed), 40), time.perf_counter() + 60.0)
print(json.dumps([before, loaded()]))
"""


def test_the_compiled_kernels_are_loaded_before_the_first_step(tmp_path):
    """numba compiles (or loads from its cache) a kernel at its first call, which takes
    milliseconds to seconds: the controller's setup calls every kernel a step uses, so that no
    control step pays for it (a fresh process, three dense steps of 40 vehicles)."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, "-c", _KERNEL_PROBE, str(tmp_path)], cwd=root, capture_output=True,
                         text=True, check=True)
    before, after = json.loads(out.stdout.strip().splitlines()[-1])
    assert sum(n > 0 for n in after.values()) >= 6  # the QP, cost, model, plan and filter kernels ran
    assert {k: n for k, n in after.items() if n != before.get(k, 0)} == {}


def _fast_entrant_solves(paths, net_file, monkeypatch, desired: list[float | None]) -> list[int]:
    """The control steps at which a vehicle alone, entering at 13 m/s (above the model's v_max of
    10 m/s) and driving its plan, solves; ``desired[n]`` [m/s] its desired speed at step n."""
    c = _nash_controller(paths, net_file)
    steps, now = [], [0]
    _watch_solo_solves(monkeypatch, lambda problem, result: steps.append(now[0]))
    s, v = paths[LANE].s_stop - 120.0, 13.0
    for n, want in enumerate(desired):
        now[0] = n
        world = _world(paths, 0.1 * n, [("fast", LANE, s, v)])
        world = dataclasses.replace(world, desired_speed=np.array([np.nan if want is None else want]))
        c.decide(world, time.perf_counter() + 10.0)
        plan = c.memory.plans["fast"]
        s, v = float(plan.positions[1]), float(plan.speeds[1])
    assert v > 10.0  # still above v_max: its plan slows it down over the horizon
    return steps


def test_a_vehicle_entering_above_its_v_max_keeps_its_plan_until_v_max_changes(paths, net_file, monkeypatch):
    """A plan that starts above v_max (the solver's cap is then the start speed, speed_cap) is
    kept like any other while it never speeds up and v_max stays the one it was solved for; a
    lower v_max (a lane limit, a desired speed) is a new problem and is solved at once."""
    kept = _fast_entrant_solves(paths, net_file, monkeypatch, [None] * 7)
    assert kept == [0, 5]  # free_resolve_steps (5) is due at step 5, not before
    lowered = _fast_entrant_solves(paths, net_file, monkeypatch, [None, None, 8.0, 8.0, 8.0])
    # solved again when v_max drops to 8 m/s (its real-time SQP may go on at the next step)
    assert lowered[:2] == [0, 2]
