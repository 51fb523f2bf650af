"""``intersection-cosim animate``: a short real run drawn from its run folder."""

import dataclasses
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from intersection_cosim.cli import main
from intersection_cosim.colors import GAME, UNCONTROLLED, kappa_color
from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.report.animation import AnimationSettings, animate, frame_times
from intersection_cosim.report.animation_frames import body_corners
from intersection_cosim.scenario import load_scenario, with_overrides

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
END = 3.0  # [s] case1_A cut short: 30 control steps, games from 2.35 s on


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    scn = with_overrides(load_scenario(SCENARIOS / "case1_A.toml"), controller="nash", budget_ms=2000.0)
    scn = dataclasses.replace(scn, scenario=dataclasses.replace(scn.scenario, duration=END, drain=0.0))
    out = tmp_path_factory.mktemp("anim") / "case1_A"
    run_scenario(scn, out)
    return out


@pytest.fixture(scope="module")
def gif(short_run):
    assert main(["animate", str(short_run)]) == 0
    return short_run / "animation.gif"


def _pixels(image: Image.Image, colour, tol: int = 12) -> int:
    rgb = np.asarray(image.convert("RGB")).reshape(-1, 3).astype(int)
    return int((np.abs(rgb - np.array(colour)).max(axis=1) <= tol).sum())


def test_gif_has_one_frame_per_control_step_at_the_default_size(short_run, gif):
    times = pd.read_csv(short_run / "trajectories.csv")["time"].unique()
    assert len(times) == 30  # 0.05 s ... 2.95 s every 0.1 s
    with Image.open(gif) as im:
        assert im.n_frames == 30
        assert im.size == AnimationSettings().size == (800, 720)
        assert im.info["duration"] == 100  # [ms] 10 fps: real time


def test_a_frame_shows_kappa_coloured_bodies_and_the_game_lines(gif):
    with Image.open(gif) as im:
        im.seek(0)
        first = im.convert("RGB")
        im.seek(27)  # t = 2.75 s: V1 plays V2 and V3
        late = im.convert("RGB")
    body = 4.5 * 1.8 * (640 / 80) ** 2  # [px] one 4.5 m x 1.8 m body at ~8 px/m
    assert _pixels(late, kappa_color(0.5)) > 2 * body  # three kappa-0.5 bodies (and the colour bar's middle)
    assert _pixels(late, GAME) > _pixels(first, GAME) + 100  # the lines of this step's games
    assert _pixels(late, kappa_color(0.0)) > 0 and _pixels(late, kappa_color(1.0)) > 0  # the colour bar's ends
    assert not np.array_equal(np.asarray(first), np.asarray(late))


def test_report_links_the_animation(short_run, gif):
    assert main(["report", str(short_run)]) == 0
    assert "![animation](animation.gif)" in (short_run / "report.md").read_text()


def test_mp4_through_ffmpeg(short_run, tmp_path):
    if shutil.which("ffmpeg") is None:
        pytest.skip("ffmpeg is not installed: no MP4")
    out = tmp_path / "run.mp4"
    assert main(["animate", str(short_run), "--out", str(out), "--fps", "20"]) == 0
    assert out.read_bytes()[4:8] == b"ftyp" and out.stat().st_size > 10_000


@pytest.mark.parametrize("case", ["missing", "not_a_run", "bad_suffix", "mp4_without_ffmpeg"])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(case, short_run, tmp_path, monkeypatch, capsys):
    run_dir, out = short_run, tmp_path / "a.gif"
    if case == "missing":
        run_dir = tmp_path / "nope"
    elif case == "not_a_run":
        run_dir = tmp_path / "empty"
        run_dir.mkdir()
    elif case == "bad_suffix":
        out = tmp_path / "a.avi"
    else:
        monkeypatch.setattr(shutil, "which", lambda name: None)
        out = tmp_path / "a.mp4"
    before = sorted(p.name for p in short_run.iterdir())
    assert main(["animate", str(run_dir), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("intersection-cosim: error: ")
    assert [p.name for p in tmp_path.iterdir()] == (["empty"] if case == "not_a_run" else [])
    assert sorted(p.name for p in short_run.iterdir()) == before


def test_frame_times_take_one_sample_per_frame_dt_and_cap_the_count():
    traj = pd.DataFrame({"time": np.round(np.arange(0.05, 20.0, 0.05), 4)})  # 399 samples every 0.05 s
    assert np.allclose(np.diff(frame_times(traj, AnimationSettings())), 0.1)
    assert len(frame_times(traj, AnimationSettings())) == 200
    capped = frame_times(traj, AnimationSettings(max_frames=50))
    assert len(capped) == 50 and capped[0] == 0.05


def test_body_is_length_behind_the_front_bumper_width_across():
    c = body_corners(10.0, -2.0, math.pi / 2, 4.5, 1.8)  # northbound, front bumper at (10, -2)
    assert np.allclose(c, [[9.1, -2.0], [10.9, -2.0], [10.9, -6.5], [9.1, -6.5]])
    assert UNCONTROLLED != kappa_color(0.5)


@pytest.mark.slow
def test_a_run_on_a_net_file_is_drawn_around_its_junction(tmp_path):
    """On SUMO's cross (its junction far from the origin) the view centres on the managed junction:
    the road and the controlled vehicles are in the frames, not an empty field."""
    scn = with_overrides(load_scenario(Path(__file__).resolve().parents[2] / "scenarios" / "cross_high.toml"),
                         budget_ms=2000.0)
    scn = dataclasses.replace(scn, scenario=dataclasses.replace(scn.scenario, duration=40.0, drain=20.0))
    run_scenario(scn, tmp_path / "run")
    out = tmp_path / "cross.gif"
    animate(tmp_path / "run", out, AnimationSettings(max_frames=60))
    road = (80, 80, 80)  # the lanes' fill (report/animation_frames.py ROAD)
    with Image.open(out) as im:
        counts = []
        for k in range(0, im.n_frames, 10):
            im.seek(k)
            counts.append(_pixels(im, road, tol=8))
        coloured = 0
        for k in range(im.n_frames):
            im.seek(k)
            frame = im.convert("RGB")
            coloured = max(coloured, sum(_pixels(frame, kappa_color(x)) for x in np.linspace(0.2, 0.8, 7)))
    assert min(counts) > 15_000  # [px] the roads cross the 800 x 720 frame (an empty field has none)
    assert coloured > 100  # some frame shows a controlled vehicle's body


def test_a_sweep_run_with_compressed_trajectories_is_animated(short_run, tmp_path):
    import gzip
    import shutil

    run = tmp_path / "sweep_run"
    shutil.copytree(short_run, run, ignore=shutil.ignore_patterns("animation.gif"))
    plain = run / "trajectories.csv"
    (run / "trajectories.csv.gz").write_bytes(gzip.compress(plain.read_bytes()))
    plain.unlink()
    assert main(["animate", str(run), "--fps", "40"]) == 0
    assert Image.open(run / "animation.gif").n_frames > 1
