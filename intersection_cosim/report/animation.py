"""``intersection-cosim animate RUN_DIR``: the run drawn from its own outputs as a GIF or an MP4.

Each frame shows the net's lanes and junction (from the run folder's ``intersection.net.xml``),
every vehicle as a rotated rectangle of the run's vehicle length and width, coloured by its kappa
while the controller commands it and grey while SUMO drives it (the colours of ``run --gui``), a
line between the two vehicles of every game played at that step, each vehicle's id and speed,
the time and a kappa colour bar. Inputs: ``trajectories.csv`` (front-bumper x, y [m] in the
paper frame, the net's frame; heading [rad]; speed [m/s]; accel_cmd), ``vehicles.csv`` (kappa),
``games.csv`` (time, vehicle_a, vehicle_b; run folders made before it existed: the games are
read from ``convergence.csv``) and ``summary.json`` (the model's vehicle size).

Frames are drawn with matplotlib (Agg); a GIF is written with Pillow, an MP4 with ffmpeg. The file
is written beside its destination and renamed into place, so a failure leaves nothing half-written.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from intersection_cosim.errors import InputError
from intersection_cosim.network.build import NET_FILE
from intersection_cosim.network.outline import NetOutline, junction_centre, read_outline
from intersection_cosim.report.animation_frames import FrameDrawer
from intersection_cosim.results.layout import (CONVERGENCE_FILE, GAMES_FILE, RUN_MARKER, TRAJECTORIES_FILE,
                                               VEHICLES_FILE, WALKERS_FILE, trajectories_file)

RUN_FILES = (RUN_MARKER, TRAJECTORIES_FILE, VEHICLES_FILE, NET_FILE)  # a run folder has these
ANIMATION_FILE = "animation.gif"  # default output, in the run folder (the run report links it)
FORMATS = (".gif", ".mp4")


@dataclass(frozen=True)
class AnimationSettings:
    """How a run is animated."""

    fps: float = 10.0  # [1/s] frames per second of playback: 10 with frame_dt 0.1 s plays in real time
    frame_dt: float = 0.1  # [s] simulation time between frames (at least one trajectory sample)
    max_frames: int = 600  # [-] frames at most; a longer run is subsampled evenly
    size: tuple[int, int] = (800, 720)  # [px] frame width, height (even, for MP4)
    margin: float = 6.0  # [m] around the vehicles' extent in the view
    max_half_view: float = 40.0  # [m] the view reaches at most this far from the centre (paper cases start 18-30 m out)
    default_length: float = 5.0  # [m] vehicle length when the run's settings do not give one
    default_width: float = 1.8  # [m] vehicle width likewise


@dataclass
class RunRecord:
    """What the animation draws of one run folder."""

    traj: pd.DataFrame  # one row per vehicle and control step
    kappa: dict[str, float]  # [-] per vehicle
    games: pd.DataFrame  # time [s], vehicle_a, vehicle_b: one row per game played
    outline: NetOutline
    length: float  # [m]
    width: float  # [m]
    title: str
    centre: tuple[float, float] = (0.0, 0.0)  # [m] the view's centre: the (first) managed junction
    reach: float | None = None  # [m] how far out the controller drives (a net file's control range; None: the settings')
    walkers: pd.DataFrame | None = None  # time [s], x, y [m]: the people at the crossings (walkers.csv), None: none


def check_run_dir(run_dir: str | Path) -> Path:
    """``run_dir`` as a Path, or :class:`InputError` when it is not a finished run's folder."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise InputError("animate", "run_dir", str(run_dir), "no such folder")
    missing = [name for name in RUN_FILES
               if not (trajectories_file(run_dir) if name == TRAJECTORIES_FILE else run_dir / name).is_file()]
    if missing:
        raise InputError("animate", "run_dir", str(run_dir), f"is not a run folder (no {', '.join(missing)})")
    return run_dir


def check_out(out: str | Path) -> Path:
    """The output file, or :class:`InputError` for an unknown format or an MP4 without ffmpeg."""
    out = Path(out)
    if out.suffix.lower() not in FORMATS:
        raise InputError("--out", "out", str(out), "must end in .gif or .mp4")
    if out.suffix.lower() == ".mp4" and shutil.which("ffmpeg") is None:
        raise InputError("--out", "out", str(out), "an MP4 needs ffmpeg on PATH (install it, or write a .gif)")
    if not out.parent.is_dir():
        raise InputError("--out", "out", str(out), "its folder does not exist")
    return out


def read_run(run_dir: Path, settings: AnimationSettings) -> RunRecord:
    """The trajectories, kappas, games, net outline and vehicle size of a run folder."""
    summary = json.loads((run_dir / RUN_MARKER).read_text())
    model = (summary.get("settings") or {}).get("model") or {}
    traj = pd.read_csv(trajectories_file(run_dir), dtype={"vehicle": str})
    vehicles = pd.read_csv(run_dir / VEHICLES_FILE, dtype={"vehicle": str})
    if (run_dir / GAMES_FILE).is_file():
        games = pd.read_csv(run_dir / GAMES_FILE, dtype={"vehicle_a": str, "vehicle_b": str})
    elif (run_dir / CONVERGENCE_FILE).is_file():  # one row per iteration of each game
        games = pd.read_csv(run_dir / CONVERGENCE_FILE, dtype={"vehicle_a": str, "vehicle_b": str})
        games = games.drop_duplicates(["time", "vehicle_a", "vehicle_b"])[["time", "vehicle_a", "vehicle_b"]]
    else:
        games = pd.DataFrame(columns=["time", "vehicle_a", "vehicle_b"])
    title = f"{summary.get('scenario', run_dir.name)}, {summary.get('controller', '')}, seed {summary.get('seed', '')}"
    network = (summary.get("settings") or {}).get("network") or {}
    on_file = bool(network.get("file"))
    centre = junction_centre(run_dir / NET_FILE, network["junctions"][0]) if on_file else (0.0, 0.0)
    reach = float(network.get("control_range", settings.max_half_view)) if on_file else None
    walkers = pd.read_csv(run_dir / WALKERS_FILE) if (run_dir / WALKERS_FILE).is_file() else None
    return RunRecord(traj=traj, kappa=dict(zip(vehicles["vehicle"], vehicles["kappa"].astype(float))), games=games,
                     outline=read_outline(run_dir / NET_FILE),
                     length=float(model.get("vehicle_length", settings.default_length)),
                     width=float(model.get("vehicle_width", settings.default_width)), title=title, centre=centre,
                     reach=reach, walkers=walkers)


def frame_times(traj: pd.DataFrame, settings: AnimationSettings) -> np.ndarray:
    """[s] the trajectory sample times drawn: every ``frame_dt``, at most ``max_frames`` of them."""
    times = np.unique(traj["time"].to_numpy(float))
    if len(times) < 2:
        return times
    period = float(np.median(np.diff(times)))  # [s] the control period
    step = max(1, int(round(settings.frame_dt / period)))
    step = max(step, math.ceil(len(times) / settings.max_frames))
    return times[::step]


def animate(run_dir: str | Path, out: str | Path | None = None, settings: AnimationSettings | None = None) -> Path:
    """Write the animation of ``run_dir`` to ``out`` (default ``RUN_DIR/animation.gif``); return its path."""
    settings = settings or AnimationSettings()
    run_dir = check_run_dir(run_dir)
    out = check_out(out if out is not None else run_dir / ANIMATION_FILE)
    run = read_run(run_dir, settings)
    times = frame_times(run.traj, settings)
    if len(times) == 0:
        raise InputError("animate", "run_dir", str(run_dir), "has no trajectory samples to draw")
    fd, tmp_name = tempfile.mkstemp(prefix=f".{out.name}.", suffix=out.suffix, dir=out.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        drawer = FrameDrawer(run, settings)
        frames = (drawer.draw(t) for t in times)
        if out.suffix.lower() == ".gif":
            _write_gif(frames, tmp, settings.fps)
        else:
            _write_mp4(frames, tmp, settings)
        tmp.chmod(0o666 & ~_umask())
        os.replace(tmp, out)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return out


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _write_gif(frames, path: Path, fps: float) -> None:
    """Frames (RGB uint8 arrays) as a looping GIF, ``1000 / fps`` ms per frame."""
    from PIL import Image

    images = (Image.fromarray(f).quantize(colors=128, method=Image.Quantize.MEDIANCUT) for f in frames)
    first = next(images)
    first.save(path, format="GIF", save_all=True, append_images=images, duration=int(round(1000 / fps)), loop=0,
               disposal=1)


def _write_mp4(frames, path: Path, settings: AnimationSettings) -> None:
    """Frames (RGB uint8 arrays) piped to ffmpeg as H.264 at ``fps``."""
    w, h = settings.size
    cmd = [shutil.which("ffmpeg"), "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}",
           "-r", f"{settings.fps:g}", "-i", "-", "-an", "-vcodec", "libx264", "-pix_fmt", "yuv420p", "-f", "mp4",
           str(path)]
    proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        for frame in frames:
            proc.stdin.write(np.ascontiguousarray(frame).tobytes())
    finally:
        proc.stdin.close()
        err = proc.stderr.read().decode(errors="replace")
        proc.wait()
    if proc.returncode != 0:
        raise RuntimeError(f"ffmpeg failed: {err.strip()}")
