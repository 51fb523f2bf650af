"""``run --gui``: the same closed loop through TraCI to sumo-gui, drawn live (under Xvfb here)."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from intersection_cosim.cli import main
from intersection_cosim.colors import GAME, kappa_color
from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import load_scenario, with_overrides

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
SHOT_SIZE = (800, 640)  # [px] width, height of the test's screenshot
SHOT_AT = 3.0  # [s] case1_A: V1 plays games with V2 and V3 from 2.35 s to 3.95 s

needs_xvfb = pytest.mark.skipif(shutil.which("xvfb-run") is None,
                                reason="xvfb-run is not installed (apt-get install xvfb): no display for sumo-gui")

SCREENSHOT_RUN = """
import sys
from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import load_scenario, with_overrides
from intersection_cosim.sim.gui import GuiSettings
scn = with_overrides(load_scenario(sys.argv[1]), controller="nash", budget_ms=2000.0)
run_scenario(scn, sys.argv[2], gui=GuiSettings(delay_ms=0, screenshot=sys.argv[3], screenshot_at={at},
                                               screenshot_size={size}))
"""


def _xvfb(args: list[str]) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SCENARIOS.parent), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 1280x1024x24", sys.executable, *args],
                          capture_output=True, text=True, timeout=300, env=env)


def _headless(case: str, out: Path) -> Path:
    run_scenario(with_overrides(load_scenario(SCENARIOS / f"{case}.toml"), controller="nash", budget_ms=2000.0), out)
    return out


@pytest.mark.slow
@needs_xvfb
def test_gui_run_writes_the_headless_outputs_and_says_it_was_a_gui_run(tmp_path):
    out = tmp_path / "gui"
    proc = _xvfb(["-m", "intersection_cosim", "run", str(SCENARIOS / "case1_D.toml"), "--controller", "nash",
                  "--budget-ms", "2000", "--gui", "--gui-delay", "0", "--out", str(out)])
    assert proc.returncode == 0, proc.stderr
    headless = _headless("case1_D", tmp_path / "headless")
    assert {p.name for p in out.iterdir()} == {p.name for p in headless.iterdir()}
    for name in ("trajectories.csv", "vehicles.csv", "convergence.csv"):  # TraCI carries doubles exactly
        assert (out / name).read_bytes() == (headless / name).read_bytes(), name
    summary = json.loads((out / "summary.json").read_text())
    assert summary["gui"] == {"simulator": "sumo-gui through TraCI", "delay_ms": 0.0}
    assert "gui" not in json.loads((headless / "summary.json").read_text())
    assert summary["counts"]["arrived"] == 3


@pytest.mark.slow
@needs_xvfb
def test_gui_screenshot_shows_the_junction_kappa_coloured_vehicles_and_the_games(tmp_path):
    from PIL import Image

    png = tmp_path / "shot.png"
    script = SCREENSHOT_RUN.format(at=SHOT_AT, size=SHOT_SIZE)
    proc = _xvfb(["-c", script, str(SCENARIOS / "case1_A.toml"), str(tmp_path / "run"), str(png)])
    assert proc.returncode == 0, proc.stderr
    image = Image.open(png)
    assert image.size == SHOT_SIZE
    rgb = np.asarray(image.convert("RGB")).reshape(-1, 3).astype(int)

    def count(colour, tol=10):
        return int((np.abs(rgb - np.array(colour)).max(axis=1) <= tol).sum())

    assert count(kappa_color(0.5)) > 300  # every case1_A vehicle has kappa 0.5: three bodies of ~100+ px
    assert count(kappa_color(0.0)) == 0 and count(kappa_color(1.0)) == 0
    assert count(GAME) > 200  # the rings and lines of this step's games
    road = count((0, 0, 0), tol=5) / len(rgb)
    assert 0.2 < road < 0.8  # the junction and its arms fill the view, with the background around them
    assert len(np.unique(rgb, axis=0)) > 20  # not blank


def test_gui_without_a_display_is_one_line_exit_2_and_writes_nothing(tmp_path, monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    out = tmp_path / "sub" / "run"
    assert main(["run", str(SCENARIOS / "case1_A.toml"), "--gui", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--gui: DISPLAY" in err and "xvfb-run" in err
    assert list(tmp_path.iterdir()) == []
