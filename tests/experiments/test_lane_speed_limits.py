"""Closed loop on the generated net: with ``[model] lane_speed_limits`` right-turners keep the
internal lanes' speed limits (netconvert's 4.4-5.8 m/s for the tight right turns), as SUMO's
own drivers do; without it (the paper's model) they take the turn at up to v_max."""

from __future__ import annotations

import sumolib

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import scenario_from_dict

import pandas as pd


def _scenario(on: bool) -> dict:
    return {"scenario": {"name": "right_turns", "duration": 30.0, "drain": 20.0, "seed": 5},
            "controller": {"kind": "nash"}, "model": {"lane_speed_limits": on},
            "flow": [{"approach": a, "movement": "right", "rate": 360, "kappa": 0.8, "begin": 0.0, "end": 30.0}
                     for a in ("south", "north")]}


def _excess(folder) -> pd.Series:
    """[m/s] speed above the lane's limit of every sample on a junction-internal lane."""
    net = sumolib.net.readNet(str(folder / "intersection.net.xml"), withInternal=True)
    limit = {ln.getID(): ln.getSpeed() for e in net.getEdges(withInternal=True) for ln in e.getLanes()}
    traj = pd.read_csv(folder / "trajectories.csv")
    inside = traj[traj["lane"].astype(str).str.startswith(":")]
    return inside["speed"] - inside["lane"].map(limit)


def test_right_turners_keep_the_turns_limit_only_with_lane_speed_limits(tmp_path):
    runs = {}
    for on in (False, True):
        summary = run_scenario(scenario_from_dict(_scenario(on), "<right_turns>"), tmp_path / str(on))
        assert summary["counts"]["arrived"] == summary["counts"]["departed"] >= 4
        assert summary["counts"]["collisions"] == 0
        runs[on] = _excess(tmp_path / str(on))
    assert runs[False].max() > 2.0  # [m/s] the paper's model turns at up to 10 m/s
    assert runs[True].max() <= 0.1  # [m/s] within the limit (SPEED_TOL and one SUMO step)


def test_on_a_real_city_junction_every_turn_keeps_its_limit(tmp_path):
    """SUMO's Braunschweig net (tools/game/fokr_bs_demo, gzipped): junction 38's turns are limited
    to 5.9-7.8 m/s; four turning flows, lights off."""
    flows = [{"from": a, "to": b, "rate": 300, "kappa": 0.7, "begin": 0.0, "end": 40.0}
             for a, b in (("-1.23", "3"), ("-2.10", "5"), ("-3.22", "1"), ("-5.5", "2"))]
    data = {"scenario": {"name": "fokr38", "duration": 40.0, "drain": 20.0, "seed": 3},
            "controller": {"kind": "stackelberg"}, "model": {"lane_speed_limits": True},
            "network": {"file": "$SUMO_HOME/tools/game/fokr_bs_demo/fokr_bs.net.xml.gz", "junctions": ["38"]},
            "flow": flows}
    summary = run_scenario(scenario_from_dict(data, "<fokr38>"), tmp_path / "run")
    assert summary["counts"]["arrived"] == summary["counts"]["departed"] >= 8
    assert summary["counts"]["collisions"] == 0
    excess = _excess(tmp_path / "run")
    assert len(excess) > 100 and excess.max() <= 0.1  # [m/s]
