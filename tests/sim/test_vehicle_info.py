"""What the simulator adapter keeps per vehicle: an exit-lane choice is taken from, and holds at,
its own junction only."""

from types import SimpleNamespace

from intersection_cosim.control.base import Decisions
from intersection_cosim.sim.exit_lanes import take_exit_choices
from intersection_cosim.sim.vehicles import VehicleInfo


def _info(**kw) -> VehicleInfo:
    return VehicleInfo("", "", "", 0.5, None, True, **kw)


def test_a_controllers_exit_lane_choice_holds_only_at_the_junction_it_was_made_for():
    info = _info(exit_lane="2", exit_junction="A")
    assert (info.exit_lane_at("A"), info.exit_lane_at("B")) == ("2", None)


def test_a_scenarios_fixed_exit_lane_holds_at_every_junction():
    info = _info(exit_lane="1", exit_fixed=True)
    assert (info.exit_lane_at("A"), info.exit_lane_at("B")) == ("1", "1")
    assert _info().exit_lane_at("A") is None


def _sim(path_junctions: dict[str, str], on: dict[str, str], **infos):
    """A stand-in of the adapter's state take_exit_choices reads: vehicles, their paths, and
    each path's junction."""
    paths = {pid: SimpleNamespace(junction=j) for pid, j in path_junctions.items()}
    return SimpleNamespace(vehicles=infos, current_path=on,
                           movements=SimpleNamespace(paths=paths, junctions=tuple(path_junctions.values())))


def test_an_exit_lane_choice_is_taken_for_the_junction_whose_path_the_vehicle_is_on():
    sim = _sim({"a": "A", "b": "B"}, {"v": "b", "h": "b"}, v=_info(), h=_info(driver="human"))
    take_exit_choices(sim, Decisions(exit_lane={"v": "1", "h": "1"}, owner={"v": "B"}))
    assert (sim.vehicles["v"].exit_lane, sim.vehicles["v"].exit_junction) == ("1", "B")
    assert sim.vehicles["h"].exit_lane is None  # a human's lane is SUMO's


def test_an_exit_lane_choice_late_from_a_junction_the_vehicle_has_left_is_not_taken():
    """Decided at A, delivered over V2X once the vehicle is on B's path: B's lane is not A's to choose."""
    sim = _sim({"a": "A", "b": "B"}, {"v": "b"}, v=_info(exit_lane="0", exit_junction="B"))
    take_exit_choices(sim, Decisions(exit_lane={"v": "1"}, owner={"v": "A"}))
    assert (sim.vehicles["v"].exit_lane, sim.vehicles["v"].exit_junction) == ("0", "B")


def test_a_route_file_vehicle_desires_the_roads_limit_up_to_its_top_speed_and_a_scenarios_its_own():
    adopted = _info(road_speed=12.0)  # [m/s] its vType's maxSpeed
    assert (adopted.desired_at(8.33), adopted.desired_at(13.89)) == (8.33, 12.0)
    assert _info(desired_speed=9.0, road_speed=12.0).desired_at(13.89) == 9.0  # its own desire first
    assert _info().desired_at(13.89) is None  # the model's v_max
