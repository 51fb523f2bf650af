"""Helpers of the sweep and report tests (the grid, table comparison, process checks)."""

from __future__ import annotations

import os
import subprocess
import time
from pathlib import Path

import pandas as pd

from intersection_cosim.results.layout import RUNS_DIR, TABLE_FILE
from intersection_cosim.results.sweep_folder import WALL_CLOCK_COLUMNS

CASE1A = str(Path(__file__).resolve().parents[2] / "scenarios" / "case1_A.toml")
# 2 x 2 kappa, 1 seed; SUMO's own controller (it ignores kappa, but it is fast and tests the machinery)
GRID = ["--kappa", "V1=0.3,0.7", "--kappa", "V2=0.2:0.5:0.3", "--seeds", "1", "--controllers", "sumo"]
GRID_RUNS = 4


def sweep_args(out: Path, *extra: str) -> list[str]:
    return ["sweep", CASE1A, *GRID, "--out", str(out), "--no-progress", *extra]


def comparable(table: pd.DataFrame) -> pd.DataFrame:
    """sweep.csv without the columns that depend on the wall clock."""
    return table.drop(columns=[c for c in WALL_CLOCK_COLUMNS if c in table]).reset_index(drop=True)


def read_table(out: Path) -> pd.DataFrame:
    return pd.read_csv(Path(out) / TABLE_FILE, keep_default_na=False, na_values=[""])


def wait_for_a_finished_run(out: Path, proc: subprocess.Popen, timeout: float = 90.0) -> None:
    """Return once a finished run folder under ``out`` holds summary.json, ``proc`` has ended, or
    after ``timeout`` seconds. A run writes into a hidden temporary folder and renames it when
    done; pathlib's glob matches hidden names, so those are skipped (a run interrupted between
    its summary and its rename is cleaned up, not kept)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and proc.poll() is None:
        if [p for p in Path(out).glob(f"{RUNS_DIR}/*/summary.json") if not p.parent.name.startswith(".")]:
            return
        time.sleep(0.02)


def group_alive(pgid: int) -> list[int]:
    """Processes (not zombies) still in process group ``pgid`` (Linux /proc)."""
    alive = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()  # state, ppid, pgrp, ...
        if int(fields[2]) == pgid and fields[0] != "Z":
            alive.append(int(entry))
    return alive


def run_children() -> list:
    """This process's children that are runs of a sweep (executors' fresh interpreters)."""
    import psutil

    out = []
    for p in psutil.Process().children(recursive=True):
        try:
            if "intersection_cosim.experiments.executors" in " ".join(p.cmdline()):
                out.append(p)
        except psutil.Error:
            pass
    return out
