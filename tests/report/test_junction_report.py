"""A run's report on a net with several managed junctions: the per-junction table and figure."""

import dataclasses
from pathlib import Path

import pandas as pd

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.report.reporting import write_report
from intersection_cosim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


def test_report_of_a_corridor_run_has_a_row_per_junction_and_the_delay_figure(tmp_path):
    scn = load_scenario(SCENARIOS / "corridor_low.toml")
    scn = dataclasses.replace(scn, scenario=dataclasses.replace(scn.scenario, duration=60.0, drain=40.0))
    run_scenario(scn, tmp_path / "run")
    steps = pd.read_csv(tmp_path / "run" / "steps.csv")
    assert sorted(steps["junction"].unique()) == ["gneJ10", "gneJ11", "gneJ12"]
    assert (steps.groupby("time").size() == 3).all()  # every junction's controller, every step
    # a vehicle of the eastbound main road is handed from junction to junction: on each one's
    # path in turn, and between them SUMO's (on no path: not in the World)
    traj = pd.read_csv(tmp_path / "run" / "trajectories.csv")
    east = traj[traj["vehicle"].str.startswith("gneE28_gneE26")]
    first = east["vehicle"].iloc[0]
    order = list(dict.fromkeys(p.split(">")[0] for p in east[east["vehicle"] == first]["path"]))
    assert order == ["gneE28_0", "gneE10_0", "gneE11_0"]
    text = write_report(tmp_path / "run").read_text()
    section = text.split("## Junctions")[1].split("##")[0]
    rows = [line for line in section.splitlines() if line.startswith("| gneJ")]
    assert [r.split("|")[1].strip() for r in rows] == ["gneJ10", "gneJ11", "gneJ12"]
    assert (tmp_path / "run" / "figures" / "junction_delay.png").stat().st_size > 10_000
