"""A pair's game whose inputs did not change keeps its equilibrium (control/game/game_reuse.py)."""

from __future__ import annotations

import time

import numpy as np
import pytest

from intersection_cosim.control.base import ControlContext
from intersection_cosim.control.game.controller import GameController
from intersection_cosim.control.game.settings import GameControllerSettings, PolicySettings
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.movements import paper_movements
from tests.control.conftest import make_world, record_solves

LEFT = "west_inner_left_inner"  # eastbound, turning left to the north
STRAIGHT = "north_middle_straight_middle"  # southbound, straight on: the left turn crosses it


def _controller(net_file, game_resolve_steps: int, game_reuse_gap: float = 1.0) -> tuple[GameController, list]:
    """A Nash controller (ETM on, 0.1 s period) and the list of iteration counts of the games it
    solves from now on."""
    c = GameController("nash")
    settings = GameControllerSettings(policy=PolicySettings(game_resolve_steps=game_resolve_steps,
                                                            game_reuse_gap=game_reuse_gap))
    c.setup(ControlContext(movements=paper_movements(net_file), model=ModelSettings(), control_period=0.1,
                           settings=settings, etm=True))
    return c, record_solves(c, lambda result: result.iterations)


def _start(c: GameController, paths):
    t = c.table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    return make_world(paths, 0.0, [("L", LEFT, t.s_a[p, q] - 22.0, 8.0), ("S", STRAIGHT, t.s_a[q, p] - 24.0, 8.0)])


def _as_planned(c: GameController, paths, t: float, slower: float = 0.0):
    """Both vehicles where their applied plans put them one period on; S ``slower`` [m/s]."""
    ps = [c.memory.plans[v] for v in ("L", "S")]
    return make_world(paths, t, [("L", LEFT, float(ps[0].positions[1]), float(ps[0].speeds[1])),
                                 ("S", STRAIGHT, float(ps[1].positions[1]), float(ps[1].speeds[1]) - slower)])


def test_a_steady_game_is_kept_between_solves_at_most_game_resolve_steps_apart(paths, net_file):
    c, solves = _controller(net_file, 4)
    per_step = []
    world = _start(c, paths)
    for n in range(12):
        before = len(solves)
        d = c.decide(world, time.perf_counter() + 10.0)
        assert d.games == 1  # the pair's game is in force every step, solved or kept
        per_step.append(len(solves) - before)
        world = _as_planned(c, paths, 0.1 * (n + 1))
    assert per_step[0] == 1  # a new game is solved
    kept = [n for n, s in enumerate(per_step) if s == 0]
    assert len(kept) >= 4  # on its plans the game is steady: most steps keep it
    runs = "".join(str(s) for s in per_step).split("1")
    assert max(len(r) for r in runs) <= 3  # never more than game_resolve_steps - 1 kept in a row
    for n in kept:  # a kept step follows a solve that converged at once, or another kept step
        assert per_step[n - 1] == 0 or solves[sum(per_step[:n]) - 1] == 1


def test_a_kept_game_starts_its_plans_from_the_measured_states(paths, net_file):
    c, solves = _controller(net_file, 5)
    world, kept = _start(c, paths), 0
    for n in range(10):
        before = len(solves)
        c.decide(world, time.perf_counter() + 10.0)
        if len(solves) == before:
            kept += 1
            for k, v in enumerate(("L", "S")):
                plan = c.memory.plans[v]
                assert plan.positions[0] == pytest.approx(world.s[k]) and plan.speeds[0] == pytest.approx(world.v[k])
        world = _as_planned(c, paths, 0.1 * (n + 1))
    assert kept >= 3


def test_a_pair_not_known_to_be_apart_at_its_conflict_point_is_solved_every_step(paths, net_file):
    """No two plans of a 3 s horizon arrive 10 s apart: with game_reuse_gap 10 s nothing is kept;
    at 0 s the same steady game is kept."""
    counts = {}
    for gap in (10.0, 0.0):
        c, solves = _controller(net_file, 5, game_reuse_gap=gap)
        world = _start(c, paths)
        for n in range(10):
            c.decide(world, time.perf_counter() + 10.0)
            world = _as_planned(c, paths, 0.1 * (n + 1))
        counts[gap] = len(solves)
    assert counts[10.0] == 10 and counts[0.0] <= 6


def test_a_player_off_its_plan_or_a_resolve_period_of_one_solves_every_step(paths, net_file):
    c, solves = _controller(net_file, 5)
    world = _start(c, paths)
    for n in range(6):  # S is 0.2 m/s slower than planned at every step: never the same game
        c.decide(world, time.perf_counter() + 10.0)
        world = _as_planned(c, paths, 0.1 * (n + 1), slower=0.2)
    assert len(solves) == 6
    every, solves_every = _controller(net_file, 1)
    world = _start(every, paths)
    for n in range(6):
        every.decide(world, time.perf_counter() + 10.0)
        world = _as_planned(every, paths, 0.1 * (n + 1))
    assert len(solves_every) == 6
    assert np.isfinite([every.memory.plans[v].accelerations for v in ("L", "S")]).all()


def test_arrival_is_the_first_plan_time_at_the_point_or_the_horizon_end():
    from intersection_cosim.control.game.game_reuse import arrival
    from intersection_cosim.games.problem import Plan

    plan = Plan.from_accelerations(0.0, 10.0, np.zeros(30), 0.1)  # 10 m/s from s = 0 for 3 s
    assert arrival(plan, 0.0) == 0.0
    assert arrival(plan, 9.95) == pytest.approx(1.0)  # 10 m after 1.0 s
    assert arrival(plan, 25.0) == pytest.approx(2.5)
    assert arrival(plan, 31.0) == pytest.approx(3.0)  # not within the 3 s horizon: its end


def test_a_game_of_a_player_entering_above_v_max_is_kept_too(paths, net_file):
    """S comes in at 13 m/s, above the model's v_max of 10 m/s: its plans start at that speed
    and slow down (the solver's cap is the start speed, games.problem.speed_cap); the steady game
    is kept between solves as one of two players within v_max is."""
    c, solves = _controller(net_file, 5)
    t = c.table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    world = make_world(paths, 0.0, [("L", LEFT, t.s_a[p, q] - 22.0, 8.0), ("S", STRAIGHT, t.s_a[q, p] - 44.0, 13.0)])
    kept = []  # S's speed [m/s] at each step that kept the game
    for n in range(10):
        before = len(solves)
        assert c.decide(world, time.perf_counter() + 10.0).games == 1
        if len(solves) == before:
            kept.append(float(world.v[1]))
        world = _as_planned(c, paths, 0.1 * (n + 1))
    assert len([v for v in kept if v > 10.0]) >= 3  # kept while S is still above v_max
