"""Closed loop through SUMO with an imperfect link: the controller sees the channel, SUMO stays the truth."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from intersection_cosim.cli import main

ROOT = Path(__file__).resolve().parents[2]


def _with_v2x(tmp_path, name: str, extra: str, duration: float | None = None) -> Path:
    text = (ROOT / "scenarios" / f"{name}.toml").read_text()
    if duration is not None:
        text = text.replace("duration = 600.0", f"duration = {duration}")
    path = tmp_path / f"{name}.toml"
    path.write_text(text + "\n" + extra)
    return path


@pytest.mark.parametrize("controller", ["nash", "stackelberg"])
def test_paper_case_with_latency_and_loss_has_no_collision(tmp_path, controller):
    scenario = _with_v2x(tmp_path, "case2_A", "[v2x]\nlatency = 0.2\nloss = 0.2\n")
    out = tmp_path / "run"
    assert main(["run", str(scenario), "--out", str(out), "--controller", controller]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["counts"]["collisions"] == 0
    assert summary["counts"]["arrived"] == summary["counts"]["vehicles"]
    v2x = summary["v2x"]
    assert v2x["messages_lost"] > 0 and v2x["commands_lost"] > 0
    assert 0.1 < v2x["messages_lost"] / v2x["messages_sent"] < 0.3
    assert summary["settings"]["v2x"]["latency"] == 0.2


def test_demand_window_with_latency_loss_and_a_detected_attack(tmp_path):
    """north_straight_1.0 is in the network from 46.75 s to 68.0 s with seed 42 and a 60 s window (its offset starts
    after its first messages: an offset present from the first message is consistent with itself)."""
    extra = ('[v2x]\nlatency = 0.1\nloss = 0.1\n[[v2x.attack]]\nvehicle = "north_straight_1.0"\n'
             'kind = "position_offset"\nvalue = 5.0\nbegin = 50.0\nend = 60.0\n')
    scenario = _with_v2x(tmp_path, "demand_balanced_medium", extra, duration=60.0)
    out = tmp_path / "run"
    assert main(["run", str(scenario), "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["counts"]["collisions"] == 0
    assert summary["v2x"]["attacked"] > 0 and summary["v2x"]["rejected"] > 0
    assert summary["v2x"]["false_rejections"] <= summary["v2x"]["messages_sent"] * 0.01
