"""The layout of run and sweep folders: file names, CSV columns and where each run lives.

A run folder (written atomically by ``experiments.run``)::

    summary.json        counts, metrics, settings and versions; its presence marks a finished run
    trajectories.csv    TRAJECTORY_COLUMNS, one row per vehicle and control step
    steps.csv           STEP_COLUMNS, one row per control step
    convergence.csv     CONVERGENCE_COLUMNS (game controllers only)
    games.csv           GAME_COLUMNS, one row per game played (empty for controllers without games)
    vehicles.csv        one row per vehicle (``results.metrics.vehicle_table``)
    pairs.csv           one row per conflicting pair (``results.metrics.pair_table``)
    walkers.csv         WALKER_COLUMNS, one row per person on or walking onto a managed crossing and
                        control step (only runs that had any)
    tripinfo.xml, ssm.xml, collisions.xml   SUMO's own outputs (``results.sumo_outputs``)

A sweep folder (written by ``experiments.sweep``)::

    sweep.json          the sweep's spec (``results.sweep_folder.SweepSpec``)
    sweep.csv           one row per finished or failed run, rebuilt from the run folders
    runs/<run id>/      one run folder each
    failed/<run id>.json  the error of a run that failed
"""

from __future__ import annotations

from pathlib import Path

# --- a run folder ------------------------------------------------------------------------------
RUN_MARKER = "summary.json"  # a folder holding this file is a finished run
TRAJECTORIES_FILE = "trajectories.csv"
STEPS_FILE = "steps.csv"
CONVERGENCE_FILE = "convergence.csv"
GAMES_FILE = "games.csv"
VEHICLES_FILE = "vehicles.csv"
PAIRS_FILE = "pairs.csv"
WALKERS_FILE = "walkers.csv"
TRIPINFO_FILE = "tripinfo.xml"
SSM_FILE = "ssm.xml"
COLLISIONS_FILE = "collisions.xml"
COLLISION_LOG_FILE = "collisions.csv"  # SUMO's collisions as the loop saw them, with who was commanded
OVERLAPS_FILE = "overlaps.csv"  # our own body-overlap check (results/overlaps.py)

# time [s], vehicle, x, y [m], speed [m/s], accel [m/s^2], heading [rad], lane, role, path,
# s [m] along the path, accel_cmd [m/s^2] (NaN: not commanded)
TRAJECTORY_COLUMNS = ["time", "vehicle", "x", "y", "speed", "accel", "heading", "lane", "role", "path", "s",
                      "accel_cmd"]
# time [s], person, crossing (SUMO lane id), position [m] on the crossing's axis, direction (+1 / -1
# along it), speed [m/s], x, y [m] (the net's frame)
WALKER_COLUMNS = ["time", "person", "crossing", "position", "direction", "speed", "x", "y"]
# time [s], collider, victim, SUMO's collision type, lane, whether a controller commanded each then
COLLISION_LOG_COLUMNS = ["time", "collider", "victim", "type", "lane", "collider_commanded", "victim_commanded"]
CONVERGENCE_COLUMNS = ["time", "vehicle_a", "vehicle_b", "solver", "status", "iteration", "residual"]
GAME_COLUMNS = ["time", "vehicle_a", "vehicle_b", "junction", "solved"]  # time [s] of the step, the pair that
# played, where, and whether its game was solved (False: it kept its last equilibrium, control/game/game_reuse.py)
# one row per control step and managed junction (its controller's own record)
STEP_COLUMNS = ["time", "compute_ms", "games", "iterations", "deadline_missed", "fallback", "deferred", "qp_solves",
                "junction"]

# --- a sweep folder ----------------------------------------------------------------------------
SPEC_FILE = "sweep.json"
TABLE_FILE = "sweep.csv"
COMPARISON_FILE = "comparison.csv"  # a compare folder's table (one row per scenario and controller)
RUNS_DIR = "runs"
FAILED_DIR = "failed"


def is_finished_run(run_dir: str | Path) -> bool:
    """True if ``run_dir`` holds a finished run (its ``summary.json``)."""
    return (Path(run_dir) / RUN_MARKER).is_file()


def run_folder(sweep_dir: str | Path, run_id: str) -> Path:
    """The folder of run ``run_id`` of the sweep in ``sweep_dir``."""
    return Path(sweep_dir) / RUNS_DIR / run_id


def failure_file(sweep_dir: str | Path, run_id: str) -> Path:
    """The failure record of run ``run_id`` of the sweep in ``sweep_dir``."""
    return Path(sweep_dir) / FAILED_DIR / f"{run_id}.json"

# --- a stress folder (experiments/stress/spec.py describes it) -----------------------------------
STRESS_SPEC_FILE = "stress.json"
STRESS_TABLE_FILE = "stress.csv"
STRESS_SUMMARY_FILE = "summary.json"
