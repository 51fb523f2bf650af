"""Yielding to pedestrians at crossings (control/safety/pedestrians.py), on SUMO's Braunschweig junction
38 (tools/game/fokr_bs_demo): a vehicle about to enter stays out of a crossing a person walks on."""

from pathlib import Path

import time

import numpy as np
import pytest
import sumo

from intersection_cosim.control.base import ControlContext, Walker
from intersection_cosim.control.game.controller import GameController
from intersection_cosim.control.safety.pedestrians import pedestrian_holds, vehicle_window, walker_window
from intersection_cosim.control.safety.settings import SafetySettings
from intersection_cosim.games.problem import Plan
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.crossings import crossing_zones, junction_crossings
from intersection_cosim.network.junction_net import load_movements
from tests.control.conftest import make_world

NET = str(Path(sumo.SUMO_HOME) / "tools" / "game" / "fokr_bs_demo" / "fokr_bs.net.xml.gz")
PATH = "-1.23_6>5_4"  # straight through; over crossing c4 (its road in), then c1 (its road out)
ST = SafetySettings()


@pytest.fixture(scope="module")
def fokr():
    movements = load_movements(NET, ("38",), 100.0)
    return movements, crossing_zones(movements, junction_crossings(NET, ("38",)), 5.0, 1.8)


def test_a_walkers_window_runs_from_reaching_the_stretch_fast_to_leaving_it_at_its_own_speed():
    span = (4.0, 6.0)  # [m] on the axis; widened by pedestrian_clearance 1 m to 3..7
    w = Walker("p", "c", 0.0, +1, 1.2)
    t_in, t_out = walker_window(w, span, ST)
    assert t_in == pytest.approx(3.0 / 1.5) and t_out == pytest.approx(7.0 / 1.2)  # [s]
    assert walker_window(w._replace(position=5.0), span, ST) == (0.0, pytest.approx(2.0 / 1.2))
    assert walker_window(w._replace(position=8.0), span, ST) is None  # past it, walking away
    back = walker_window(w._replace(position=8.0, direction=-1), span, ST)  # coming back towards it
    assert back == (pytest.approx(1.0 / 1.5), pytest.approx(5.0 / 1.2))
    standing = walker_window(w._replace(position=5.0, speed=0.0), span, ST)
    assert standing == (0.0, pytest.approx(2.0 / 0.5))  # walks on at pedestrian_speed_low


def _holds(fokr, s, v, walkers, lead=None, emergency=-4.0):
    """``emergency`` [m/s^2]: the vehicle's hardest emergency braking (-4: none beyond its own)."""
    movements, zones = fokr
    world = make_world(movements.paths, 10.0, [("A", PATH, s, v)])
    world.walkers = tuple(walkers)
    return pedestrian_holds(world, movements, zones, {}, {}, ST, 0.1, lambda k: (-4.0, 2.5, emergency), 2.0, 0.1,
                            lambda k, exit_lane: lead)


def test_a_vehicle_waits_at_its_stop_line_for_a_person_on_its_crossing_braking_from_the_last_moment(fokr):
    movements, zones = fokr
    path, (c_in, _) = movements.paths[PATH], zones[PATH]
    mid = sum(c_in.span) / 2  # [m] on the crossing's axis, in front of the vehicle
    person = Walker("p", c_in.lane, mid, +1, 1.2)
    stop = path.s_stop - ST.margin  # [m]
    # 10 m/s: comfortable braking (2 m/s^2) needs 25 m; from 40 m before its stop point it drives on
    assert _holds(fokr, stop - 40.0, 10.0, [person]) == {}
    cap = _holds(fokr, stop - 24.0, 10.0, [person])["A"]
    assert cap == pytest.approx(-100.0 / (2 * 24.0))  # [m/s^2] stops at its stop line
    assert _holds(fokr, stop - 0.5, 0.0, [person])["A"] == pytest.approx(0.0)  # standing near it, it stays
    assert _holds(fokr, stop - 10.0, 0.0, [person]) == {}  # standing further back, it may move up
    # 12 m before the line at 10 m/s it can no longer stop there at 4 m/s^2 but can before the crossing
    assert _holds(fokr, path.s_stop - 13.0, 10.0, [person])["A"] >= -4.0
    # too close to stop at all: it drives on (it would stand on the crossing)
    assert _holds(fokr, c_in.zone_in - 3.0, 10.0, [person]) == {}
    # nobody, or a person who has passed its stretch walking away: nothing
    assert _holds(fokr, stop - 20.0, 10.0, []) == {}
    assert _holds(fokr, stop - 20.0, 10.0, [person._replace(position=c_in.span[1] + 2.0)]) == {}


def test_a_person_far_along_the_crossing_does_not_stop_a_vehicle_that_passes_first(fokr):
    movements, zones = fokr
    path, (c_in, _) = movements.paths[PATH], zones[PATH]
    far = Walker("p", c_in.lane, c_in.span[0] - 12.0, +1, 1.2)  # 12 m before its stretch: 8 s at 1.5 m/s
    assert _holds(fokr, path.s_stop - 20.0, 10.0, [far]) == {}  # over the crossing in ~3 s
    near = far._replace(position=c_in.span[0] - 3.0)  # 2 s away: within the 1.5 s gap of its passage
    assert "A" in _holds(fokr, path.s_stop - 20.0, 10.0, [near])


def test_a_person_on_the_road_out_holds_the_vehicle_at_its_stop_line_not_in_the_box(fokr):
    movements, zones = fokr
    path, (_, c_out) = movements.paths[PATH], zones[PATH]
    person = Walker("p", c_out.lane, sum(c_out.span) / 2, -1, 0.0)  # standing on the crossing out
    assert _holds(fokr, path.s_stop - 10.0, 5.0, [person]) == {}  # at 5 m/s it need not brake yet
    cap = _holds(fokr, path.s_stop - 6.0, 5.0, [person])["A"]
    assert cap == pytest.approx(-25.0 / (2 * (6.0 - ST.margin)))  # [m/s^2] at its stop line
    inside = _holds(fokr, c_out.zone_in - 7.0, 5.0, [person])["A"]  # in the junction: before the crossing
    assert inside == pytest.approx(-25.0 / (2 * (7.0 - ST.pedestrian_margin)))


def test_a_vehicle_does_not_enter_a_crossing_it_could_not_leave_while_people_walk_there(fokr):
    """Its leader stands just past the crossing: it would have to stop on it, in the people's way."""
    movements, zones = fokr
    path, (c_in, _) = movements.paths[PATH], zones[PATH]
    far = Walker("p", c_in.lane, c_in.span[0] - 12.0, +1, 1.2)  # no conflict by the windows alone
    s = path.s_stop - 6.0  # [m] at 5 m/s: it must brake now to stop at its stop line
    assert _holds(fokr, s, 5.0, [far]) == {}
    blocked = _holds(fokr, s, 5.0, [far], lead=(c_in.zone_out + 0.5, 0.0))  # rear 0.5 m past the crossing
    assert blocked["A"] == pytest.approx(-25.0 / (2 * (6.0 - ST.margin)))
    assert _holds(fokr, s, 5.0, [far], lead=(c_in.zone_out + 0.5, 3.0)) == {}  # the leader drives on
    assert _holds(fokr, s, 5.0, [far], lead=(c_in.zone_out + 5.0, 0.0)) == {}  # room behind the crossing
    assert _holds(fokr, s, 5.0, [], lead=(c_in.zone_out + 0.5, 0.0)) == {}  # nobody there


def test_a_standing_vehicle_reckons_to_drive_off_not_to_creep_over_the_crossing(fokr):
    """Standing at its stop point with no plan over the crossing, a vehicle leaves the crossing
    as at full acceleration, not at the 0.1 m/s floor speed (two minutes for the crossing, in
    which someone always walks onto a busy one: it stood for good)."""
    movements, zones = fokr
    path, (c_in, _) = movements.paths[PATH], zones[PATH]
    s = path.s_stop - ST.margin  # [m] standing at its stop point
    world = make_world(movements.paths, 10.0, [("A", PATH, s, 0.0)])
    t_in, t_out = vehicle_window(world, 0, c_in, None, 0.1, 2.5)
    d_in, d_out = c_in.zone_in - s, c_in.zone_out - s  # [m]
    assert t_in == pytest.approx((2 * d_in / 2.5) ** 0.5) and t_out == pytest.approx((2 * d_out / 2.5) ** 0.5)
    assert t_out < 5.0  # [s] the crossing is ~10 m long
    # a person 14 m before its stretch (9 s away at 1.5 m/s) does not hold it; one 4 m away does
    coming = Walker("p", c_in.lane, c_in.span[0] - 15.0, +1, 1.2)
    assert _holds(fokr, s, 0.0, [coming]) == {}
    assert "A" in _holds(fokr, s, 0.0, [coming._replace(position=c_in.span[0] - 5.0)])


def test_a_plan_that_ends_on_the_crossing_leaves_it_from_the_plans_end(fokr):
    """A slow start whose horizon ends inside the crossing: the leaving is reckoned from the plan's
    last state, not taken as never (which held the vehicle against every person to come)."""
    movements, zones = fokr
    c_in, _ = zones[PATH]
    s = c_in.zone_in - 1.0  # [m]
    world = make_world(movements.paths, 10.0, [("A", PATH, s, 0.0)])
    plan = Plan.from_accelerations(s, 0.0, np.full(30, 1.0), 0.1)  # 1 m/s^2 for 3 s: 4.5 m, 3 m/s
    t_in, t_out = vehicle_window(world, 0, c_in, plan, 0.1, 2.5)
    rest, v = c_in.zone_out - plan.positions[-1], 3.0  # [m], [m/s] at the horizon's end
    assert t_in == pytest.approx((2 * 1.0 / 1.0) ** 0.5, abs=0.1)
    assert t_out == pytest.approx(3.0 + ((v * v + 2 * 2.5 * rest) ** 0.5 - v) / 2.5)
    assert t_out < 6.0  # [s]


def test_a_vehicle_too_close_to_stop_in_its_own_braking_makes_an_emergency_stop_for_a_person(fokr):
    """SUMO inserts a vehicle 4 m before a crossing a person walks over (Ingolstadt 335525545: it
    hit her at 7 m/s). At 5.7 m/s stopping there takes 4.1 m/s^2, beyond its 4 m/s^2: it brakes
    within its emergencyDecel instead of driving on (knowing none, it stops within the zone's
    edge); it still drives on when it cannot stop even so."""
    movements, zones = fokr
    c_in, _ = zones[PATH]
    person = Walker("p", c_in.lane, sum(c_in.span) / 2, +1, 1.2)  # in front of it
    need = -5.7 ** 2 / (2 * (4.0 - 0.05))  # [m/s^2] to stop at the crossing's edge
    edge = _holds(fokr, c_in.zone_in - 4.0, 5.7, [person])["A"]  # no harder braking known: within the edge
    assert edge == pytest.approx(-5.7 ** 2 / (2 * (4.0 + 1.5)))
    assert _holds(fokr, c_in.zone_in - 4.0, 5.7, [person], emergency=-9.0)["A"] == pytest.approx(need)
    assert _holds(fokr, c_in.zone_in - 3.0, 12.0, [person], emergency=-9.0) == {}  # 16 m/s^2: drives on
    assert _holds(fokr, c_in.zone_in - 4.0, 5.7, [], emergency=-9.0) == {}  # nobody: no emergency
    # in the closed loop the safety filter lets the emergency stop through, below the vehicle's decel
    controller = GameController("nash")
    controller.setup(ControlContext(movements=movements, model=ModelSettings(), control_period=0.1, settings=None,
                                    etm=True))
    world = make_world(movements.paths, 10.0, [("A", PATH, c_in.zone_in - 4.0, 5.7)])
    world.walkers, world.decel, world.emergency_decel = (person,), np.array([4.5]), np.array([9.0])
    a = controller.decide(world, time.perf_counter() + 10.0).accel["A"]
    assert a < -4.0 and a == pytest.approx(need, rel=1e-3)  # [m/s^2] (its zone is built with the run's bodies)


def test_the_follower_of_an_emergency_stop_keeps_its_safe_speed_behind_that_braking(fokr):
    """Krauss' safe speed behind a leader that makes an emergency stop counts on the leader's
    actual braking, not its vType's decel (on a DRT junction the follower stopped 0.09 m behind)."""
    from intersection_cosim.control.safety.onboard import krauss_safe_speed

    movements, zones = fokr
    c_in, _ = zones[PATH]
    person = Walker("p", c_in.lane, sum(c_in.span) / 2, +1, 1.2)
    s_a, v = c_in.zone_in - 4.0, 7.0  # [m], [m/s]: a stop at 6.2 m/s^2
    controller = GameController("nash")
    controller.setup(ControlContext(movements=movements, model=ModelSettings(), control_period=0.1, settings=None,
                                    etm=True))
    world = make_world(movements.paths, 10.0, [("A", PATH, s_a, v), ("B", PATH, s_a - 8.0, v)])
    world.walkers, world.decel, world.emergency_decel = (person,), np.array([4.0, 4.0]), np.array([9.0, 9.0])
    d = controller.decide(world, time.perf_counter() + 10.0)
    stop = -v * v / (2 * (4.0 - 0.05))  # [m/s^2] A's emergency stop
    assert d.accel["A"] == pytest.approx(stop, rel=1e-3)
    gap = 8.0 - controller.model.vehicle_length - controller.settings.safety.margin  # [m] bumper to bumper
    behind_emergency = (krauss_safe_speed(gap, v, 4.0, 0.1, -stop) - v) / 0.1  # [m/s^2]
    behind_normal = (krauss_safe_speed(gap, v, 4.0, 0.1, 4.0) - v) / 0.1
    assert behind_emergency < behind_normal - 1.0
    assert d.accel["B"] <= behind_emergency + 1e-6


def test_a_vehicle_at_the_crossings_edge_with_a_person_in_front_stops_there_deeper_in_it_drives_on(fokr):
    """Under a V2X link's position noise a vehicle standing at the edge was read 0.2-0.6 m inside
    its zone, taken as committed and driven into the person (fokr38, 5-7 people hit in 300 s).
    Within EDGE_DEPTH of the zone's start it stops now; deeper, or with nobody in its way within
    the windows themselves (a person the time gap alone counts), it drives on as before."""
    from intersection_cosim.control.safety.pedestrians import EDGE_DEPTH

    movements, zones = fokr
    c_in, _ = zones[PATH]
    person = Walker("p", c_in.lane, sum(c_in.span) / 2, +1, 1.2)  # on its stretch
    standing = _holds(fokr, c_in.zone_in + 0.4, 0.3, [person], emergency=-9.0)["A"]
    assert standing == pytest.approx(-0.3 / 0.1)  # [m/s^2] stops within the period
    assert _holds(fokr, c_in.zone_in + 0.4, 2.0, [person], emergency=-9.0)["A"] == pytest.approx(-9.0)
    assert _holds(fokr, c_in.zone_in + EDGE_DEPTH + 0.2, 0.3, [person], emergency=-9.0) == {}
    assert _holds(fokr, c_in.zone_in + 0.4, 0.3, [], emergency=-9.0) == {}
    # before the zone, too fast to stop at its start: it stops within the edge
    s = c_in.zone_in - 1.0  # [m]
    a = _holds(fokr, s, 5.0, [person], emergency=-9.0)["A"]
    assert a == pytest.approx(-25.0 / (2 * (1.0 + EDGE_DEPTH)))  # [m/s^2] 25/(2 * 0.95) needs 13 m/s^2
    # a person 2 s before its stretch, 0.5 s after the vehicle is over it: the gap counts him (a
    # normal hold where it can stop), no emergency stop where it cannot
    late = person._replace(position=c_in.span[0] - 1.0 - 3.0)  # [m] 3 m at 1.5 m/s from the widened span
    assert _holds(fokr, c_in.zone_in - 0.5, 8.0, [late], emergency=-9.0) == {}
