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
     'safety_margin = 2.0\n' + GOOD_VEHICLE, "controller.policy.safety_margin", "2.0: moved to [controller.safety]"),
    ("a policy key in the solver table", HEADER + '[controller]\nkind = "stackelberg"\n[controller.solver]\n'
     'solo_max_iter = 2\n' + GOOD_VEHICLE, "controller.solver.solo_max_iter", "2: moved to [controller.policy]"),
    ("an unknown key of a sub-table", HEADER + '[controller]\nkind = "nash"\n[controller.safety]\ngap = 2.0\n'
     + GOOD_VEHICLE, "controller.safety.gap", "2.0"),
    ("a bad value in a sub-table", HEADER + '[controller]\nkind = "nash"\n[controller.safety]\nyield_order = "fifo"\n'
     + GOOD_VEHICLE, "controller.safety.yield_order", "'fifo'"),
    ("a table fcfs does not take", HEADER + '[controller]\nkind = "fcfs"\n[controller.policy]\nsolo_max_iter = 2\n'
     + GOOD_VEHICLE, "controller.policy.solo_max_iter", "only [controller.solver]"),
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
