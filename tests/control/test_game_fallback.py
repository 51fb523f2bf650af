"""The game controller's fallback: last applied plans, shifted, still through the safety filter."""

import time

import numpy as np
import pytest

from intersection_cosim.control.base import World


def _world(paths, t, s_a, s_b, v=8.0):
    # V1 northbound turning left, V2 westbound turning left: their paths cross (Case 1).
    ids = ["V1", "V2"]
    pids = ["south_inner_left_inner", "east_inner_left_inner"]
    xy = [paths[p].point_at(s) for p, s in zip(pids, (s_a, s_b))]
    return World(time=t, ids=ids, path_ids=pids, s=np.array([s_a, s_b]), v=np.array([v, v]),
                 a=np.zeros(2), x=np.array([p[0] for p in xy]), y=np.array([p[1] for p in xy]),
                 heading=np.zeros(2), kappa=np.array([0.9, 0.9]), role=["ready", "ready"],
                 lanes=["south_in_2", "east_in_2"],
                 exit_choices={"V1": ("inner",), "V2": ("inner",)})


def test_fallback_without_plans_brakes_comfortably(controller, paths):
    d = controller.fallback(_world(paths, 0.0, 120.0, 100.0))
    assert d.fallback and d.accel["V1"] == pytest.approx(-controller.settings.game.comfort_brake)


def test_fallback_drives_the_last_plans_and_keeps_the_overrun_ones_for_the_next_step(controller, paths):
    """decide() ran at 1.0 s and again at 1.1 s, which overran: the fallback of 1.1 s drives the
    plans of 1.0 s shifted by one period, not the late ones of 1.1 s, through the filter; the
    late plans of 1.1 s are what the next step shifts (they land one period late)."""
    cp = controller.table
    i, j = cp.index["south_inner_left_inner"], cp.index["east_inner_left_inner"]
    s_a, s_b = cp.s_a[i, j] - 16.0, cp.s_b[i, j] - 16.0  # [m] both 2 s from the point
    controller.decide(_world(paths, 1.0, s_a, s_b), time.perf_counter() + 10.0)
    applied = dict(controller.memory.plans)
    # 1.1 s: moved as planned, but the world says both are 2 m/s faster: decide plans anew
    moved = {v: (float(p.positions[1]), float(p.speeds[1])) for v, p in applied.items()}
    world = _world(paths, 1.1, moved["V1"][0], moved["V2"][0])
    world.v[:] = (moved["V1"][1], moved["V2"][1])
    controller.decide(world, time.perf_counter() + 10.0)
    late = dict(controller.memory.plans)
    assert any(late[v] is not applied[v] for v in applied)
    before = controller.diagnostics().safety_interventions
    d = controller.fallback(world)
    assert d.fallback and not d.games
    for v in ("V1", "V2"):
        kept = max(float(applied[v].accelerations[1]), -float(world.v[world.ids.index(v)]) / 0.1)
        assert d.accel[v] <= kept + 1e-12  # the 1.0 s plan, shifted (or lowered by the filter)
        assert controller.memory.plans[v] is late[v]  # the next step shifts the late 1.1 s plan
    assert controller.diagnostics().safety_interventions >= before
    # 1.2 s overruns too: it drives the 1.1 s plans shifted by one period
    nxt = _world(paths, 1.2, *(float(late[v].positions[1]) for v in ("V1", "V2")))
    nxt.v[:] = [float(late[v].speeds[1]) for v in ("V1", "V2")]
    d = controller.fallback(nxt)
    for v in ("V1", "V2"):
        assert d.accel[v] <= max(float(late[v].accelerations[1]), -float(nxt.v[nxt.ids.index(v)]) / 0.1) + 1e-12


def test_fallback_brakes_one_of_two_plans_that_would_collide(controller, paths):
    """No plans yet, both 2 s from their crossing at 8 m/s: the kept plans brake comfortably,
    and the filter still orders the two (one stops before the point)."""
    cp = controller.table
    i, j = cp.index["south_inner_left_inner"], cp.index["east_inner_left_inner"]
    world = _world(paths, 1.0, cp.s_a[i, j] - 16.0, cp.s_b[i, j] - 16.0)
    d = controller.fallback(world)
    assert d.fallback
    assert max(d.accel.values()) == pytest.approx(-controller.settings.game.comfort_brake)
    assert min(d.accel.values()) <= -controller.settings.game.comfort_brake
