"""What the simulator adapter keeps per vehicle: an exit-lane choice holds at its own junction."""

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
