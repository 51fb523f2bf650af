"""A vehicle's exit lane leads on along its route: the controller never sends it onto a lane of a
short exit edge from which its route does not go on.

Closed loop on a netconvert net: road W-C (one lane) crosses a north-south street at junction C
(managed) and goes on as the 3-lane edge CD, about 10 m long, to node D, where each lane of CD
leads onto one road of its own (lane 0 to DR, lane 1 to DS, lane 2 to DL). The movement W-C-D has
three exit lanes; the lane-choice game prefers the one in line with the approach (lane 0). InTAS
Ingolstadt feeds its 7-arm cluster junction by such an edge (4.5 m): a vehicle put on a lane that
does not lead on stopped at that lane's end, and a queue formed behind it. On this edge SUMO
still changes lanes in time, so the test checks the lane each vehicle drives on CD.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import sumolib

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import scenario_from_dict
from tests.plain_nets import plain_net


def _fan_net(folder: Path) -> Path:
    nodes = [("W", -300, 0, None), ("C", 0, 0, "priority"), ("D", 25, 0, "priority"), ("N", 0, 200, None),
             ("X", 0, -200, None), ("R", 150, -150, None), ("S", 250, 0, None), ("L", 150, 150, None)]
    edges = [("WC", "W", "C", 1), ("CD", "C", "D", 3), ("NC", "N", "C", 1), ("CX", "C", "X", 1),
             ("DR", "D", "R", 1), ("DS", "D", "S", 1), ("DL", "D", "L", 1)]
    connections = [("WC", "CD", 0, k) for k in range(3)] + [("CD", e, k, 0) for k, e in enumerate(("DR", "DS", "DL"))]
    return plain_net(folder, "fan", nodes, edges, connections)


def _run(tmp_path: Path, net: Path, routes: list[list[str]], gap: float, duration: float) -> dict:
    """Run ``routes`` (one vehicle each, ``gap`` [s] apart) on ``net`` with junction C managed."""
    trips = "".join(f'<vehicle id="{r[-1]}{n // 3}" type="car" depart="{gap * n}" departSpeed="max">'
                    f'<route edges="{" ".join(r)}"/></vehicle>' for n, r in enumerate(routes))
    (tmp_path / "demand.rou.xml").write_text(f'<routes><vType id="car" length="4.5" width="1.8"/>{trips}</routes>')
    data = {"scenario": {"name": net.stem, "duration": duration, "drain": 60.0, "seed": 1},
            "controller": {"kind": "nash", "budget_ms": 2000.0},
            "network": {"file": str(net), "junctions": ["C"], "routes": str(tmp_path / "demand.rou.xml")}}
    return run_scenario(scenario_from_dict(data, f"<{net.stem}>"), tmp_path / "run")


def test_every_vehicle_is_sent_onto_an_exit_lane_its_route_goes_on_from(tmp_path):
    net = _fan_net(tmp_path)
    sumo_net = sumolib.net.readNet(str(net))
    assert sumo_net.getEdge("CD").getLength() < 20.0  # [m] too short to change lanes on
    for k, edge in enumerate(("DR", "DS", "DL")):  # each lane of CD leads onto one road only
        assert [c.getTo().getID() for c in sumo_net.getEdge("CD").getLanes()[k].getOutgoing()] == [edge]
    summary = _run(tmp_path, net, [["WC", "CD", e] for _n in range(3) for e in ("DL", "DS", "DR")], 2.0, 20.0)
    assert summary["counts"]["arrived"] == 9 and summary["counts"]["collisions"] == 0
    log = (tmp_path / "run" / "sumo.log").read_text()
    assert "no connection to the next edge" not in log
    traj = pd.read_csv(tmp_path / "run" / "trajectories.csv")
    on_cd = traj[traj["lane"].str.startswith("CD_")]
    want = {"DR": "CD_0", "DS": "CD_1", "DL": "CD_2"}
    assert set(on_cd["vehicle"]) == {f"{e}{n}" for e in want for n in range(3)}
    for vid, lanes in on_cd.groupby("vehicle")["lane"]:
        assert set(lanes) == {want[vid[:2]]}, vid  # on CD only on the lane its route goes on from


def _fan_after_a_link_net(folder: Path) -> Path:
    """As :func:`_fan_net`, but the exit edge CE is a 3-lane link of about 50 m whose lanes each go
    on to one lane of the short edge EF only, and EF's lanes fan out at F."""
    nodes = [("W", -300, 0, None), ("C", 0, 0, "priority"), ("E", 60, 0, "priority"), ("F", 72, 0, "priority"),
             ("N", 0, 200, None), ("X", 0, -200, None), ("R", 200, -150, None), ("S", 300, 0, None),
             ("L", 200, 150, None)]
    edges = [("WC", "W", "C", 1), ("CE", "C", "E", 3), ("EF", "E", "F", 3), ("NC", "N", "C", 1), ("CX", "C", "X", 1),
             ("FR", "F", "R", 1), ("FS", "F", "S", 1), ("FL", "F", "L", 1)]
    connections = ([("WC", "CE", 0, k) for k in range(3)] + [("CE", "EF", k, k) for k in range(3)]
                   + [("EF", e, k, 0) for k, e in enumerate(("FR", "FS", "FL"))])
    return plain_net(folder, "fan2", nodes, edges, connections)


def test_an_exit_lane_leads_on_only_if_the_lane_it_feeds_on_a_short_next_edge_does(tmp_path):
    """Every lane of CE links to EF, so one edge of look-ahead keeps all three; only the lane in
    line with the route's lane on the short EF leads on. The vehicle leaves junction C on it."""
    from intersection_cosim.sim.exit_lanes import LANE_CHANGE_ROOM

    net = _fan_after_a_link_net(tmp_path)
    sumo_net = sumolib.net.readNet(str(net))
    assert sumo_net.getEdge("EF").getLength() < LANE_CHANGE_ROOM <= sumo_net.getEdge("CE").getLength()
    summary = _run(tmp_path, net, [["WC", "CE", "EF", e] for _n in range(2) for e in ("FL", "FS", "FR")], 2.0, 14.0)
    assert summary["counts"]["arrived"] == 6 and summary["counts"]["collisions"] == 0
    traj = pd.read_csv(tmp_path / "run" / "trajectories.csv")
    first_on_ce = traj[traj["lane"].str.startswith("CE_")].groupby("vehicle")["lane"].first()
    want = {"FR": "CE_0", "FS": "CE_1", "FL": "CE_2"}
    assert first_on_ce.to_dict() == {f"{e}{n}": lane for e, lane in want.items() for n in range(2)}
