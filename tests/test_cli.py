"""The command line's help: what a user sees first."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from intersection_cosim.cli import main
from intersection_cosim.control import registry

COMMANDS = ("net", "run", "sweep", "compare", "report", "animate", "junctions")


def _help(capsys, *argv: str) -> str:
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--help"])
    assert exc.value.code == 0
    return capsys.readouterr().out


def test_top_level_help_lists_every_command_with_one_example(capsys):
    text = _help(capsys)
    assert "``" not in text and "thin" not in text  # not the module's developer docstring
    assert "Hang et al." in text
    examples = text[text.index("examples:"):]
    for command in COMMANDS:
        assert re.search(rf"^ +{command} +\S", text, re.M), command  # listed with its one-line help
        assert len(re.findall(rf"^  intersection-cosim {command} ", examples, re.M)) == 1, command


def test_run_help_lists_the_registry_controllers(capsys):
    text = _help(capsys, "run")
    listed = text[text.index("controllers ("):]
    for name in registry.names():
        line = next(ln for ln in listed.splitlines() if ln.split()[:1] == [name])
        assert registry.get(name).description in line
    assert "--force" in text


def test_sweep_help_spells_controllers_as_compare(capsys):
    assert "--controllers K1,K2" in _help(capsys, "sweep")
    assert "--controllers K1,K2" in _help(capsys, "compare")


def test_junctions_lists_a_net_named_through_sumo_home(capsys, monkeypatch):
    import sumo

    monkeypatch.delenv("SUMO_HOME", raising=False)  # falls back to the eclipse-sumo package's
    assert main(["junctions", "$SUMO_HOME/tools/game/cross/cross.net.xml"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["id", "type", "arms", "in", "out", "lanes_in", "lanes_out", "connections",
                                "manageable", "reason"]
    assert [ln.split() for ln in lines[1:]] == [["0", "traffic_light", "4", "4", "4", "10", "4", "12", "True"]]
    monkeypatch.setenv("SUMO_HOME", sumo.SUMO_HOME)
    assert main(["junctions", "${SUMO_HOME}/tools/game/cross/cross.net.xml", "--all"]) == 0
    out = capsys.readouterr().out
    assert len(out.splitlines()) == 1 + 9 and "dead end" in out


def test_junctions_of_a_missing_net_is_one_line_and_status_2(capsys, tmp_path):
    assert main(["junctions", str(tmp_path / "none.net.xml")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "no such file" in err


def test_junctions_of_a_file_without_edges_is_one_line_and_status_2(capsys):
    routes = Path(__file__).resolve().parents[1] / "scenarios" / "fokr38_people_low.rou.xml"
    assert main(["junctions", str(routes)]) == 2  # a route file: sumolib reads it as a net without edges
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "fokr38_people_low.rou.xml" in lines[0] and "no edges" in lines[0]


def test_bare_command_prints_the_usage_and_every_command(capsys):
    assert main([]) == 0
    text = capsys.readouterr().out
    assert text.startswith("usage: intersection-cosim")
    for command in COMMANDS:
        assert re.search(rf"^ +{command} +\S", text, re.M), command
