"""The layout of run and sweep folders: file names, CSV columns and where each run lives.

A run folder (written atomically by ``experiments.run``)::

    summary.json        counts, metrics, settings and versions; its presence marks a finished run
    trajectories.csv    TRAJECTORY_COLUMNS, one row per vehicle and control step (gzip-compressed,
                        trajectories.csv.gz, in a sweep's or comparison's runs: ``trajectories_file``)
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
TRAJECTORIES_GZ = "trajectories.csv.gz"  # the same, gzip-compressed: a sweep's runs (about a tenth the size)
STEPS_FILE = "steps.csv"
CONVERGENCE_FILE = "convergence.csv"
GAMES_FILE = "games.csv"
VEHICLES_FILE = "vehicles.csv"
PAIRS_FILE = "pairs.csv"
WALKERS_FILE = "walkers.csv"
TRIPINFO_FILE = "tripinfo.xml"
QUEUES_FILE = "queues.xml"  # SUMO's queue output, aggregated per edge over the whole run
APPROACHES_FILE = "approaches.csv"  # results/engineer.py: control delay, LOS, queues per approach and movement
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
# games.csv's further columns, set on the rows of a pair that played inside a coupled cluster game
# (control/game/cluster_games.py; empty / NaN otherwise): the cluster's members joined by "+", its size, the
# solve's iterations, last residual [m/s^2] and status, the equilibrium check ("pass" / "fail" / "": not
# checked) and the largest relative gains [-] of a unilateral deviation, sampled and by a best-response re-solve
CLUSTER_COLUMNS = ["cluster", "size", "iterations", "residual", "status", "check", "gain_sampled", "gain_resolve"]
# one row per control step and managed junction (its controller's own record)
STEP_COLUMNS = ["time", "compute_ms", "games", "iterations", "deadline_missed", "fallback", "deferred", "qp_solves",
                "junction", "skipped"]  # skipped: the junction had nothing to decide (sim.network_scheduler)

# --- a sweep folder ----------------------------------------------------------------------------
SPEC_FILE = "sweep.json"
TABLE_FILE = "sweep.csv"
COMPARISON_FILE = "comparison.csv"  # a compare folder's table (one row per scenario and controller)
RUNS_DIR = "runs"
FAILED_DIR = "failed"


def trajectories_file(run_dir: str | Path) -> Path:
    """The run's trajectories: ``trajectories.csv``, or ``trajectories.csv.gz`` in a sweep's run
    (pandas reads either)."""
    plain = Path(run_dir) / TRAJECTORIES_FILE
    return plain if plain.is_file() or not (Path(run_dir) / TRAJECTORIES_GZ).is_file() else Path(run_dir) / TRAJECTORIES_GZ


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
