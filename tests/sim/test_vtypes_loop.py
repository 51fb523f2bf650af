"""Vehicle types in the closed loop with real SUMO (issue 16): a bus crossing a car keeps its
whole 12 m body clear of the car, and the vehicles' bodies come from their SUMO vTypes."""

import json
import textwrap

import pandas as pd
import pytest

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import load_scenario, with_overrides

CROSSING = """
[scenario]
name = "bus_and_car"
duration = 30.0
drain = 30.0

[controller]
kind = "nash"

[[vtype]]
id = "bus"
length = 12.0
width = 2.5
accel = 1.2
decel = 4.0

[[vehicle]]
id = "BUS"
approach = "south"
lane = "middle"
distance = 12.0
movement = "straight"
speed = 8.0
kappa = 0.5
vtype = "bus"

[[vehicle]]
id = "CAR"
approach = "east"
lane = "middle"
distance = 28.0
movement = "straight"
speed = 8.0
kappa = 0.5
"""


def _run(tmp_path, text: str, controller: str, name: str):
    (tmp_path / f"{name}.toml").write_text(textwrap.dedent(text))
    run_scenario(with_overrides(load_scenario(tmp_path / f"{name}.toml"), controller=controller), tmp_path / name)
    summary = json.loads((tmp_path / name / "summary.json").read_text())
    return (summary, pd.read_csv(tmp_path / name / "vehicles.csv").set_index("vehicle"),
            pd.read_csv(tmp_path / name / "pairs.csv"), pd.read_csv(tmp_path / name / "trajectories.csv"))


@pytest.mark.slow
@pytest.mark.parametrize("controller", ["nash", "stackelberg"])
def test_a_bus_crossing_a_car_keeps_its_body_clear(tmp_path, controller):
    """The bus, 12 m from its stop line, crosses first; the car waits for the bus's rear (0.4 s
    longer than for a 4.5 m car in the bus's place) and enters after it has left: PET > 0
    measured with the bus's own body, and no collision by SUMO's count."""
    summary, vehicles, pairs, traj = _run(tmp_path, CROSSING, controller, "bus")
    _, with_car, _, _ = _run(tmp_path, CROSSING.replace('vtype = "bus"', ""), controller, "car")
    assert summary["counts"]["collisions"] == 0
    assert vehicles["arrival"].notna().all()
    assert vehicles.loc["BUS", "vtype"] == "bus" and vehicles.loc["CAR", "vtype"] == "av"
    pair = pairs.iloc[0]
    assert {pair.vehicle_a, pair.vehicle_b} == {"BUS", "CAR"} and pair.conflict == "cross"
    assert pair.pet > 0.2  # the bus's rear (12 m behind its front) left before the car's front came
    assert vehicles.loc["BUS", "arrival"] < vehicles.loc["CAR", "arrival"]  # the bus went first
    assert vehicles.loc["CAR", "travel_time"] > with_car.loc["CAR", "travel_time"] + 0.2  # a longer body to wait for
    # the bus accelerates at most at its own 1.2 m/s^2 while the controller drives it
    assert traj[traj.vehicle == "BUS"]["accel_cmd"].max() <= 1.2 + 1e-9
