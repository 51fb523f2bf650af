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


def _split_then_left_net(folder: Path) -> Path:
    """W widens at S into the three lanes of SC; C (a crossing) keeps each lane (SC_k -> CD_k); at
    D, 60 m on, only CD's left lane turns left (north), the others go straight (east)."""
    nodes = [("W", -300, 0, None), ("S", -30, 0, "priority"), ("C", 0, 0, "priority"), ("D", 60, 0, "priority"),
             ("E", 260, 0, None), ("N", 0, 200, None), ("X", 0, -200, None), ("DN", 60, 200, None),
             ("DS", 60, -200, None)]
    edges = [("WS", "W", "S", 1), ("SC", "S", "C", 3), ("CD", "C", "D", 3), ("DE", "D", "E", 1), ("NC", "N", "C", 1),
             ("CX", "C", "X", 1), ("DDN", "D", "DN", 1), ("DSD", "DS", "D", 1)]
    connections = ([("WS", "SC", 0, k) for k in range(3)] + [("SC", "CD", k, k) for k in range(3)]
                   + [("CD", "DE", 0, 0), ("CD", "DE", 1, 0), ("CD", "DDN", 2, 0)])
    return plain_net(folder, "splitleft", nodes, edges, connections, speed=16.67)


def test_before_a_lane_split_a_vehicle_is_put_on_the_lane_its_route_goes_on_from(tmp_path):
    """A route-file vehicle before the split is on the path of the split's lane that its route
    goes on from (SUMO's driver takes it): the left lane for a left turn at D, not the first lane
    of the split whose path reaches the right exit edge at C (before: SC_0 for both, so D's turn
    was seen on a lane it could not turn from, and D saw nothing of the vehicle as its guest)."""
    net = _split_then_left_net(tmp_path)
    routes = tmp_path / "demand.rou.xml"
    routes.write_text('<routes><vType id="car" length="4.5" width="1.8"/>'
                      '<vehicle id="left" type="car" depart="0" departSpeed="max"><route edges="WS SC CD DDN"/></vehicle>'
                      '<vehicle id="straight" type="car" depart="8" departSpeed="max"><route edges="WS SC CD DE"/></vehicle>'
                      '</routes>')
    data = {"scenario": {"name": "splitleft", "duration": 10.0, "drain": 60.0, "seed": 1},
            "controller": {"kind": "nash", "budget_ms": 2000.0},
            "network": {"file": str(net), "junctions": ["C", "D"], "routes": str(routes)}}
    summary = run_scenario(scenario_from_dict(data, "<splitleft>"), tmp_path / "run")
    assert summary["counts"]["arrived"] == 2 and summary["counts"]["collisions"] == 0
    traj = pd.read_csv(tmp_path / "run" / "trajectories.csv")
    before_split = traj[traj["lane"] == "WS_0"].dropna(subset=["path"])
    left, straight = (set(before_split[before_split["vehicle"] == v]["path"]) for v in ("left", "straight"))
    assert left == {"SC_2>CD_2"}
    assert straight and "SC_2>CD_2" not in straight  # lanes 0 and 1 go on east: the first of them
    assert set(traj[traj["vehicle"] == "left"]["lane"]) >= {"SC_2", "CD_2", "DDN_0"}
