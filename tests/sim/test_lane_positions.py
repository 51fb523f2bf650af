"""A vehicle's arc length along its path runs on without a jump where SUMO's length of a lane is
not its shape's: SUMO's Braunschweig net (tools/game/fokr_bs_demo) has 239 such lanes, its
junction 38's approaches up to 1.1 m longer in SUMO than drawn (sim/sumo.py, SumoSimulation.arc)."""

from __future__ import annotations

import pandas as pd
import pytest

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import scenario_from_dict


@pytest.mark.slow
def test_arc_lengths_never_run_back_across_a_stop_line_of_a_net_whose_lanes_are_longer_than_drawn(tmp_path):
    flows = [{"from": a, "to": b, "rate": 400, "kappa": 0.5, "begin": 0.0, "end": 30.0}
             for a, b in (("-1.23", "3"), ("-1.23", "5"), ("-2.10", "5"), ("-3.22", "1"))]
    data = {"scenario": {"name": "fokr38", "duration": 30.0, "drain": 20.0, "seed": 2},
            "controller": {"kind": "nash"},
            "network": {"file": "$SUMO_HOME/tools/game/fokr_bs_demo/fokr_bs.net.xml.gz", "junctions": ["38"]},
            "flow": flows}
    summary = run_scenario(scenario_from_dict(data, "<fokr38>"), tmp_path / "run")
    assert summary["counts"]["collisions"] == 0 and summary["counts"]["arrived"] == summary["counts"]["departed"] >= 10
    traj = pd.read_csv(tmp_path / "run" / "trajectories.csv").dropna(subset=["path"])
    traj = traj.sort_values(["vehicle", "time"])
    step = traj.groupby(["vehicle", "path"])["s"].diff().dropna()  # [m] per control step
    crossed = traj.assign(internal=traj["lane"].astype(str).str.startswith(":")).groupby("vehicle")["internal"].any()
    assert crossed.sum() >= 10  # vehicles that drove over a stop line into the junction
    assert step.min() >= -0.01  # [m] unscaled, the front ran up to 1.08 m back at the line
