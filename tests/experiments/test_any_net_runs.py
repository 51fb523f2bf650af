"""Closed-loop runs on SUMO nets that are not the generated paper intersection."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pandas as pd
import pytest

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.network.junction_net import load_movements
from intersection_cosim.scenario import load_scenario, with_overrides

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"

pytestmark = pytest.mark.slow


def _run(name: str, controller: str, out: Path, duration: float = 90.0):
    scn = with_overrides(load_scenario(SCENARIOS / f"{name}.toml"), controller=controller, budget_ms=2000.0)
    scn = dataclasses.replace(scn, scenario=dataclasses.replace(scn.scenario, duration=duration))
    summary = run_scenario(scn, out)
    return summary, pd.read_csv(out / "trajectories.csv"), pd.read_csv(out / "vehicles.csv")


@pytest.mark.parametrize("name", ["cross_medium", "tjunction_high"])
def test_the_game_controller_drives_a_net_file_junction_without_collision(tmp_path, name):
    summary, traj, vehicles = _run(name, "nash", tmp_path / name)
    counts = summary["counts"]
    assert counts["departed"] >= 10 and counts["arrived"] == counts["departed"]
    assert counts["collisions"] == 0
    assert set(traj["role"]) == {"ready", "passing", "outside"}
    assert traj["path"].str.contains(">").all()  # paths of the net's connections: from lane > to lane
    commanded = traj[traj["role"] != "outside"]
    assert commanded["accel_cmd"].notna().all()  # every vehicle in the zone is the controller's
    scn = load_scenario(SCENARIOS / f"{name}.toml")
    paths = load_movements(scn.network.file, scn.network.junctions, scn.network.control_range).paths
    first = commanded.groupby("vehicle").first()
    to_stop = first["path"].map(lambda p: paths[p].s_stop) - first["s"]  # [m] when taken over
    assert (to_stop <= scn.network.control_range + 1e-6).all() and (to_stop > 0.0).all()
    assert (vehicles["approach"] != "").all() and set(vehicles["movement"]) <= {"left", "straight", "right"}
    assert pd.read_csv(tmp_path / name / "games.csv").shape[0] > 0


def test_the_lights_are_off_for_the_controllers_and_on_for_sumo_tls(tmp_path):
    """On SUMO's cross (a signalized junction), its own programme stops vehicles at red: SUMO's
    priority rules with the lights off and the game controller both pass them faster."""
    tt = {kind: _run("cross_medium", kind, tmp_path / kind)[2]["travel_time"].mean()
          for kind in ("sumo-tls", "sumo-priority", "nash")}
    assert tt["sumo-tls"] > tt["sumo-priority"] + 5.0
    assert tt["sumo-tls"] > tt["nash"] + 5.0
