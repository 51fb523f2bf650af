"""A managed junction sees the vehicles bound for it before a lane split, not after it.

Closed loop on a netconvert net: a one-lane road W widens at node S into the three lanes of a short
edge SC that ends at junction C (a crossing with a north-south street). Only C is managed. Before,
an approach was extended upstream only through unique predecessors, so C's approach ended at S's
internal lanes: a vehicle coming along W at the road's 16.7 m/s was first commanded about 10 m
before C's stop line, too close to stop (InTAS Ingolstadt has such splits before its 7-arm
cluster junction; at road speed its vehicles crossed into the cluster unseen until then).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import sumolib

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.network.junction_net import load_movements
from intersection_cosim.scenario import scenario_from_dict
from tests.plain_nets import plain_net


def _split_net(folder: Path) -> Path:
    nodes = [("W", -300, 0, None), ("S", -30, 0, "priority"), ("C", 0, 0, "priority"), ("E", 200, 0, None),
             ("N", 0, 200, None), ("X", 0, -200, None)]
    edges = [("WS", "W", "S", 1), ("SC", "S", "C", 3), ("CE", "C", "E", 1), ("NC", "N", "C", 1), ("CX", "C", "X", 1)]
    return plain_net(folder, "split", nodes, edges, [("WS", "SC", 0, k) for k in range(3)], speed=16.67)


def test_a_vehicle_is_taken_over_before_the_lane_split_that_precedes_the_junction(tmp_path):
    net = _split_net(tmp_path)
    assert 5.0 < sumolib.net.readNet(str(net)).getEdge("SC").getLength() < 25.0  # [m] the split is close to C
    paths = load_movements(net, ("C",), 100.0).paths
    routes = tmp_path / "demand.rou.xml"
    routes.write_text('<routes><vType id="car" length="4.5" width="1.8"/>'
                      '<vehicle id="v" type="car" depart="0" departSpeed="max"><route edges="WS SC CE"/></vehicle>'
                      '</routes>')
    data = {"scenario": {"name": "split", "duration": 5.0, "drain": 60.0, "seed": 1},
            "controller": {"kind": "nash", "budget_ms": 2000.0},
            "network": {"file": str(net), "junctions": ["C"], "routes": str(routes)}}
    summary = run_scenario(scenario_from_dict(data, "<split>"), tmp_path / "run")
    assert summary["counts"]["arrived"] == 1 and summary["counts"]["collisions"] == 0
    traj = pd.read_csv(tmp_path / "run" / "trajectories.csv")
    commanded = traj[traj["accel_cmd"].notna()]
    first = commanded.iloc[0]
    assert first["lane"] == "WS_0"  # before the split (before: on S's internal lane, past it)
    assert paths[first["path"]].s_stop - first["s"] > 80.0  # [m] about the control range before C's line
