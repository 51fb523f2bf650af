"""control/safety/exit_room.py: a READY vehicle is held at its stop line while its exit lane is full."""

import dataclasses
import os

import numpy as np
import pytest

from intersection_cosim.control.base import ControlContext
from intersection_cosim.control.safety.exit_room import exit_room_caps
from intersection_cosim.control.baselines.fcfs import FcfsController
from intersection_cosim.control.baselines.reservations import FcfsSettings
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.junction_net import load_movements

from tests.control.conftest import make_world

CORRIDOR = os.path.join(os.path.dirname(__import__("sumo").__file__), "tools", "game", "corridor", "corridor.net.xml")
STRAIGHT = "gneE10_0>gneE11_0"  # eastbound through gneJ11, exit lane gneE11_0
KW = dict(length=5.0, min_gap=2.5, margin=1.0, comfort=2.0, a_min=-5.0, period=0.1, standing=1.0)


@pytest.fixture(scope="module")
def movements():
    return load_movements(CORRIDOR, ("gneJ10", "gneJ11", "gneJ12"), 80.0)


def _world(movements, free, s_to_stop=4.0, v=4.0):
    path = movements.paths[STRAIGHT]
    world = make_world(movements.paths, 10.0, [("E", STRAIGHT, path.s_stop - s_to_stop, v)])
    return dataclasses.replace(world, exit_free={"gneE11_0": free} if free is not None else {})


def test_a_full_standing_exit_lane_holds_the_vehicle_short_of_its_stop_line(movements):
    caps = exit_room_caps(_world(movements, (3.0, 0.0)), movements, {}, **KW)
    # stop 1 m before the line from 4 m/s, 4 m away: a = -v^2 / 2 (d - margin) = -16 / 6
    assert caps["E"] == pytest.approx(-16.0 / 6.0)


def test_room_for_length_plus_gap_or_a_lane_that_drives_off_lets_it_go(movements):
    assert exit_room_caps(_world(movements, (7.5, 0.0)), movements, {}, **KW) == {}
    assert exit_room_caps(_world(movements, (7.4, 0.0)), movements, {}, **KW) != {}
    # 3 m free now, but its last vehicle drives at 5 m/s: 5 m more by the time it reaches the line
    assert exit_room_caps(_world(movements, (3.0, 5.0)), movements, {}, **KW) == {}


def test_far_from_its_line_it_approaches_as_planned_and_a_lane_not_reported_is_free(movements):
    assert exit_room_caps(_world(movements, (0.0, 0.0), s_to_stop=40.0), movements, {}, **KW) == {}
    assert exit_room_caps(_world(movements, None), movements, {}, **KW) == {}


def test_a_vehicle_standing_in_the_junction_claims_room_on_the_same_exit_lane(movements):
    world = make_world(movements.paths, 10.0, [("E", STRAIGHT, movements.paths[STRAIGHT].s_stop - 4.0, 4.0),
                                               ("N", "gneE21_0>gneE11_0", movements.paths["gneE21_0>gneE11_0"].s_stop + 3.0, 0.0)])
    world = dataclasses.replace(world, role=["ready", "passing"], exit_free={"gneE11_0": (10.0, 0.0)})
    assert "E" in exit_room_caps(world, movements, {}, **KW)  # 10 m free, 7.5 claimed by N
    moving = dataclasses.replace(world, v=np.array([4.0, 3.0]))
    assert exit_room_caps(moving, movements, {}, **KW) == {}  # N drives on: it claims nothing yet


def _fcfs(movements, exit_room: bool = True):
    ctrl = FcfsController()
    ctrl.setup(ControlContext(movements=movements, model=ModelSettings(), control_period=0.1,
                              settings=FcfsSettings(exit_room=exit_room), etm=True))
    return ctrl


def test_fcfs_holds_a_vehicle_without_exit_room_and_reserves_nothing_for_it(movements):
    # 4 m/s, 4 m before the line, exit lane full and standing: fcfs's rule 5 brakes it to stop
    # follow_gap = 1 m before the line (-16 / 6 m/s^2) and grants it no slot
    ctrl = _fcfs(movements)
    decisions = ctrl.decide(_world(movements, (3.0, 0.0)), deadline=float("inf"))
    assert decisions.accel["E"] == pytest.approx(-16.0 / 6.0)
    assert "E" not in ctrl.grants
    # room on the lane: it is granted its earliest arrival and accelerates
    ctrl = _fcfs(movements)
    decisions = ctrl.decide(_world(movements, (50.0, 0.0)), deadline=float("inf"))
    assert "E" in ctrl.grants and decisions.accel["E"] > 0.0
    # the rule off: it is granted and drives on into the box
    ctrl = _fcfs(movements, exit_room=False)
    decisions = ctrl.decide(_world(movements, (3.0, 0.0)), deadline=float("inf"))
    assert "E" in ctrl.grants and decisions.accel["E"] > 0.0
