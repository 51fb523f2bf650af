"""Lane speed limits (ModelSettings.lane_speed_limits): a turn's lower limit is planned for and kept."""

import time

import numpy as np
import pytest

from intersection_cosim.control.base import ControlContext
from intersection_cosim.control.game.controller import GameController
from intersection_cosim.control.safety.speed_limits import lane_speed_holds, limit_acceleration
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.movements import paper_movements
from tests.control.conftest import make_world


@pytest.fixture(scope="module")
def right(paths):
    """A right turn of the generated net: its internal lanes are limited below the model's 10 m/s."""
    pid = next(p for p, path in paths.items() if path.movement == "right")
    path = paths[pid]
    limit = min(path.speed_limits[path.stop_index:-1])
    assert limit < 7.0 and path.speed_limits[0] > 13.0  # [m/s] the turn, the approach at 50 km/h
    return path, limit


def test_a_turns_limit_is_in_force_from_where_comfortable_braking_reaches_it(right):
    path, limit = right
    start = path.lane_starts[path.stop_index]  # [m] the first internal lane
    lead = (10.0 ** 2 - limit ** 2) / (2 * 2.0)  # [m] to slow from 10 m/s at 2 m/s^2
    assert path.speed_limit_ahead(start - lead - 0.5, 10.0, 2.0) == 10.0
    assert path.speed_limit_ahead(start - lead + 0.5, 10.0, 2.0) == limit
    assert path.speed_limit_ahead(path.s_exit + 1.0, 10.0, 2.0) == 10.0  # on the exit lane
    assert path.speed_limit_ahead(start, limit - 1.0, 2.0) == limit - 1.0  # slower than it wants


def test_the_caps_brake_from_the_last_moment_and_keep_the_limit_on_the_lane(right):
    path, limit = right
    start, v, dt = path.lane_starts[path.stop_index], 10.0, 0.1
    need = (v * v - limit * limit) / (2 * 2.0)  # [m] braking distance at 2 m/s^2
    assert limit_acceleration(path, start - v * dt - need - 1.0, v, 2.0, dt) == np.inf  # not yet
    s = start - v * dt - need + 1.0
    # braking from here on over what is left after the period (the acceleration holds for it)
    assert limit_acceleration(path, s, v, 2.0, dt) == pytest.approx(-(v * v - limit * limit) / (2 * (need - 1.0)))
    assert limit_acceleration(path, start + 1.0, limit + 1.0, 2.0, dt) == pytest.approx(-1.0 / dt)
    assert limit_acceleration(path, start + 1.0, limit, 2.0, dt) == np.inf  # at its limit


def _controller(net_file, on: bool) -> GameController:
    c = GameController("nash")
    c.setup(ControlContext(movements=paper_movements(net_file), model=ModelSettings(lane_speed_limits=on),
                           control_period=0.1, settings=None, etm=True))
    return c


def test_with_limits_on_a_right_turner_plans_for_its_limit_and_is_held_to_it(net_file, paths, right):
    path, limit = right
    start = path.lane_starts[path.stop_index]
    world = make_world(paths, 0.0, [("R", path.id, start - 15.0, 10.0)])  # 15 m before the turn at 10 m/s
    off_ctrl = _controller(net_file, False)
    off = off_ctrl.decide(world, time.perf_counter() + 10.0)
    on_ctrl = _controller(net_file, True)
    on = on_ctrl.decide(world, time.perf_counter() + 10.0)
    assert off.accel["R"] > -0.5  # the paper's model: no reason to slow
    # with the limit: held to the braking that reaches it at the turn, 14 m after this period
    assert on.accel["R"] == pytest.approx(-(100.0 - limit ** 2) / (2 * 14.0), rel=1e-6)
    # its plan (before the filter) slows towards the limit, the paper model's keeps 10 m/s
    planned = {name: c.memory.plans["R"].speeds for name, c in (("off", off_ctrl), ("on", on_ctrl))}
    assert planned["off"][-1] > 9.5 and planned["on"][-1] < 0.5 * (10.0 + limit)
    assert lane_speed_holds(world, on_ctrl.ctx.movements, {}, 2.0, 0.1) == {"R": pytest.approx(on.accel["R"])}
