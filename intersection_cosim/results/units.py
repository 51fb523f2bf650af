"""The unit and meaning of every CSV column the package writes, and ``units.csv``, the sidecar that
states them beside the CSVs of a run, sweep, comparison or report folder.

The column names stay short (``travel_time``, ``heading``) so every reader keeps its names; the
sidecar gives each a unit: ``s``, ``ms``, ``m``, ``m/s``, ``m/s^2``, ``rad``, ``veh/h``, ``g``, or a
declaration that it has none: ``1`` (a dimensionless number: a ratio, a share, kappa), ``count``,
``bool`` or ``text`` (an id or a label, numbers such as a seed included).
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterable, Mapping

import pandas as pd

UNITS_FILE = "units.csv"
UNITS_COLUMNS = ["file", "column", "unit", "meaning"]
UNITLESS = ("1", "count", "bool", "text")  # declared without a physical unit

# column -> (unit, meaning); the same name means the same thing in every file that has it
COLUMNS: dict[str, tuple[str, str]] = {
    # trajectories.csv, walkers.csv
    "time": ("s", "simulation time"),
    "vehicle": ("text", "vehicle id (SUMO)"),
    "x": ("m", "x of the front bumper centre (a person: its position), net frame"),
    "y": ("m", "y of the front bumper centre (a person: its position), net frame"),
    "speed": ("m/s", "speed"),
    "accel": ("m/s^2", "acceleration realised in the last step"),
    "heading": ("rad", "heading, counter-clockwise from east"),
    "lane": ("text", "SUMO lane id"),
    "role": ("text", "ready (approaching), passing (in the junction) or outside"),
    "path": ("text", "movement path id through the junction"),
    "s": ("m", "arc length along the path"),
    "accel_cmd": ("m/s^2", "acceleration the controller commanded (empty: not commanded)"),
    "person": ("text", "person id (SUMO)"),
    "crossing": ("text", "SUMO lane id of the crossing"),
    "position": ("m", "position along the crossing's axis"),
    "direction": ("1", "+1 or -1: walking direction along the crossing's axis"),
    # steps.csv, games.csv, convergence.csv
    "compute_ms": ("ms", "wall time of the controller's step"),
    "games": ("count", "games played in the step"),
    "iterations": ("count", "best-response iterations summed over the step's games"),
    "deadline_missed": ("bool", "the step overran its budget"),
    "fallback": ("bool", "the step's decisions came from the fallback"),
    "deferred": ("count", "games and solo solves left to a later step by the anytime step"),
    "qp_solves": ("count", "QPs solved in the step"),
    "junction": ("text", "SUMO junction id"),
    "skipped": ("bool", "the junction had nothing to decide: its controller was not called"),
    "vehicle_a": ("text", "first vehicle of the pair"),
    "vehicle_b": ("text", "second vehicle of the pair"),
    "solved": ("bool", "the game was solved (False: its last equilibrium was kept)"),
    "solver": ("text", "equilibrium (nash / stackelberg; NE / SE in a report)"),
    "status": ("text", "outcome (a solve: converged, ...; a sweep run: ok or failed)"),
    "iteration": ("count", "iteration of the game"),
    "residual": ("m/s^2", "max change of any player's plan between iterations"),
    # vehicles.csv, pairs.csv
    "approach": ("text", "approach arm or edge"),
    "movement": ("text", "left, straight or right"),
    "kappa": ("1", "aggressiveness"),
    "depart": ("s", "departure time"),
    "arrival": ("s", "arrival time"),
    "travel_time": ("s", "arrival - depart (tripinfo duration)"),
    "time_loss": ("s", "time lost against driving at the lanes' speed limits (tripinfo timeLoss)"),
    "exit_lane": ("text", "lane the vehicle left the junction on"),
    "collided": ("bool", "SUMO recorded a collision of the vehicle"),
    "driver": ("text", "av or human"),
    "vtype": ("text", "SUMO vType id"),
    "conflict": ("text", "kind of the pair's conflict: cross, confluence, ..."),
    "min_ttc": ("s", "minimum time to collision, ours"),
    "pet": ("s", "post-encroachment time, ours"),
    "min_ttc_ssm": ("s", "minimum TTC of SUMO's SSM device"),
    "time_min_ttc_ssm": ("s", "simulation time SSM's minimum TTC was taken at"),
    "pet_ssm": ("s", "post-encroachment time of SUMO's SSM device"),
    "game_steps": ("count", "control steps in which the pair played a game"),
    "driver_a": ("text", "driver of vehicle_a"), "driver_b": ("text", "driver of vehicle_b"),
    "vtype_a": ("text", "vType of vehicle_a"), "vtype_b": ("text", "vType of vehicle_b"),
    # collisions.csv, overlaps.csv
    "collider": ("text", "vehicle that collided"),
    "victim": ("text", "vehicle or person it collided with"),
    "type": ("text", "SUMO's collision type"),
    "collider_commanded": ("bool", "a controller commanded the collider then"),
    "victim_commanded": ("bool", "a controller commanded the victim then"),
    "lane_a": ("text", "lane of vehicle_a"), "lane_b": ("text", "lane of vehicle_b"),
    "a_commanded": ("bool", "a controller commanded vehicle_a then"),
    "b_commanded": ("bool", "a controller commanded vehicle_b then"),
    # sweep.csv
    "run_id": ("text", "run folder name"),
    "controller": ("text", "controller kind"),
    "seed": ("text", "random seed"),
    "mean_travel_time": ("s", "mean travel time of the run's vehicles"),
    "min_pet": ("s", "smallest SSM PET of the run"),
    "collisions": ("count", "collisions SUMO recorded"),
    "arrived": ("count", "vehicles that arrived"),
    "vehicles": ("count", "vehicles of the run(s)"),
    "departed": ("count", "vehicles that departed"),
    "compute_ms_median": ("ms", "median compute time per control step"),
    "compute_ms_p95": ("ms", "95th percentile of the compute time per control step"),
    "deadline_misses": ("count", "steps that overran their budget"),
    "fallbacks": ("count", "steps decided by the fallback"),
    "error": ("text", "why a run failed"),
    "latency": ("s", "V2X latency (scenario axis)"),
    "loss": ("1", "V2X message loss share (scenario axis)"),
    "av_share": ("1", "share of AVs in the flows (scenario axis)"),
    # comparison.csv
    "scenario": ("text", "scenario name (a report: the paper's scenario letter)"),
    "demand_veh_h": ("veh/h", "demand of the scenario's flows"),
    "seeds": ("count", "seeds of the comparison"),
    "runs_ok": ("count", "finished runs"),
    "travel_time_mean": ("s", "mean travel time of the arrived vehicles"),
    "travel_time_p95": ("s", "95th percentile of the travel time"),
    "time_loss_mean": ("s", "mean time loss"),
    "throughput_veh_h": ("veh/h", "arrived vehicles per hour of the demand window"),
    "ssm_min_ttc": ("s", "smallest SSM min TTC (SSM's collision class left out)"),
    "ssm_min_pet": ("s", "smallest SSM PET"),
    "ssm_encounters": ("count", "SSM encounters"),
    "ssm_share_under_thresholds": ("1", "share of SSM encounters with TTC < 3 s or PET < 2 s"),
    "ssm_collision_encounters": ("count", "SSM encounters SSM classified as a collision (type 111)"),
    "pedestrian_collisions": ("count", "collisions of a vehicle and a person"),
    "late_or_stuck": ("count", "departed vehicles that never arrived or lost more than 60 s"),
    "ended_early": ("count", "runs ended early (deadlock or memory limit)"),
    "control_steps": ("count", "control steps"),
    "junction_steps": ("count", "steps of one junction's controller"),
    "deadline_miss_share": ("1", "share of junction steps that overran their budget"),
    "deferred_step_share": ("1", "share of steps with deferred work"),
    "not_inserted": ("count", "vehicles due that SUMO never inserted"),
    "control_delay": ("s", "control delay: SUMO's time loss of the arrived trips through the junction"),
    "los": ("text", "HCM level of service of the control delay"),
    "queue_p95_max": ("m", "largest 95th-percentile queue of an approach (SUMO's queue output)"),
    "fuel_g_per_trip": ("g", "fuel per arrived trip (SUMO's emissions device)"),
    "co2_g_per_trip": ("g", "CO2 per arrived trip (SUMO's emissions device)"),
    # approaches.csv
    "los_table": ("text", "the HCM table the LOS is read from (signalized or unsignalized)"),
    "throughput": ("veh/h", "arrived trips per hour of the demand window"),
    "queue_p95": ("m", "95th percentile of the approach edge's queue over the steps with a queue (SUMO)"),
    "queue_max": ("m", "longest queue of the approach edge (SUMO's queue output)"),
    # reproduce_paper.py's tables
    "pair": ("text", "the two vehicles"),
    "paper_min_ttc": ("s", "the paper's min TTC"),
    "case": ("text", "the paper's case"),
    "ratio": ("text", "which scenario against which"),
    "ratio_paper_min_ttc": ("1", "ratio of the paper's min TTC"),
    "ratio_min_ttc": ("1", "ratio of our min TTC"),
    "ratio_pet": ("1", "ratio of our PET"),
    "etm": ("bool", "the event trigger was on"),
    "check": ("text", "number of the check"),
    "description": ("text", "what the check claims"),
    "values": ("text", "the measured values, with their units"),
    "holds": ("text", "True, False or n/a (with the reason in values)"),
}
# prefix -> (unit, meaning with {} for the rest of the name): per-vehicle and per-pair columns of sweep.csv
PREFIXES: tuple[tuple[str, str, str], ...] = (
    ("kappa_", "1", "kappa of {}"), ("travel_time_", "s", "travel time of {}"),
    ("min_ttc_ssm_", "s", "SSM min TTC of {}"), ("min_ttc_", "s", "our min TTC of {}"),
    ("pet_", "s", "SSM PET of {}"), ("v2x_", "count", "V2X messages: {}"),
)


def unit_of(column: str) -> tuple[str, str] | None:
    """(unit, meaning) of a CSV column, None if the column is not declared."""
    if column in COLUMNS:
        return COLUMNS[column]
    for prefix, unit, meaning in PREFIXES:
        if column.startswith(prefix) and len(column) > len(prefix):
            return unit, meaning.format(column[len(prefix):])
    return None


def units_table(files: Mapping[str, Iterable[str]]) -> pd.DataFrame:
    """One row per (file, column) of ``files`` (file name -> its columns) with unit and meaning
    ("?" for an undeclared column)."""
    rows = [(name, col, *(unit_of(col) or ("?", ""))) for name, cols in files.items() for col in cols]
    return pd.DataFrame(rows, columns=UNITS_COLUMNS)


def write_units(folder: str | Path, files: Mapping[str, Iterable[str]]) -> Path:
    """Write ``folder/units.csv`` for ``files`` (file name -> its columns), merged with the rows
    already there for other files; returns its path."""
    path = Path(folder) / UNITS_FILE
    table = units_table(files)
    if path.is_file():
        old = pd.read_csv(path, dtype=str, keep_default_na=False)
        table = pd.concat([old[~old["file"].isin(list(files))], table], ignore_index=True)
    table.to_csv(path, index=False)
    return path


def csv_columns(folder: str | Path) -> dict[str, list[str]]:
    """File name -> header of every CSV in ``folder`` (compressed ones included), units.csv left out."""
    folder = Path(folder)
    found = sorted([*folder.glob("*.csv"), *folder.glob("*.csv.gz")])
    return {p.name: list(pd.read_csv(p, nrows=0).columns) for p in found if p.name != UNITS_FILE}
