"""The game controller's fallback: last applied plans, shifted, still through the safety filter."""

import numpy as np
import pytest

from intersection_cosim.control.base import World
from intersection_cosim.games.problem import Plan


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
    assert d.fallback and d.accel["V1"] == pytest.approx(-controller.gs.comfort_brake)


def test_fallback_discards_the_overrun_steps_plans_and_filters_a_collision(controller, paths):
    gs = controller.gs
    # Both applied plans hold 8 m/s: V1 and V2 reach their crossing point together.
    cp = controller.table
    i, j = cp.index["south_inner_left_inner"], cp.index["east_inner_left_inner"]
    s_cp_a, s_cp_b = cp.s_a[i, j], cp.s_b[i, j]
    s_a, s_b = s_cp_a - 16.0, s_cp_b - 16.0  # [m] both 2 s from the point
    world = _world(paths, 1.0, s_a, s_b)
    hold = np.zeros(gs.steps)
    controller.plans = {"V1": Plan.from_accelerations(s_a, 8.0, hold, gs.dt),
                        "V2": Plan.from_accelerations(s_b, 8.0, hold, gs.dt)}
    controller.options = {"V1": "inner", "V2": "inner"}
    # decide() ran for this step (its plans are discarded) and overran; then the fallback:
    controller._decided_at, controller._applied = 1.0, dict(controller.plans)
    controller.plans = {}
    d = controller.fallback(world)
    assert d.fallback
    a = sorted((d.accel["V1"], d.accel["V2"]))
    # one of the two must yield: it brakes to stop before the point; the other keeps its plan
    assert a[1] == pytest.approx(0.0)
    assert a[0] < -1.0
    assert controller.filtered >= 1
