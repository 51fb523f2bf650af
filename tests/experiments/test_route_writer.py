"""write_routes on a [network] file net: SUMO accepts what it writes; a user route file rides along."""

import dataclasses
import os
import re
import subprocess
import textwrap
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import sumo

from intersection_cosim.experiments.files import ROUTE_FILE, route_files, write_routes, write_sumocfg
from intersection_cosim.network.build import build_network
from intersection_cosim.network.paths import load_paths
from intersection_cosim.scenario import load_scenario
from intersection_cosim.scenario.draws import generate_flow_vehicles

SUMO_BIN = os.path.join(str(sumo.SUMO_HOME), "bin", "sumo")
CROSS = Path(sumo.SUMO_HOME) / "tools/game/cross/cross.net.xml"
SCENARIO = """
[scenario]
name = "cross"
duration = 20.0
seed = 3

[network]
file = "$SUMO_HOME/tools/game/cross/cross.net.xml"
junctions = ["0"]
{routes}

[[flow]]
id = "west"
from = "1fi"
to = "2o"
rate = 720
kappa = 0.5

[[flow]]
id = "south"
route = ["3si", "4o"]
rate = 360
kappa = 0.5
lane = 1
speed = 8.0
pos = 10.0

[[vehicle]]
id = "A"
edge = "1si"
lane = 1
pos = 100.0
to = "2o"
speed = 5.0
kappa = 0.4

[[vehicle]]
id = "B"
position = [300.0, 214.1]
route = ["2si", "4o"]
speed = 4.0
kappa = 0.6
depart = 1.0
"""


def _scenario(folder: Path, routes: str = ""):
    path = folder / "scenario.toml"
    path.write_text(textwrap.dedent(SCENARIO.format(routes=routes)))
    scn = load_scenario(path)
    return scn, generate_flow_vehicles(scn, np.random.default_rng(scn.scenario.seed))


def _sumo(net: Path, routes: list[str], end: float, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([SUMO_BIN, "-n", str(net), "-r", ",".join(routes), "--end", f"{end:g}",
                           "--no-step-log", "true", "--duration-log.statistics", "true"],
                          capture_output=True, text=True, timeout=60, cwd=cwd,
                          env={**os.environ, "SUMO_HOME": str(sumo.SUMO_HOME)})


def _loaded(proc: subprocess.CompletedProcess) -> int:
    """Vehicles SUMO loaded ("Inserted: 7 (Loaded: 13)", or "Inserted: 13" when all were inserted)."""
    match = re.search(r"Inserted: (\d+)(?: \(Loaded: (\d+)\))?", proc.stdout)
    return int(match.group(2) or match.group(1))


def test_generic_routes_are_what_sumo_accepts(tmp_path):
    scn, flow_vehicles = _scenario(tmp_path)
    write_routes(tmp_path / ROUTE_FILE, scn, {}, flow_vehicles)
    root = ET.parse(tmp_path / ROUTE_FILE).getroot()
    vehicles = {el.get("id"): el for el in root.iter("vehicle")}
    a, b = vehicles["A"], vehicles["B"]
    assert {k: a.get(k) for k in ("type", "depart", "departLane", "departPos", "departSpeed")} == {
        "type": "av", "depart": "0", "departLane": "1", "departPos": "100.00", "departSpeed": "5"}
    assert a.find("route").get("edges") == "1si 2o"
    assert (b.get("departLane"), b.get("departPos"), b.get("depart")) == ("0", "42.74", "1")
    assert b.find("route").get("edges") == "2si 4o"
    west = [el for vid, el in vehicles.items() if vid.startswith("west.")]
    south = [el for vid, el in vehicles.items() if vid.startswith("south.")]
    assert len(west) + len(south) == len(flow_vehicles) and west and south
    insertion = ("departLane", "departPos", "departSpeed")
    assert {tuple(el.get(k) for k in insertion) for el in west} == {("best", "base", "max")}
    assert {tuple(el.get(k) for k in insertion) for el in south} == {("1", "10.00", "8")}
    assert {el.find("route").get("edges") for el in west} == {"1fi 1si 2o"}
    departs = [float(el.get("depart")) for el in root.iter("vehicle")]
    assert departs == sorted(departs)
    assert root.find("vType").get("id") == "av"

    assert _sumo(CROSS, [ROUTE_FILE], 1, tmp_path).returncode == 0
    proc = _sumo(CROSS, [ROUTE_FILE], 20, tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "Error" not in proc.stderr
    assert _loaded(proc) == 2 + len(flow_vehicles)


def test_a_user_route_file_is_listed_not_copied(tmp_path):
    (tmp_path / "bg.rou.xml").write_text('<routes><vType id="car"/><flow id="bg" type="car" begin="0" end="20" '
                                         'vehsPerHour="720" from="4fi" to="3fo"/></routes>')
    scn, flow_vehicles = _scenario(tmp_path, 'routes = "bg.rou.xml"')
    assert route_files(scn) == [ROUTE_FILE, str((tmp_path / "bg.rou.xml").resolve())]
    run = tmp_path / "run"
    run.mkdir()
    write_routes(run / ROUTE_FILE, scn, {}, flow_vehicles)
    assert "bg" not in (run / ROUTE_FILE).read_text()
    write_sumocfg(run / "scenario.sumocfg", str(CROSS), scn)
    cfg = ET.parse(run / "scenario.sumocfg").getroot()
    assert cfg.find("input/route-files").get("value") == f"{ROUTE_FILE},{(tmp_path / 'bg.rou.xml').resolve()}"
    proc = _sumo(CROSS, route_files(scn), 20, run)
    assert proc.returncode == 0, proc.stderr
    assert _loaded(proc) == 2 + len(flow_vehicles) + 4  # bg: 720 veh/h for 20 s


def test_paper_scenarios_list_only_their_own_route_file():
    scn = load_scenario(Path(__file__).resolve().parents[2] / "scenarios" / "case1_A.toml")
    assert route_files(scn) == [ROUTE_FILE]


def test_a_flow_of_a_vtype_of_the_user_route_file(tmp_path):
    """``vtype = "lorry"`` may name a vType of ``[network] routes``: its body is read for the
    scenario (length, width, accel, decel), no copy is written, and the user's file is loaded
    first so SUMO knows the type before the flow's first vehicle."""
    (tmp_path / "bg.rou.xml").write_text('<routes><vType id="lorry" length="10" width="2.4" accel="1.1"/>'
                                         '</routes>')
    path = tmp_path / "scenario.toml"
    path.write_text(textwrap.dedent(SCENARIO.format(routes='routes = "bg.rou.xml"')).replace(
        'id = "west"', 'id = "west"\nvtype = "lorry"'))
    scn = load_scenario(path)
    lorry = scn.vtype("lorry")
    assert (lorry.length, lorry.width, lorry.accel, lorry.decel, lorry.from_routes) == (10.0, 2.4, 1.1, 4.5, True)
    assert scn.flows[0].vtype == "lorry"
    assert route_files(scn) == [str((tmp_path / "bg.rou.xml").resolve()), ROUTE_FILE]
    flow_vehicles = generate_flow_vehicles(scn, np.random.default_rng(scn.scenario.seed))
    run = tmp_path / "run"
    run.mkdir()
    write_routes(run / ROUTE_FILE, scn, {}, flow_vehicles)
    root = ET.parse(run / ROUTE_FILE).getroot()
    assert [el.get("id") for el in root.iter("vType")] == ["av"]
    assert {el.get("type") for el in root.iter("vehicle") if el.get("id").startswith("west.")} == {"lorry"}
    proc = _sumo(CROSS, route_files(scn), 20, run)
    assert proc.returncode == 0, proc.stderr
    assert _loaded(proc) == 2 + len(flow_vehicles)


def test_the_av_vtype_takes_the_games_acceleration_limits(tmp_path):
    """vType av's accel / decel are the game's a_max / -a_min: the defaults 2.5 / 4.0, or the
    [controller.game] table's; a [[vtype]] without its own takes them too."""
    base = Path(__file__).resolve().parents[2] / "scenarios" / "case1_A.toml"
    text = base.read_text() + '\n[[vtype]]\nid = "van"\nlength = 6.0\n'
    for game, expected in (("", ("2.5", "4")), ("[controller.game]\na_max = 2.0\na_min = -3.5\n", ("2", "3.5"))):
        path = tmp_path / "s.toml"
        path.write_text(text + "\n" + game)
        scn = load_scenario(path)
        vehicles = [dataclasses.replace(v, vtype="van") if v.id == "V1" else v for v in scn.vehicles]
        scn = dataclasses.replace(scn, vehicles=tuple(vehicles))
        write_routes(tmp_path / ROUTE_FILE, scn, load_paths(build_network(tmp_path / "net")), [])
        types = {el.get("id"): el for el in ET.parse(tmp_path / ROUTE_FILE).getroot().iter("vType")}
        for vid in ("av", "van"):
            assert (types[vid].get("accel"), types[vid].get("decel")) == expected
