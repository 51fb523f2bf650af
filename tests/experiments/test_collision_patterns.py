"""Closed loop per collision pattern of the game controller on small nets built here.

Two junctions A and B on a one-way road W -> A -> B -> E, each crossed by a one-way street, or
one junction whose two-lane approach has a lane per movement (netconvert from plain XML); the
demand is a route file of hand-timed vehicles (AVs of the user's own routes, adopted by the
controller). Each test drives the pattern with ``nash`` and checks SUMO's collision records,
the bumper-to-bumper gaps and speeds of the vehicles involved, and who commanded them.
"""

from __future__ import annotations

import subprocess
from pathlib import Path
from types import SimpleNamespace

import libsumo
import pandas as pd
import pytest
import sumolib

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.network.by_junction import path_junction
from intersection_cosim.results.sumo_outputs import read_collisions
from intersection_cosim.scenario import scenario_from_dict
from intersection_cosim.sim.sumo import SumoSimulation
from intersection_cosim.v2x.channel import Channel
from tests.plain_nets import plain_net

pytestmark = pytest.mark.slow

LENGTH = 4.5  # [m] every vehicle's body (the route files' vType)
SPEED_MODE_SUMO = 31  # SUMO's default speed mode: every check of its own driver model on
VTYPE = '<vType id="car" length="4.5" width="1.8" minGap="2.5"/>'


def _corridor(folder: Path, spacing: float) -> Path:
    """The net: A at x = 0 and B at x = ``spacing`` [m] on the eastbound road WA -> AB -> BE, a
    southbound street through each (NAA -> ASA, NBB -> BSB); one lane each, priority junctions."""
    nodes = (f'<nodes><node id="A" x="0" y="0" type="priority"/><node id="B" x="{spacing}" y="0" type="priority"/>'
             f'<node id="W" x="-200" y="0"/><node id="E" x="{spacing + 150}" y="0"/>'
             f'<node id="NA" x="0" y="150"/><node id="SA" x="0" y="-150"/>'
             f'<node id="NB" x="{spacing}" y="150"/><node id="SB" x="{spacing}" y="-150"/></nodes>')
    edges = "<edges>" + "".join(f'<edge id="{e}" from="{a}" to="{b}" numLanes="1" speed="13.89"/>' for e, a, b in (
        ("WA", "W", "A"), ("AB", "A", "B"), ("BE", "B", "E"), ("NAA", "NA", "A"), ("ASA", "A", "SA"),
        ("NBB", "NB", "B"), ("BSB", "B", "SB"))) + "</edges>"
    (folder / "c.nod.xml").write_text(nodes)
    (folder / "c.edg.xml").write_text(edges)
    net = folder / "corridor.net.xml"
    subprocess.run([sumolib.checkBinary("netconvert"), "-n", "c.nod.xml", "-e", "c.edg.xml", "--no-turnarounds",
                    "-o", net.name], cwd=folder, check=True, capture_output=True)
    return net


def _fork(folder: Path) -> Path:
    """A single junction A: WA (two lanes) from the west, lane 0 only straight on to AE, lane 1
    only left into AN; SA from the south to both."""
    (folder / "f.nod.xml").write_text('<nodes><node id="A" x="0" y="0" type="priority"/><node id="W" x="-200" y="0"/>'
                                      '<node id="E" x="150" y="0"/><node id="N" x="0" y="150"/>'
                                      '<node id="S" x="0" y="-150"/></nodes>')
    (folder / "f.edg.xml").write_text("<edges>" + "".join(
        f'<edge id="{e}" from="{a}" to="{b}" numLanes="{n}" speed="13.89"/>'
        for e, a, b, n in (("WA", "W", "A", 2), ("AE", "A", "E", 1), ("AN", "A", "N", 1), ("SA", "S", "A", 1)))
        + "</edges>")
    (folder / "f.con.xml").write_text("<connections>" + "".join(
        f'<connection from="{a}" to="{b}" fromLane="{k}" toLane="0"/>'
        for a, b, k in (("WA", "AE", 0), ("WA", "AN", 1), ("SA", "AE", 0), ("SA", "AN", 0))) + "</connections>")
    net = folder / "fork.net.xml"
    subprocess.run([sumolib.checkBinary("netconvert"), "-n", "f.nod.xml", "-e", "f.edg.xml", "-x", "f.con.xml",
                    "--no-turnarounds", "-o", net.name], cwd=folder, check=True, capture_output=True)
    return net


def _edge_length(net: Path, edge: str) -> float:
    return sumolib.net.readNet(str(net)).getEdge(edge).getLength()  # [m]


def _routes(folder: Path, vehicles: list[tuple[float, str]]) -> Path:
    """A route file of ``vehicles`` ((depart [s], <vehicle> element)), sorted by departure."""
    path = folder / "demand.rou.xml"
    body = "\n".join(v for _, v in sorted(vehicles, key=lambda v: v[0]))
    path.write_text(f"<routes>\n{VTYPE}\n{body}\n</routes>\n")
    return path


def _run(folder: Path, net: Path, routes: Path, control_range: float, v2x: dict | None = None,
         junctions: tuple[str, ...] = ("A", "B")):
    """Run ``nash`` on ``junctions``: (summary, trajectories, SUMO's collision records)."""
    data = {"scenario": {"name": "pattern", "duration": 30.0, "drain": 60.0, "seed": 1},
            "controller": {"kind": "nash", "budget_ms": 2000.0},
            "network": {"file": str(net), "junctions": list(junctions), "control_range": control_range,
                        "routes": str(routes), "desired_speed": "v_max"}}  # the patterns are timed for 10 m/s
    if v2x is not None:
        data["v2x"] = v2x
    out = folder / "run"
    summary = run_scenario(scenario_from_dict(data, "<pattern>"), out)
    return summary, pd.read_csv(out / "trajectories.csv"), read_collisions(out / "collisions.xml")


def _records(collisions: pd.DataFrame) -> list[tuple]:
    return [tuple(r) for r in collisions[["time", "collider", "victim", "lane"]].itertuples(index=False)]


def _eastbound_gaps(traj: pd.DataFrame, ids: set[str]) -> pd.DataFrame:
    """Per control step and pair of consecutive vehicles of ``ids`` on the eastbound road (a
    straight line: x orders them): the follower's bumper-to-bumper gap [m] and both speeds."""
    rows = []
    east = traj[traj["vehicle"].isin(ids)].sort_values(["time", "x"])
    for time, g in east.groupby("time", sort=True):
        x, v, vid = g["x"].to_numpy(), g["speed"].to_numpy(), g["vehicle"].to_numpy()
        rows += [(time, vid[k], vid[k + 1], x[k + 1] - LENGTH - x[k], v[k], v[k + 1]) for k in range(len(x) - 1)]
    return pd.DataFrame(rows, columns=["time", "follower", "leader", "gap", "v_follower", "v_leader"])


class OwnerLog:
    """Who commands each vehicle, SUMO step by SUMO step, read from the simulator adapter.

    A command's junction is the managed junction whose controller decided it: the one whose path
    the vehicle was on in the World it was decided on (without a V2X link the simulator's World
    of that very step; over V2X the World the link showed, each command arriving one latency
    later). After every SUMO step a vehicle that holds a command may hold only that of the
    junction whose path it is on short of the path's exit lane; a vehicle once commanded and
    holding none now is driven by SUMO with SUMO's own checks (its default speed mode)."""

    def __init__(self):
        self.sender: dict[str, str] = {}  # vehicle -> junction of the command it holds
        self.owners: dict[str, list[str]] = {}  # vehicle -> junctions whose commands it took, in order
        self.stale: list[tuple] = []  # (time [s], vehicle, command's junction, junction now (None: none), lane)
        self.unchecked: list[tuple] = []  # (time [s], vehicle, speed mode): SUMO drives it, its checks off
        self.commanded_steps = 0  # [-] SUMO steps x vehicles holding a command
        self._sent: dict[tuple[str, float], str] = {}  # (vehicle, arrival [s]) -> junction, over V2X

    def install(self, mp: pytest.MonkeyPatch) -> None:
        command, advance, send = SumoSimulation.command, SumoSimulation.advance, Channel.send

        def logged_send(channel, decisions, time):
            for vid in decisions.accel:
                if vid in channel.tracks:
                    junction = path_junction(channel.movements, channel.tracks[vid].accepted.path_id)
                    self._sent[(vid, round(time + channel.settings.latency, 3))] = junction
            send(channel, decisions, time)

        def logged_command(sim, decisions):
            held = dict(sim.commands)
            command(sim, decisions)
            for vid, accel in decisions.accel.items():
                if sim.commands.get(vid) != float(accel):
                    continue  # not taken
                if self._sent:
                    junction = self._sent.pop((vid, round(sim.time, 3)), None)
                    if junction is None or held.get(vid) == float(accel):
                        continue  # not told apart from the command it held
                else:
                    junction = path_junction(sim.movements, sim.current_path[vid])
                self.sender[vid] = junction
                seen = self.owners.setdefault(vid, [])
                if not seen or seen[-1] != junction:
                    seen.append(junction)

        def logged_advance(sim):
            advance(sim)
            self.check(sim)

        mp.setattr(Channel, "send", logged_send)
        mp.setattr(SumoSimulation, "command", logged_command)
        mp.setattr(SumoSimulation, "advance", logged_advance)

    def check(self, sim) -> None:
        for vid, state in sim.states.items():
            lane = state[libsumo.VAR_LANE_ID]
            if vid not in sim.commands:
                mode = sim.api.vehicle.getSpeedMode(vid)
                if vid in self.owners and mode != SPEED_MODE_SUMO:
                    self.unchecked.append((round(sim.time, 2), vid, mode))
                continue
            self.commanded_steps += 1
            pid = sim.current_path.get(vid)
            now = None
            if pid is not None and lane != sim.paths[pid].lanes[-1]:
                now = path_junction(sim.movements, pid)
            if now != self.sender.get(vid):
                self.stale.append((round(sim.time, 2), vid, self.sender.get(vid), now, lane))


def _short_link(folder: Path, v2x: dict | None = None) -> SimpleNamespace:
    """An 8.8 m link from A to B: ten AVs eastbound 1.2 s apart at 10 m/s through A and B, and
    ten AVs southbound through B 1.5 s apart from 5 s (kappa 0.9): B stops the eastbound ones
    on the link while those behind them are still in A's box."""
    net = _corridor(folder, 20.0)
    east = [(i * 1.2, f'<vehicle id="e{i}" type="car" depart="{i * 1.2:.2f}" departSpeed="10">'
                      '<route edges="WA AB BE"/></vehicle>') for i in range(10)]
    south = [(5.0 + j * 1.5, f'<vehicle id="s{j}" type="car" depart="{5.0 + j * 1.5:.2f}" departSpeed="10">'
                             '<param key="kappa" value="0.9"/><route edges="NBB BSB"/></vehicle>') for j in range(10)]
    log = OwnerLog()
    with pytest.MonkeyPatch.context() as mp:
        log.install(mp)
        summary, traj, collisions = _run(folder, net, _routes(folder, east + south), 100.0, v2x)
    return SimpleNamespace(net=net, summary=summary, traj=traj, collisions=collisions, log=log,
                           east={f"e{i}" for i in range(10)})


@pytest.fixture(scope="module")
def short_link(tmp_path_factory):
    return _short_link(tmp_path_factory.mktemp("short_link"))


def _assert_one_owner(run: SimpleNamespace) -> None:
    log = run.log
    handed = [vid for vid in run.east if log.owners.get(vid, [])[:2] == ["A", "B"]]
    assert len(handed) >= 8  # commanded by A, then by B
    assert log.commanded_steps > 1000
    assert (len(log.stale), len(log.unchecked)) == (0, 0), (
        f"SUMO steps x vehicles holding a command of a junction they were not on: {len(log.stale)}, "
        f"first {log.stale[:3]}; driven by SUMO with its checks off: {len(log.unchecked)}, first {log.unchecked[:3]}")


def test_the_short_link_is_as_short_as_asked(short_link):
    assert 8.0 < _edge_length(short_link.net, "AB") < 10.0  # [m]


def test_vehicles_leaving_a_junction_stop_behind_the_queue_of_the_next_one(short_link):
    """Who leaves A at speed into the queue B holds on the 8.8 m link stops behind it."""
    counts, traj = short_link.summary["counts"], short_link.traj
    assert counts["departed"] == counts["arrived"] == 20
    on_link = traj[traj["vehicle"].isin(short_link.east) & (traj["lane"] == "AB_0")]
    assert on_link["speed"].min() < 1.0  # [m/s] the pattern happened: B stopped an eastbound AV on the link
    assert _records(short_link.collisions) == [], f"SUMO's collisions {_records(short_link.collisions)}"
    gaps = _eastbound_gaps(traj, short_link.east)
    worst = gaps.loc[gaps["gap"].idxmin()]
    assert worst["gap"] >= 0.0, f"min bumper-to-bumper gap {worst.to_dict()}"
    collisions = short_link.summary["collisions"]
    assert collisions["sumo_records_commanded"] == 0 and collisions["overlap_pairs_commanded"] == 0


def test_a_vehicle_leaving_a_junction_holds_no_command_of_the_junction_it_left(short_link):
    """Handover on the 8.8 m link: every SUMO step a vehicle is commanded by the junction whose
    path it is on or driven by SUMO with SUMO's own checks, never by a junction it has left."""
    _assert_one_owner(short_link)


def test_an_av_stops_behind_a_vehicle_whose_trip_ends_on_its_approach(tmp_path):
    """A vehicle whose trip starts and ends on A's approach WA stands there 12 s (a stop): it is
    on no path of A, so A's controller does not track it. The two AVs coming up behind it at
    10 m/s stop short of it."""
    net = _corridor(tmp_path, 20.0)
    parked = (0.0, '<vehicle id="parked" type="car" depart="0" departPos="150" arrivalPos="170">'
                   '<route edges="WA"/><stop lane="WA_0" endPos="152" duration="12"/></vehicle>')
    avs = [(2.0 * i, f'<vehicle id="e{i}" type="car" depart="{2.0 * i:.1f}" departPos="60" departSpeed="10">'
                     '<route edges="WA AB BE"/></vehicle>') for i in range(2)]
    summary, traj, collisions = _run(tmp_path, net, _routes(tmp_path, [parked, *avs]), 100.0)
    assert "parked" not in set(traj["vehicle"])  # never on a managed path
    assert summary["counts"]["departed"] == summary["counts"]["arrived"] == 3
    assert _records(collisions) == [], f"SUMO's collisions {_records(collisions)}"
    e0 = traj[(traj["vehicle"] == "e0") & (traj["time"] <= 12.0)]  # the parked vehicle stands at least that long
    assert (e0["lane"] == "WA_0").all()
    gap = (152.0 - LENGTH) - e0["s"]  # [m] to the parked vehicle's rear (WA_0 is the path's first lane)
    assert gap.min() >= 0.0, f"e0's min gap to the parked vehicle {gap.min():.2f} m"
    assert e0.loc[gap.idxmin(), "speed"] < 0.5  # [m/s] it stands behind it
    assert summary["collisions"]["sumo_records_commanded"] == 0


def test_an_av_released_after_a_junction_stops_behind_the_queue_of_the_next(tmp_path):
    """A 119 m link, 25 m control range, 0.1 s V2X latency: four AVs stand in B's range (B holds
    them: a vehicle stands on B's exit for 20 s), the last one's rear beyond the range. AV ``x``
    leaves A at 10 m/s and drives along the link on A's exit lane, past A and short of B's range,
    up to the back of that queue. It stops behind it."""
    net = _corridor(tmp_path, 130.0)
    link = _edge_length(net, "AB")
    vehicles = [(0.0, '<vehicle id="parked" type="car" depart="0" departPos="0" arrivalPos="40"><route edges="BE"/>'
                      '<stop lane="BE_0" endPos="6" duration="20"/></vehicle>'),
                (0.0, '<vehicle id="x" type="car" depart="0" departPos="100" departSpeed="10">'
                      '<route edges="WA AB BE"/></vehicle>')]
    vehicles += [(0.0, f'<vehicle id="q{k}" type="car" depart="0" departPos="{link - 0.5 - 7.5 * k:.2f}" '
                       'departSpeed="0"><route edges="AB BE"/></vehicle>') for k in range(4)]
    summary, traj, collisions = _run(tmp_path, net, _routes(tmp_path, vehicles), 25.0, v2x={"latency": 0.1})
    assert summary["counts"]["departed"] == summary["counts"]["arrived"] == 6
    x = traj[traj["vehicle"] == "x"]
    assert (x["role"] == "outside").sum() > 50  # on A's exit lane, let go by A, for more than 5 s
    assert _records(collisions) == [], f"SUMO's collisions {_records(collisions)}"
    gaps = _eastbound_gaps(traj, {"x", "q3"})
    behind = gaps[(gaps["follower"] == "x") & (gaps["leader"] == "q3")]
    held = behind[behind["time"] < 20.0]  # while the parked vehicle holds the queue
    worst = held.loc[held["gap"].idxmin()]
    assert worst["gap"] >= 0.0, f"x behind q3: {worst.to_dict()}"
    assert held["v_leader"].max() < 0.5 and held["v_follower"].min() < 0.1  # [m/s] x stood behind the standing q3
    assert summary["collisions"]["sumo_records_commanded"] == 0


def test_an_av_stops_behind_a_vehicle_waiting_to_change_into_its_turning_lane(tmp_path):
    """A vehicle turning left from WA stands at the end of lane 0 (straight only) for 20 s,
    three vehicles standing on lane 1 (left only) beside it: its route leaves by no path of
    lane 0, so the controller does not track it there. The AV coming up behind it on lane 0 at
    10 m/s stops short of it."""
    net = _fork(tmp_path)
    end = _edge_length(net, "WA")  # [m]
    vehicles = [(0.0, f'<vehicle id="b{k}" type="car" depart="0" departLane="1" departPos="{end - 30 - 10 * k:.1f}" '
                      f'arrivalPos="{end - 1:.1f}"><route edges="WA"/>'
                      f'<stop lane="WA_1" endPos="{end - 6 - 7 * k:.1f}" duration="20"/></vehicle>') for k in range(3)]
    vehicles += [(0.0, f'<vehicle id="v" type="car" depart="0" departLane="0" departPos="{end - 10:.1f}" departSpeed="0">'
                       '<route edges="WA AN"/></vehicle>'),
                 (0.0, '<vehicle id="x" type="car" depart="0" departLane="0" departPos="60" departSpeed="10">'
                       '<route edges="WA AE"/></vehicle>')]
    summary, traj, collisions = _run(tmp_path, net, _routes(tmp_path, vehicles), 100.0, junctions=("A",))
    assert summary["counts"]["departed"] == summary["counts"]["arrived"] == 5
    v = traj[traj["vehicle"] == "v"]
    assert "WA_0" not in set(v["lane"]) and v["time"].min() > 20.0  # untracked while it waits on lane 0
    assert _records(collisions) == [], f"SUMO's collisions {_records(collisions)}"
    x = traj[(traj["vehicle"] == "x") & (traj["time"] < 20.0)]
    assert (x["lane"] == "WA_0").all() and x["speed"].min() < 0.1  # [m/s] x stood behind v on lane 0
    assert summary["collisions"]["sumo_records_commanded"] == 0


def test_over_v2x_a_vehicle_leaving_a_junction_holds_no_command_of_the_junction_it_left(tmp_path):
    """The 8.8 m link with 0.2 s V2X latency: a command decided before the handover arrives
    after it; the vehicle does not take it, and nobody collides."""
    run = _short_link(tmp_path, v2x={"latency": 0.2})
    _assert_one_owner(run)
    assert _records(run.collisions) == [], f"SUMO's collisions {_records(run.collisions)}"


def _split(folder: Path, link: float) -> Path:
    """Junction A, then a two-lane link AE of about ``link`` [m] to E: WA enters AE on lane 0
    only; at E lane 0 goes straight on (EX), lane 1 turns left (EN); a street from the south
    crosses A (SA -> AN2)."""
    (folder / "s.nod.xml").write_text(
        f'<nodes><node id="A" x="0" y="0" type="priority"/><node id="E" x="{link + 10}" y="0" type="priority"/>'
        f'<node id="W" x="-200" y="0"/><node id="X" x="{link + 160}" y="0"/><node id="N" x="{link + 10}" y="150"/>'
        '<node id="S" x="0" y="-150"/><node id="N2" x="0" y="150"/></nodes>')
    (folder / "s.edg.xml").write_text("<edges>" + "".join(
        f'<edge id="{e}" from="{a}" to="{b}" numLanes="{n}" speed="13.89"/>'
        for e, a, b, n in (("WA", "W", "A", 1), ("AE", "A", "E", 2), ("EX", "E", "X", 1), ("EN", "E", "N", 1),
                           ("SA", "S", "A", 1), ("AN2", "A", "N2", 1))) + "</edges>")
    (folder / "s.con.xml").write_text("<connections>" + "".join(
        f'<connection from="{a}" to="{b}" fromLane="{i}" toLane="{j}"/>'
        for a, b, i, j in (("WA", "AE", 0, 0), ("AE", "EX", 0, 0), ("AE", "EN", 1, 0), ("SA", "AN2", 0, 0)))
        + "</connections>")
    net = folder / "split.net.xml"
    subprocess.run([sumolib.checkBinary("netconvert"), "-n", "s.nod.xml", "-e", "s.edg.xml", "-x", "s.con.xml",
                    "--no-turnarounds", "-o", net.name], cwd=folder, check=True, capture_output=True)
    return net


def test_a_vehicle_changes_lanes_only_once_its_body_has_left_the_junction(tmp_path, monkeypatch):
    """An AV crosses A onto lane 0 of a 15 m link whose lane 1 it needs for its left turn at E:
    SUMO would change lanes (in one step, a lane width sideways) as soon as its front is on the
    link, its rear still across A's crossing street. It changes only once its rear is a metre
    onto the link, and arrives. (SUMO's state of the vehicle is read after every step.)"""
    net = _split(tmp_path, 15.0)
    seen = []
    advance = SumoSimulation.advance

    def recording(sim):
        advance(sim)
        st = sim.states.get("v")
        if st is not None:
            seen.append((st[libsumo.VAR_LANE_ID], st[libsumo.VAR_LANEPOSITION]))

    monkeypatch.setattr(SumoSimulation, "advance", recording)
    vehicles = [(0.0, '<vehicle id="v" type="car" depart="0" departSpeed="10"><route edges="WA AE EN"/></vehicle>')]
    summary, _, collisions = _run(tmp_path, net, _routes(tmp_path, vehicles), 100.0, junctions=("A",))
    assert summary["counts"]["arrived"] == 1 and _records(collisions) == []
    on_link = [(lane, pos) for lane, pos in seen if lane.startswith("AE_")]
    assert on_link[0][0] == "AE_0" and {lane for lane, _ in on_link} == {"AE_0", "AE_1"}
    first = next(pos for lane, pos in on_link if lane == "AE_1")  # [m] its front when it changed
    assert first >= LENGTH + 1.0  # its rear a metre onto the link


def _bike_lane(folder: Path) -> Path:
    """A single junction A: WA from the west has a bicycle lane (lane 0, bicycles only) beside the
    car lane; bicycles ride straight on to AE's bicycle lane, cars turn right into AS across it (or
    go straight on); a street from the north (NA) into AS and AE."""
    (folder / "b.nod.xml").write_text('<nodes><node id="A" x="0" y="0" type="priority"/><node id="W" x="-200" y="0"/>'
                                      '<node id="E" x="150" y="0"/><node id="S" x="0" y="-150"/>'
                                      '<node id="N" x="0" y="150"/></nodes>')
    bike = '<lane index="0" allow="bicycle" width="1.5"/>'
    (folder / "b.edg.xml").write_text(
        f'<edges><edge id="WA" from="W" to="A" numLanes="2" speed="13.89">{bike}</edge>'
        f'<edge id="AE" from="A" to="E" numLanes="2" speed="13.89">{bike}</edge>'
        '<edge id="AS" from="A" to="S" numLanes="1" speed="13.89"/><edge id="NA" from="N" to="A" numLanes="1" '
        'speed="13.89"/></edges>')
    (folder / "b.con.xml").write_text("<connections>" + "".join(
        f'<connection from="{a}" to="{b}" fromLane="{i}" toLane="{j}"/>'
        for a, b, i, j in (("WA", "AE", 0, 0), ("WA", "AE", 1, 1), ("WA", "AS", 1, 0), ("NA", "AS", 0, 0),
                           ("NA", "AE", 0, 1))) + "</connections>")
    net = folder / "bike.net.xml"
    subprocess.run([sumolib.checkBinary("netconvert"), "-n", "b.nod.xml", "-e", "b.edg.xml", "-x", "b.con.xml",
                    "--no-turnarounds", "-o", net.name], cwd=folder, check=True, capture_output=True)
    return net


def _right_hook(folder: Path, crossing: bool):
    """An AV turning right at A from 60 m up WA at 10 m/s; a cyclist on WA's bicycle lane at
    5 m/s, 126 m up, riding straight on: they reach the bicycle lane's crossing together. The
    bicycle lane is on no movement path of the controller's (cars only), so it does not track the
    cyclist. (summary, trajectories, SUMO's collision records.)"""
    folder.mkdir()
    net = _bike_lane(folder)
    routes = folder / "demand.rou.xml"
    routes.write_text(f'<routes>\n{VTYPE}\n<vType id="bike" vClass="bicycle" length="1.6" width="0.65" minGap="0.5" '
                      'maxSpeed="5.5"/>\n<vehicle id="bike" type="bike" depart="0" departLane="0" departPos="126" '
                      'departSpeed="5"><route edges="WA AE"/></vehicle>\n<vehicle id="av" type="car" depart="0" '
                      'departLane="1" departPos="60" departSpeed="10"><route edges="WA AS"/></vehicle>\n</routes>\n')
    data = {"scenario": {"name": "right_hook", "duration": 30.0, "drain": 30.0, "seed": 1},
            "controller": {"kind": "nash", "budget_ms": 2000.0, "onboard": {"crossing": crossing}},
            "network": {"file": str(net), "junctions": ["A"], "routes": str(routes),
                        "desired_speed": "v_max"}}  # the scene is timed for an AV at 10 m/s
    out = folder / "run"
    summary = run_scenario(scenario_from_dict(data, "<right hook>"), out)
    return summary, pd.read_csv(out / "trajectories.csv"), read_collisions(out / "collisions.xml")


def test_an_av_turning_across_a_bicycle_lane_lets_the_cyclist_on_it_pass(tmp_path):
    """The right hook: the controller does not see the cyclist; the onboard guard's crossing sense
    does (SUMO gives the cyclist the right of way over the turning car) and holds the AV before
    the bicycle lane until the cyclist has passed. Without the sense, the same scene collides."""
    summary, traj, collisions = _right_hook(tmp_path / "on", crossing=True)
    assert summary["counts"]["departed"] == summary["counts"]["arrived"] == 2
    assert _records(collisions) == [], f"SUMO's collisions {_records(collisions)}"
    assert summary["collisions"]["overlap_pairs_commanded"] == 0
    assert "bike" not in set(traj["vehicle"])  # never tracked by the controller
    assert summary["counts"]["onboard_crossing_caps"] > 10
    av = traj[traj["vehicle"] == "av"]
    assert av["speed"].min() < 1.0  # [m/s] it waited for the cyclist (inside A, short of the bicycle lane)
    off, _, _ = _right_hook(tmp_path / "off", crossing=False)
    assert off["collisions"]["sumo_records_commanded"] > 0  # the scene is a threat: without the sense it collides


def _narrowing(folder: Path) -> Path:
    """A at x = 0, B at x = 10 on the eastbound road, so close that the link AB between their
    boxes is 0.2 m long (as between some of InTAS Ingolstadt's junctions): WA (two lanes; lane 1
    onto either lane of AB, lane 0 onto AB's lane 0), AB (two lanes, both onto BE's one lane),
    BE; a southbound street through each. Priority junctions."""
    nodes = [("A", 0, 0, "priority"), ("B", 10, 0, "priority"), ("W", -200, 0, None), ("E", 160, 0, None),
             ("NA", 0, 150, None), ("SA", 0, -150, None), ("NB", 10, 150, None), ("SB", 10, -150, None)]
    edges = [("WA", "W", "A", 2), ("AB", "A", "B", 2), ("BE", "B", "E", 1), ("NAA", "NA", "A", 1),
             ("ASA", "A", "SA", 1), ("NBB", "NB", "B", 1), ("BSB", "B", "SB", 1)]
    connections = [("WA", "AB", 0, 0), ("WA", "AB", 1, 0), ("WA", "AB", 1, 1), ("AB", "BE", 0, 0),
                   ("AB", "BE", 1, 0), ("NAA", "ASA", 0, 0), ("NBB", "BSB", 0, 0)]
    return plain_net(folder, "narrowing", nodes, edges, connections)


def test_an_exit_lane_chosen_at_one_junction_is_not_enforced_at_the_next(tmp_path, monkeypatch):
    """AVs from WA's lane 1 choose their lane of AB at A (lane 1, the straight-on preference);
    at B both of AB's lanes lead onto BE's one lane, so that choice names no lane of B. A SUMO
    step takes a vehicle from A's box over the 0.2 m link straight into B's. Every
    SUMO step a vehicle on a managed path is on a lane of it (in B's box: B's path, not A's),
    the AVs in B's box are B's, and all arrive without a collision. (Before, the choice made at
    A was enforced at B, found no connection there and left the vehicle on A's path: A went on
    commanding it through B's box, at an arc length read off B's internal lane.)"""
    net = _narrowing(tmp_path)
    off_path, in_b = [], {}
    advance = SumoSimulation.advance

    def checked(sim):
        advance(sim)
        for vid, pid in sim.current_path.items():
            lane = sim.states[vid][libsumo.VAR_LANE_ID] if vid in sim.states else None
            if lane is not None and lane not in sim.paths[pid].lanes:
                off_path.append((round(sim.time, 2), vid, pid, lane))
            if lane is not None and lane.startswith(":B_") and vid in sim.owner:
                in_b.setdefault(vid, set()).add(sim.owner[vid])

    monkeypatch.setattr(SumoSimulation, "advance", checked)
    east = [(1.5 * i, f'<vehicle id="e{i}" type="car" depart="{1.5 * i:.1f}" departLane="1" departSpeed="10">'
                      '<route edges="WA AB BE"/></vehicle>') for i in range(4)]
    summary, traj, collisions = _run(tmp_path, net, _routes(tmp_path, east), 100.0)
    assert _edge_length(net, "AB") < 0.5  # [m]
    assert "WA_1>AB_1" in set(traj.loc[traj["lane"].str.startswith(":A_"), "path"])  # A chose AB's lane 1
    assert off_path == [], f"vehicles off their path's lanes: {len(off_path)}, first {off_path[:3]}"
    assert set(traj.loc[traj["lane"].str.startswith(":B_"), "path"]) == {"AB_1>BE_0"}  # B's path in B's box
    assert in_b and all(owners == {"B"} for owners in in_b.values()), in_b
    assert summary["counts"]["departed"] == summary["counts"]["arrived"] == 4
    assert _records(collisions) == [], f"SUMO's collisions {_records(collisions)}"
