"""`run` into an existing folder: a finished run is kept unless --force; a file or a foreign folder is refused."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from intersection_cosim.cli import main
from intersection_cosim.errors import InputError
from intersection_cosim.experiments.output_folder import prepare_output

CASE1A = str(Path(__file__).resolve().parents[2] / "scenarios" / "case1_A.toml")


def _run(out: Path, *extra: str) -> list[str]:
    return ["run", CASE1A, "--controller", "sumo", "--seed", "3", "--out", str(out), *extra]


def test_run_into_a_finished_run_is_refused_unless_force(tmp_path, capsys):
    """Two SUMO runs of Case 1 A (about a second each)."""
    out = tmp_path / "run"
    assert main(_run(out)) == 0
    summary = out / "summary.json"
    before = summary.stat().st_mtime_ns
    capsys.readouterr()

    assert main(_run(out)) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("intersection-cosim: error: --out")
    assert "holds a finished run" in err and "--force" in err
    assert summary.stat().st_mtime_ns == before  # untouched
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # no temporary folder left

    assert main(_run(out, "--force")) == 0
    assert summary.stat().st_mtime_ns > before
    assert json.loads(summary.read_text())["seed"] == 3
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_prepare_output_refuses_a_file_and_a_foreign_folder(tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match="is a file"):
        prepare_output(tmp_path / "file", force=True)
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "a.txt").write_text("mine")
    with pytest.raises(InputError, match="not a previous run's folder"):
        prepare_output(tmp_path / "notes", force=True)
    (tmp_path / "done").mkdir()
    (tmp_path / "done" / "summary.json").write_text("{}")
    with pytest.raises(InputError, match="--force"):
        prepare_output(tmp_path / "done")
    tmp = prepare_output(tmp_path / "done", force=True)
    assert tmp.parent == tmp_path and tmp.name.startswith(".done.tmp-")
    tmp.rmdir()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["done", "file", "notes"]


def test_a_controller_that_drives_through_kept_lights_is_refused_in_one_line(tmp_path, capsys):
    """signals = "on" keeps a managed junction's lights: SUMO's drivers obey them, but the game
    controllers command their vehicles through the junction and would run them."""
    cross = (Path(__file__).resolve().parents[2] / "scenarios" / "cross_low.toml").read_text()
    assert 'signals = "off"' in cross
    scenario = tmp_path / "lit.toml"
    scenario.write_text(cross.replace('signals = "off"', 'signals = "on"'))
    out = tmp_path / "run"
    assert main(["run", str(scenario), "--controller", "nash", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "network.signals = 'on'" in err and "run the lights of 0" in err
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["lit.toml"]


def test_pedestrians_in_the_route_file_are_refused_for_a_controller_that_does_not_see_them(tmp_path, capsys):
    """SUMO's Braunschweig junction with people walking over its crossings: fcfs's reservations
    know no pedestrians; the game controllers yield to them (control/safety/pedestrians.py) and SUMO's
    drivers do by themselves, so both run the file."""
    (tmp_path / "walk.rou.xml").write_text(
        '<routes><personFlow id="p" begin="0" end="20" period="4"><walk from="-1.23" to="5"/></personFlow></routes>')
    scenario = tmp_path / "walk.toml"
    scenario.write_text("""
[scenario]
name = "walk"
duration = 20.0
[network]
file = "$SUMO_HOME/tools/game/fokr_bs_demo/fokr_bs.net.xml.gz"
junctions = ["38"]
routes = "walk.rou.xml"
[[flow]]
from = "-1.23"
to = "3"
rate = 300
kappa = 0.5
""")
    out = tmp_path / "run"
    assert main(["run", str(scenario), "--controller", "fcfs", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "network.routes" in err and "has pedestrians" in err
    assert not out.exists()
    assert main(["run", str(scenario), "--controller", "sumo-priority", "--out", str(out)]) == 0  # SUMO's drivers see them
    assert main(["run", str(scenario), "--controller", "stackelberg", "--out", str(tmp_path / "se")]) == 0
