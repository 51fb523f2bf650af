"""Bad input: one line naming the file, the field and the value; exit status 2; nothing on disk."""

import subprocess
import sys
import textwrap

import pytest

from intersection_cosim.cli import main

GOOD_VEHICLE = """
[[vehicle]]
id = "V1"
approach = "south"
lane = "inner"
distance = 13.0
movement = "left"
speed = 5.5
kappa = 0.5
"""

BUS = """
[[vtype]]
id = "bus"
length = 12.0
width = 2.5
accel = 1.2
decel = 4.0
kappa = 0.3
"""

HEADER = """
[scenario]
name = "bad"
duration = 5.0
"""

# (label, scenario text, field expected in the message, value expected in the message)
CASES = [
    ("unknown top-level key", HEADER + "[foo]\nx = 1\n" + GOOD_VEHICLE, "foo", "{'x': 1}"),
    ("unknown scenario key", "[scenario]\ndurtion = 5.0\n" + GOOD_VEHICLE, "scenario.durtion", "5.0"),
    ("unknown vehicle key", HEADER + GOOD_VEHICLE.replace("speed = 5.5", "sped = 5.5"), "vehicle[0].sped", "5.5"),
    ("unknown model key", HEADER + "[model]\nk_lattt = 2.0\n" + GOOD_VEHICLE, "model.k_lattt", "2.0"),
    ("unknown controller kind", HEADER + '[controller]\nkind = "magic"\n' + GOOD_VEHICLE, "controller.kind", "'magic'"),
    ("kappa above 1", HEADER + GOOD_VEHICLE.replace("kappa = 0.5", "kappa = 1.5"), "vehicle[V1].kappa", "1.5"),
    ("kappa below 0", HEADER + GOOD_VEHICLE.replace("kappa = 0.5", "kappa = -0.1"), "vehicle[V1].kappa", "-0.1"),
    ("unknown approach", HEADER + GOOD_VEHICLE.replace('"south"', '"southwest"'), "vehicle[V1].approach", "'southwest'"),
    ("unknown lane", HEADER + GOOD_VEHICLE.replace('"inner"', '"fast"'), "vehicle[V1].lane", "'fast'"),
    ("unknown movement", HEADER + GOOD_VEHICLE.replace('"left"', '"uturn"'), "vehicle[V1].movement", "'uturn'"),
    ("movement the lane cannot make", HEADER + GOOD_VEHICLE.replace('"inner"', '"middle"'), "vehicle[V1].movement", "'left'"),
    ("duplicate ids", HEADER + GOOD_VEHICLE + GOOD_VEHICLE.replace("13.0", "40.0"), "vehicle.id", "'V1'"),
    ("too close on one lane", HEADER + GOOD_VEHICLE + GOOD_VEHICLE.replace('"V1"', '"V2"').replace("13.0", "16.0"),
     "vehicle[V2].position", "["),
    ("negative speed", HEADER + GOOD_VEHICLE.replace("speed = 5.5", "speed = -1.0"), "vehicle[V1].speed", "-1.0"),
    ("zero desired speed", HEADER + GOOD_VEHICLE.replace("speed = 5.5", "speed = 0.0\ndesired_speed = 0.0"),
     "vehicle[V1].desired_speed", "0.0"),
    ("start above desired speed", HEADER + GOOD_VEHICLE.replace("speed = 5.5", "speed = 5.5\ndesired_speed = 4.0"),
     "vehicle[V1].speed", "5.5"),
    ("negative work clock", HEADER + "[controller]\nwork_clock_ms = -0.5\n" + GOOD_VEHICLE,
     "controller.work_clock_ms", "-0.5"),
    ("negative rate", HEADER + '[[flow]]\napproach = "north"\nmovement = "straight"\nrate = -100\nkappa = 0.5\n',
     "flow[0].rate", "-100"),
    ("flow kappa outside", HEADER + '[[flow]]\napproach = "north"\nmovement = "straight"\nrate = 100\n'
     'kappa = {dist = "uniform", low = 0.2, high = 1.2}\n', "flow[0].kappa.high", "1.2"),
    ("position off every path", HEADER + GOOD_VEHICLE.replace('approach = "south"\nlane = "inner"\ndistance = 13.0',
     "position = [4.0, -30.0]"), "vehicle[V1].position", "[4.0, -30.0]"),
    ("wrong type", HEADER.replace("5.0", '"long"') + GOOD_VEHICLE, "scenario.duration", "'long'"),
    ("malformed TOML", HEADER + "[[vehicle]\nid = 1\n", "toml", "line"),
    ("a game key in the solver table", HEADER + '[controller]\nkind = "nash"\n[controller.solver]\nhorizon = 4.0\n'
     + GOOD_VEHICLE, "controller.solver.horizon", "4.0: moved to [controller.game]"),
    ("a safety key in the policy table", HEADER + '[controller]\nkind = "nash"\n[controller.policy]\n'
     'margin = 2.0\n' + GOOD_VEHICLE, "controller.policy.margin", "2.0: moved to [controller.safety]"),
    ("a policy key in the solver table", HEADER + '[controller]\nkind = "stackelberg"\n[controller.solver]\n'
     'solo_max_iter = 2\n' + GOOD_VEHICLE, "controller.solver.solo_max_iter", "2: moved to [controller.policy]"),
    ("a negative solo_reuse_residual", HEADER + '[controller]\nkind = "nash"\n[controller.policy]\n'
     'solo_reuse_residual = -0.3\n' + GOOD_VEHICLE, "controller.policy.solo_reuse_residual", "-0.3"),
    ("an unknown key of a sub-table", HEADER + '[controller]\nkind = "nash"\n[controller.safety]\ngap = 2.0\n'
     + GOOD_VEHICLE, "controller.safety.gap", "2.0"),
    ("a bad value in a sub-table", HEADER + '[controller]\nkind = "nash"\n[controller.safety]\nyield_order = "fifo"\n'
     + GOOD_VEHICLE, "controller.safety.yield_order", "'fifo'"),
    ("av_share above 1", HEADER + '[[flow]]\napproach = "north"\nmovement = "straight"\nrate = 100\nkappa = 0.5\n'
     'av_share = 1.5\n', "flow[0].av_share", "1.5"),
    ("av_share below 0", HEADER + '[[flow]]\napproach = "north"\nmovement = "straight"\nrate = 100\nkappa = 0.5\n'
     'av_share = -0.2\n', "flow[0].av_share", "-0.2"),
    ("av_share not a number", HEADER + '[[flow]]\napproach = "north"\nmovement = "straight"\nrate = 100\nkappa = 0.5\n'
     'av_share = "half"\n', "flow[0].av_share", "'half'"),
    ("bad driver", HEADER + GOOD_VEHICLE.replace("kappa = 0.5", 'kappa = 0.5\ndriver = "robot"'),
     "vehicle[V1].driver", "'robot'"),
    ("unknown human model", HEADER + '[human]\nmodel = "Wiedemann"\n' + GOOD_VEHICLE, "human.model", "'Wiedemann'"),
    ("unknown human key", HEADER + '[human]\nreaction = 1.0\n' + GOOD_VEHICLE, "human.reaction", "1.0"),
    ("human sigma above 1", HEADER + '[human]\nsigma = 1.5\n' + GOOD_VEHICLE, "human.sigma", "1.5"),
    ("a table fcfs does not take", HEADER + '[controller]\nkind = "fcfs"\n[controller.policy]\nsolo_max_iter = 2\n'
     + GOOD_VEHICLE, "controller.policy.solo_max_iter", "only [controller.solver]"),
    # vehicle types (issue 16)
    ("an unknown vtype of a vehicle", HEADER + BUS + GOOD_VEHICLE.replace("kappa = 0.5", 'kappa = 0.5\nvtype = "tram"'),
     "vehicle[0].vtype", "'tram'"),
    ("an unknown vtype of a flow", HEADER + BUS + '[[flow]]\napproach = "north"\nmovement = "straight"\nrate = 100\n'
     'kappa = 0.5\nvtype = "lorry"\n', "flow[0].vtype", "'lorry'"),
    ("a vtype of negative length", HEADER + BUS.replace("length = 12.0", "length = -12.0") + GOOD_VEHICLE,
     "vtype[bus].length", "-12.0"),
    ("a vtype of negative accel", HEADER + BUS.replace("accel = 1.2", "accel = -1.2") + GOOD_VEHICLE,
     "vtype[bus].accel", "-1.2"),
    ("a vtype of zero decel", HEADER + BUS.replace("decel = 4.0", "decel = 0.0") + GOOD_VEHICLE,
     "vtype[bus].decel", "0.0"),
    ("an unknown vtype field", HEADER + BUS.replace("width = 2.5", "widht = 2.5") + GOOD_VEHICLE,
     "vtype[bus].widht", "2.5"),
    ("a vtype without id", HEADER + BUS.replace('id = "bus"\n', "") + GOOD_VEHICLE, "vtype[0].id", "None"),
    ("a vtype named av", HEADER + BUS.replace('id = "bus"', 'id = "av"') + GOOD_VEHICLE, "vtype[0].id", "'av'"),
    ("a vtype length as text", HEADER + BUS.replace("length = 12.0", 'length = "long"') + GOOD_VEHICLE,
     "vtype[bus].length", "'long'"),
    ("a vtype kappa above 1", HEADER + BUS.replace("kappa = 0.3", "kappa = 1.3") + GOOD_VEHICLE,
     "vtype[bus].kappa", "1.3"),
    ("an unknown vtype driver", HEADER + BUS + '[[vtype]]\nid = "tram"\ndriver = "robot"\n' + GOOD_VEHICLE,
     "vtype[tram].driver", "'robot'"),
    ("a human vtype's vehicle said to be an AV", HEADER + '[[vtype]]\nid = "hcar"\ndriver = "human"\n'
     + GOOD_VEHICLE.replace("kappa = 0.5", 'kappa = 0.5\nvtype = "hcar"\ndriver = "av"'), "vehicle[0].driver", "'av'"),
    ("av_share on a human vtype's flow", HEADER + '[[vtype]]\nid = "hcar"\ndriver = "human"\n[[flow]]\n'
     'approach = "north"\nmovement = "straight"\nrate = 100\nkappa = 0.5\nvtype = "hcar"\nav_share = 0.5\n',
     "flow[0].av_share", "0.5"),
    ("a vehicle of a vtype without kappa gives none", HEADER + '[[vtype]]\nid = "van"\nlength = 6.0\n'
     + GOOD_VEHICLE.replace("kappa = 0.5", 'vtype = "van"'), "vehicle[V1].kappa", "None"),
]


def _run(tmp_path, text, capsys):
    scenario = tmp_path / "scenario.toml"
    scenario.write_text(textwrap.dedent(text))
    out = tmp_path / "out"
    rc = main(["run", str(scenario), "--out", str(out)])
    err = capsys.readouterr().err
    return rc, err, scenario, out


@pytest.mark.parametrize("label,text,field,value", CASES, ids=[c[0] for c in CASES])
def test_bad_scenario(tmp_path, capsys, label, text, field, value):
    rc, err, scenario, out = _run(tmp_path, text, capsys)
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert str(scenario) in lines[0]
    assert field in lines[0]
    assert value in lines[0]
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scenario.toml"]  # nothing written


def test_missing_file(tmp_path, capsys):
    rc = main(["run", str(tmp_path / "nope.toml"), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1
    assert "nope.toml" in err and "no such file" in err
    assert list(tmp_path.iterdir()) == []


def test_a_file_name_the_system_refuses_is_one_line(tmp_path, capsys):
    """A shell that did not expand a brace list hands over one name longer than the system allows."""
    name = "scenarios/{" + ",".join(f"demand_{n}" for n in range(40)) + "}.toml"
    rc = main(["compare", name, "--controllers", "nash", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "Traceback" not in err
    assert "cannot be read (File name too long)" in err
    assert list(tmp_path.iterdir()) == []


def test_unwritable_output_directory(tmp_path, capsys):
    scenario = tmp_path / "scenario.toml"
    scenario.write_text(HEADER + GOOD_VEHICLE)
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    out = blocker / "run"
    rc = main(["run", str(scenario), "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1
    assert "--out" in err and str(out) in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file", "scenario.toml"]


def test_bad_command_line_values(tmp_path, capsys):
    scenario = tmp_path / "scenario.toml"
    scenario.write_text(HEADER + GOOD_VEHICLE)
    assert main(["run", str(scenario), "--controller", "nope", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "--controller" in err and "'nope'" in err
    assert main(["run", str(scenario), "--seed", "-4", "--out", str(tmp_path / "o")]) == 2
    assert "--seed" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_console_script_prints_no_traceback(tmp_path):
    scenario = tmp_path / "scenario.toml"
    scenario.write_text(HEADER + GOOD_VEHICLE.replace("kappa = 0.5", "kappa = 2"))
    proc = subprocess.run([sys.executable, "-m", "intersection_cosim", "run", str(scenario),
                           "--out", str(tmp_path / "o")], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert "vehicle[V1].kappa = 2" in proc.stderr


# ---- [network] and demand by edge ids (SUMO's cross example: junction "0", edges 1fi -> 1si -> 0 -> 2o ...)

NET = """
[scenario]
name = "bad"
duration = 5.0

[network]
file = "$SUMO_HOME/tools/game/cross/cross.net.xml"
junctions = ["0"]
"""

GOOD_FLOW = """
[[flow]]
from = "1fi"
to = "2o"
rate = 300
kappa = 0.5
"""

GOOD_EDGE_VEHICLE = """
[[vehicle]]
id = "A"
edge = "1si"
lane = 1
pos = 100.0
to = "3o"
speed = 5.0
kappa = 0.5
"""

BAD_ROUTES = '<routes>\n  <vehicle id="x" depart="0"><route edges="1si nowhere"/></vehicle>\n</routes>\n'

# (label, scenario text, extra files {name: text}, field expected in the message, value expected in the message)
NETWORK_CASES = [
    ("net file missing", NET.replace("$SUMO_HOME/tools/game/cross/cross.net.xml", "nope.net.xml") + GOOD_FLOW, {},
     "network.file", "'nope.net.xml': no such file"),
    ("net file malformed", NET.replace("$SUMO_HOME/tools/game/cross/cross.net.xml", "bad.net.xml") + GOOD_FLOW,
     {"bad.net.xml": "<net><edge id="}, "network.file", "'bad.net.xml': is not a SUMO net"),
    ("net file without edges", NET.replace("$SUMO_HOME/tools/game/cross/cross.net.xml", "empty.net.xml") + GOOD_FLOW,
     {"empty.net.xml": "<net version=\"1.20\"/>"}, "network.file", "it has no edges"),
    ("net file is a folder", NET.replace("$SUMO_HOME/tools/game/cross/cross.net.xml", ".") + GOOD_FLOW, {},
     "network.file", "'.': cannot be read"),
    ("unset variable", NET.replace("$SUMO_HOME", "$NO_SUCH_COSIM_VAR") + GOOD_FLOW, {},
     "network.file", "$NO_SUCH_COSIM_VAR is not set"),
    ("av_share above 1 on a net file", NET + GOOD_FLOW + "av_share = 2\n", {}, "flow[0].av_share", "2"),
    ("bad driver on a net file", NET + GOOD_EDGE_VEHICLE + 'driver = "robot"\n', {}, "vehicle[A].driver", "'robot'"),
    ("unknown network key", NET + "junktions = [\"0\"]\n" + GOOD_FLOW, {}, "network.junktions", "unknown key"),
    ("junction not in the net", NET.replace('["0"]', '["m9"]') + GOOD_FLOW, {},
     "network.junctions", "'m9': is not a junction of the net (nearest: 'm4', 'm3', 'm2')"),
    ("a dead end to manage", NET.replace('["0"]', '["1"]') + GOOD_FLOW, {}, "network.junctions",
     "'1': is a dead end"),
    ("no junctions", NET.replace('["0"]', "[]") + GOOD_FLOW, {}, "network.junctions", "[]"),
    ("junctions not a list", NET.replace('["0"]', '"0"') + GOOD_FLOW, {}, "network.junctions", "'0'"),
    ("junctions not strings", NET.replace('["0"]', "[0]") + GOOD_FLOW, {}, "network.junctions", "[0]"),
    ("junctions missing", NET.replace('junctions = ["0"]\n', "") + GOOD_FLOW, {}, "network.junctions", "is required"),
    ("signals neither on nor off", NET + 'signals = "yes"\n' + GOOD_FLOW, {}, "network.signals", "'yes'"),
    ("control range zero", NET + "control_range = 0.0\n" + GOOD_FLOW, {}, "network.control_range", "0.0: must be > 0"),
    ("control range negative", NET + "control_range = -5\n" + GOOD_FLOW, {}, "network.control_range", "-5"),
    ("route file missing", NET + 'routes = "nope.rou.xml"\n' + GOOD_FLOW, {}, "network.routes", "no such file"),
    ("route file not XML", NET + 'routes = "r.rou.xml"\n' + GOOD_FLOW, {"r.rou.xml": "vehicles, please"},
     "network.routes", "is not SUMO routes XML"),
    ("route file not routes", NET + 'routes = "r.rou.xml"\n' + GOOD_FLOW, {"r.rou.xml": "<additional/>"},
     "network.routes", "<additional>, not <routes>"),
    ("route file SUMO refuses", NET + 'routes = "r.rou.xml"\n' + GOOD_FLOW, {"r.rou.xml": BAD_ROUTES},
     "network.routes", "SUMO refuses it: Error: The edge 'nowhere'"),
    ("route file redefines av", NET + 'routes = "r.rou.xml"\n' + GOOD_FLOW,
     {"r.rou.xml": '<routes><vType id="av"/></routes>'},
     "network.routes", "defines vType 'av'"),
    ("route file reuses an id", NET + 'routes = "r.rou.xml"\n' + GOOD_EDGE_VEHICLE,
     {"r.rou.xml": '<routes><trip id="A" depart="0" from="4fi" to="3fo"/></routes>'}, "network.routes", "'A'"),
    ("junctions without a file", HEADER + '[network]\njunctions = ["0"]\n' + GOOD_VEHICLE, {},
     "network.junctions", "['0']: needs network.file"),
    ("routes without a file", HEADER + '[network]\nroutes = "r.rou.xml"\n' + GOOD_VEHICLE, {},
     "network.routes", "needs network.file"),
    ("flow without a route", NET + GOOD_FLOW.replace('"2o"', '"1fo"'), {}, "flow[0].to", "'1fo': no route"),
    ("flow from an unknown edge", NET + GOOD_FLOW.replace('"1fi"', '"1xi"'), {}, "flow[0].from", "'1xi'"),
    ("flow to missing", NET + GOOD_FLOW.replace('to = "2o"\n', ""), {}, "flow[0].to", "is required"),
    ("flow route not connected", NET + '[[flow]]\nroute = ["1fi", "2o"]\nrate = 300\nkappa = 0.5\n', {},
     "flow[0].route[1]", "'2o': is not reached from '1fi'"),
    ("flow route and from", NET + GOOD_FLOW + 'route = ["1si", "2o"]\n', {}, "flow[0].from", "either route"),
    ("flow by approach on a net file", NET + '[[flow]]\napproach = "north"\nmovement = "left"\nrate = 300\n'
     'kappa = 0.5\n', {}, "flow[0].approach", "generated net only"),
    ("flow lane out of range", NET + GOOD_FLOW + "lane = 5\n", {}, "flow[0].lane",
     "5: must be a lane index of edge '1fi'"),
    ("flow pos beyond the edge", NET + GOOD_FLOW + "pos = 41.0\n", {}, "flow[0].pos", "41.0: must be <= 40.7"),
    ("flow speed word", NET + GOOD_FLOW + 'speed = "fast"\n', {}, "flow[0].speed", "'fast'"),
    ("flow unknown key", NET + GOOD_FLOW + "movement_ = 1\n", {}, "flow[0].movement_", "unknown key"),
    ("vehicle on an unknown edge", NET + GOOD_EDGE_VEHICLE.replace('"1si"', '"1sj"'), {}, "vehicle[A].edge",
     "'1sj': is not an edge of the net (nearest: '1si'"),
    ("vehicle lane out of range", NET + GOOD_EDGE_VEHICLE.replace("lane = 1", "lane = 3"), {}, "vehicle[A].lane", "3"),
    ("vehicle pos beyond the lane", NET + GOOD_EDGE_VEHICLE.replace("100.0", "140.0"), {}, "vehicle[A].pos",
     "140.0: must be <= 135.75"),
    ("vehicle position off every lane", NET + GOOD_EDGE_VEHICLE.replace('edge = "1si"\nlane = 1\npos = 100.0',
     "position = [0.0, 0.0]"), {}, "vehicle[A].position", "[0.0, 0.0]: more than 1 m"),
    ("vehicle position and edge", NET + GOOD_EDGE_VEHICLE.replace("lane = 1", "position = [300.0, 214.1]"), {},
     "vehicle[A].edge", "either position"),
    ("vehicle without a destination", NET + GOOD_EDGE_VEHICLE.replace('to = "3o"\n', ""), {}, "vehicle[A].to",
     "is required"),
    ("vehicle route not from its edge", NET + GOOD_EDGE_VEHICLE.replace('to = "3o"', 'route = ["2si", "4o"]'), {},
     "vehicle[A].route", "must start on the vehicle's edge '1si'"),
    ("vehicle to unreachable", NET + GOOD_EDGE_VEHICLE.replace('"3o"', '"1o"'), {}, "vehicle[A].to", "'1o': no route"),
    ("vehicle by movement on a net file", NET + GOOD_EDGE_VEHICLE + 'movement = "left"\n', {}, "vehicle[0].movement",
     "generated net only"),
    ("vehicles too close", NET + GOOD_EDGE_VEHICLE + GOOD_EDGE_VEHICLE.replace('"A"', '"B"').replace("100.0", "102.0"),
     {}, "vehicle[B].pos", "102.0: within 4.5 m of A on lane 1si_1"),
    ("paper flow by a foreign edge", HEADER + '[[flow]]\nfrom = "1si"\nto = "west_out"\nrate = 100\nkappa = 0.5\n', {},
     "flow[0].from", "'1si': is not an entry edge of the generated net"),
    ("paper flow U-turn", HEADER + '[[flow]]\nfrom = "south_in"\nto = "south_out"\nrate = 100\nkappa = 0.5\n', {},
     "flow[0].to", "'south_out': no route from 'south_in'"),
]


@pytest.mark.parametrize("label,text,files,field,value", NETWORK_CASES, ids=[c[0] for c in NETWORK_CASES])
def test_bad_network_or_demand(tmp_path, capsys, label, text, files, field, value):
    for name, content in files.items():
        (tmp_path / name).write_text(content)
    rc, err, scenario, out = _run(tmp_path, text, capsys)
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert str(scenario) in lines[0]
    assert f"{field} = " in lines[0]
    assert value in lines[0]
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["scenario.toml", *files])  # nothing written
