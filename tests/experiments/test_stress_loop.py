"""``intersection-cosim stress`` closed loop: with the safety filter switched off (``--set``) a
short random search of a shipped scenario finds a collision, writes it as a scenario file, and
``intersection-cosim run`` on that file replays the collision at the recorded time."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from intersection_cosim.cli import main

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "demand_balanced_high.toml"
CONTROL_PERIOD = 0.1  # [s] the scenario's control period


@pytest.mark.slow
def test_stress_finds_a_collision_without_the_safety_filter_and_its_file_replays_it(tmp_path):
    out = tmp_path / "stress"
    args = ["stress", str(SCENARIO), "--runs", "2", "--duration", "30", "--workers", "1", "--no-shrink",
            "--no-progress", "--out", str(out), "--set", "controller.safety.enabled=false",
            "--set", "stress.demand_scale=[1.8, 2.0]"]
    assert main(args) == 0
    summary = json.loads((out / "summary.json").read_text())
    table = pd.read_csv(out / "stress.csv")
    assert len(table) == 2 and (table["status"] == "ok").all()
    crash = next(f for f in summary["failures"] if f["kind"] == "collision")
    assert summary["min_margin"] == -1.0
    assert main(args) == 0  # a rerun: every run finished, the same table
    wall = ["compute_ms_median"]
    assert pd.read_csv(out / "stress.csv").drop(columns=wall).equals(table.drop(columns=wall))
    replay = tmp_path / "replay"
    assert main(["run", str(out / crash["file"]), "--out", str(replay)]) == 0
    log = pd.read_csv(replay / "collisions.csv")
    assert len(log) > 0
    first = log.sort_values("time").iloc[0]
    assert abs(first["time"] - crash["time"]) <= CONTROL_PERIOD
    assert {first["collider"], first["victim"]} == set(crash["vehicles"])
