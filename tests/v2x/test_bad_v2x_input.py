"""Bad [v2x] input: one line naming the file, the field and the value; exit status 2; nothing on disk."""

import textwrap

import pytest

from intersection_cosim.cli import main

SCENARIO = """
[scenario]
name = "bad_v2x"
duration = 5.0

[[vehicle]]
id = "V1"
approach = "south"
lane = "inner"
distance = 13.0
movement = "left"
speed = 5.5
kappa = 0.5

[[flow]]
id = "F"
approach = "north"
movement = "straight"
rate = 360
kappa = 0.5
"""

ATTACK = '\n[[v2x.attack]]\nvehicle = "V1"\nkind = "position_offset"\nvalue = 5.0\nbegin = 1.0\nend = 3.0\n'

# (label, appended text, field expected in the message, value expected in the message)
CASES = [
    ("negative latency", "\n[v2x]\nlatency = -0.1\n", "v2x.latency", "-0.1"),
    ("loss above 1", "\n[v2x]\nloss = 1.5\n", "v2x.loss", "1.5"),
    ("loss below 0", "\n[v2x]\nloss = -0.2\n", "v2x.loss", "-0.2"),
    ("unknown v2x key", "\n[v2x]\nlatncy = 0.1\n", "v2x.latncy", "0.1"),
    ("unknown attack kind", ATTACK.replace("position_offset", "jamming"), "v2x.attack[0].kind", "'jamming'"),
    ("attack on no vehicle", ATTACK.replace('"V1"', '"V9"'), "v2x.attack[0].vehicle", "'V9'"),
    ("attack on a flow id without index", ATTACK.replace('"V1"', '"F"'), "v2x.attack[0].vehicle", "'F'"),
    ("attack begins after its end", ATTACK.replace("begin = 1.0", "begin = 4.0"), "v2x.attack[0].begin", "4.0"),
    ("unknown attack key", ATTACK.replace("value = 5.0", "valu = 5.0"), "v2x.attack[0].valu", "5.0"),
    ("attack not a table array", '\n[v2x]\nattack = 3\n', "v2x.attack", "3"),
    ("attack on a flow vehicle the seed does not draw", ATTACK.replace('"V1"', '"F.999"'),
     "v2x.attack[0].vehicle", "'F.999'"),
]


@pytest.mark.parametrize("label,extra,field,value", CASES, ids=[c[0] for c in CASES])
def test_bad_v2x_table(tmp_path, capsys, label, extra, field, value):
    scenario = tmp_path / "scenario.toml"
    scenario.write_text(textwrap.dedent(SCENARIO) + extra)
    rc = main(["run", str(scenario), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert str(scenario) in lines[0] and field in lines[0] and value in lines[0], lines[0]
    assert "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scenario.toml"]  # nothing written


def test_good_v2x_table_loads(tmp_path):
    from intersection_cosim.scenario import load_scenario

    scenario = tmp_path / "scenario.toml"
    scenario.write_text(textwrap.dedent(SCENARIO) + "\n[v2x]\nlatency = 0.2\nloss = 0.1\n" + ATTACK.replace(
        '"V1"', '"F.0"'))
    v2x = load_scenario(scenario).v2x
    assert (v2x.latency, v2x.loss, v2x.plausibility, v2x.enabled) == (0.2, 0.1, True, True)
    assert [(a.vehicle, a.kind, a.value, a.begin, a.end) for a in v2x.attack] == [
        ("F.0", "position_offset", 5.0, 1.0, 3.0)]
    assert load_scenario(tmp_path / "scenario.toml").v2x.period == 0.0


def test_no_v2x_table_is_perfect_information(tmp_path):
    from intersection_cosim.scenario import load_scenario

    scenario = tmp_path / "scenario.toml"
    scenario.write_text(textwrap.dedent(SCENARIO))
    assert not load_scenario(scenario).v2x.enabled
