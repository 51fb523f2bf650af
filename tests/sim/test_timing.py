"""sim.timing: SUMO's step times, with the simulation time each step reached (a real run)."""

import dataclasses
from pathlib import Path

import numpy as np

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import load_scenario, with_overrides
from intersection_cosim.sim.sumo import SumoSimulation
from intersection_cosim.sim.timing import sumo_step_timer

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


def test_every_sumo_step_is_timed_with_the_time_it_reached(tmp_path):
    """Case 1 A for 3 s under SUMO's controller at 0.05 s steps: 60 steps, each with a wall time
    above 0 ms and the simulation time after it, 0.05 s apart; outside the block SUMO is not timed."""
    scn = with_overrides(load_scenario(SCENARIOS / "case1_A.toml"), controller="sumo")
    scn = dataclasses.replace(scn, scenario=dataclasses.replace(scn.scenario, duration=3.0, drain=0.0))
    times: list[float] = []
    with sumo_step_timer(times) as ms:
        run_scenario(scn, tmp_path / "run")
    step = scn.scenario.step_length  # [s]
    assert step == 0.05
    assert len(ms) == len(times) >= round(3.0 / step)
    assert min(ms) > 0.0
    assert np.allclose(np.diff(times), step)
    assert times[-1] >= 3.0 - 1e-9
    assert SumoSimulation.advance.__name__ == "advance"  # restored
