"""A run's result tables (trajectories, steps, games, vehicles, pairs and the rest), built from the
closed loop's records and SUMO's own outputs and written as CSVs, and its summary.json."""

from __future__ import annotations

import dataclasses
import platform
from pathlib import Path
from typing import Mapping, NamedTuple

import numpy as np
import pandas as pd

from intersection_cosim import __version__
from intersection_cosim.control.base import Diagnostics
from intersection_cosim.experiments.closed_loop import Records, Simulated
from intersection_cosim.experiments.route_window import file_counts
from intersection_cosim.experiments.run_inputs import RunInputs
from intersection_cosim.network.cache import sumo_version
from intersection_cosim.network.by_junction import path_junction
from intersection_cosim.network.conflicts import movement_conflicts
from intersection_cosim.network.paths import MovementPath
from intersection_cosim.results.collision_counts import collision_counts
from intersection_cosim.results.layout import (APPROACHES_FILE, QUEUES_FILE, CLUSTER_COLUMNS, COLLISION_LOG_COLUMNS, COLLISION_LOG_FILE, COLLISIONS_FILE, CONVERGENCE_COLUMNS, CONVERGENCE_FILE, GAME_COLUMNS,
                                               GAMES_FILE, PAIRS_FILE, SSM_FILE, STEP_COLUMNS, STEPS_FILE,
                                               TRAJECTORIES_FILE, TRAJECTORIES_GZ, TRAJECTORY_COLUMNS, TRIPINFO_FILE, VEHICLES_FILE,
                                               OVERLAPS_FILE, WALKER_COLUMNS, WALKERS_FILE)
from intersection_cosim.results.metrics import pair_table, vehicle_table
from intersection_cosim.results.overlaps import OVERLAP_COLUMNS
from intersection_cosim.results.engineer import approach_table, delay_summary, run_energy
from intersection_cosim.results.sumo_outputs import (PEDESTRIAN_COLLISIONS, read_collisions, read_queues, read_ssm,
                                                     read_tripinfo)
from intersection_cosim.results.units import csv_columns, write_units
from intersection_cosim.scenario.model import Scenario
from intersection_cosim.settings import to_dict


class RunTables(NamedTuple):
    """A run's result tables."""

    traj: pd.DataFrame
    steps: pd.DataFrame
    tripinfo: pd.DataFrame
    collisions: pd.DataFrame
    vehicles: pd.DataFrame
    pairs: pd.DataFrame
    collision_log: pd.DataFrame  # COLLISION_LOG_COLUMNS: SUMO's records, with who was under a controller
    overlaps: pd.DataFrame  # OVERLAP_COLUMNS: our own check's overlap events
    approaches: pd.DataFrame  # results/engineer.py's APPROACH_COLUMNS: delay, LOS, queues per approach


def result_tables(scn: Scenario, folder: Path, inputs: RunInputs, simulated: Simulated) -> RunTables:
    """The run's tables, from the loop's records and the outputs SUMO wrote into ``folder``."""
    traj = pd.DataFrame(simulated.records.traj_rows, columns=TRAJECTORY_COLUMNS)
    steps = pd.DataFrame(simulated.records.step_rows, columns=STEP_COLUMNS)
    tripinfo = read_tripinfo(folder / TRIPINFO_FILE)
    ssm = read_ssm(folder / SSM_FILE)
    collisions = read_collisions(folder / COLLISIONS_FILE)
    vehicles = vehicle_table(_with_movements(simulated.infos, simulated.final_paths, inputs.paths), tripinfo,
                             simulated.exit_lanes, collisions)
    touch = max([scn.model.vehicle_width] + [vt.width for vt in scn.vtypes if vt.width is not None])  # [m]
    pairs = pair_table(traj, simulated.final_paths, inputs.paths, movement_conflicts(inputs.movements, touch),
                       scn.model, ssm, simulated.records.game_steps,
                       {vid: (info.driver, info.vtype) for vid, info in simulated.infos.items()}, simulated.bodies)
    log = pd.DataFrame(list(simulated.collision_log), columns=COLLISION_LOG_COLUMNS)
    overlaps = pd.DataFrame(simulated.records.overlaps.rows, columns=list(OVERLAP_COLUMNS))
    junction_of = {vid: path_junction(inputs.movements, pid) for vid, pid in simulated.final_paths.items()
                   if pid in inputs.paths}
    approaches = approach_table(vehicles, junction_of, inputs.paths, read_queues(folder / QUEUES_FILE),
                                scn.scenario.duration, los_table(scn, inputs.controller))
    return RunTables(traj, steps, tripinfo, collisions, vehicles, pairs, log, overlaps, approaches)


def los_table(scn: Scenario, controller) -> str:
    """The HCM level-of-service table of a run: signalized under traffic lights (a signal
    controller, or the lights a net keeps with ``signals = "on"``), else unsignalized."""
    lit = controller.junction_type == "traffic_light" or (not scn.network.generated and scn.network.signals == "on"
                                                         and not controller.controls_vehicles)
    return "HCM signalized" if lit else "HCM unsignalized"


def _with_movements(infos: dict, final_paths: dict[str, str], paths: Mapping[str, MovementPath]) -> dict:
    """``infos`` with the approach (edge) and movement of the path each vehicle without a named
    one took (on a net file vehicles are known by their routes)."""
    out = {}
    for vid, info in infos.items():
        pid = final_paths.get(vid)
        if not info.approach and pid in paths:
            info = dataclasses.replace(info, approach=paths[pid].approach, movement=paths[pid].movement)
        out[vid] = info
    return out


def write_tables(folder: Path, tables: RunTables, records: Records, diagnostics: Diagnostics,
                 compress: bool = False) -> None:
    """Write the run's CSVs into ``folder`` (convergence.csv only for a controller that solves games,
    walkers.csv only for a run with people at its crossings); with ``compress`` the trajectories,
    most of a run's bytes, as trajectories.csv.gz."""
    traj = folder / (TRAJECTORIES_GZ if compress else TRAJECTORIES_FILE)
    tables.traj.to_csv(traj, index=False, float_format="%.4f",
                       compression={"method": "gzip", "mtime": 0} if compress else None)  # mtime 0: same bytes
    if diagnostics.convergence is not None:
        rows = [(r.time, r.vehicle_a, r.vehicle_b, r.solver, r.status, m + 1, res)
                for r in diagnostics.convergence for m, res in enumerate(r.residuals)]
        pd.DataFrame(rows, columns=CONVERGENCE_COLUMNS).to_csv(folder / CONVERGENCE_FILE, index=False,
                                                               float_format="%.6g")
    tables.steps.to_csv(folder / STEPS_FILE, index=False, float_format="%.4f")
    games_table(records.game_rows, diagnostics.clusters).to_csv(folder / GAMES_FILE, index=False, float_format="%.4f")
    if records.walker_rows:
        pd.DataFrame(records.walker_rows, columns=WALKER_COLUMNS).to_csv(folder / WALKERS_FILE, index=False,
                                                                         float_format="%.4f")
    tables.vehicles.to_csv(folder / VEHICLES_FILE, index=False, float_format="%.4f")
    tables.pairs.to_csv(folder / PAIRS_FILE, index=False, float_format="%.4f")
    tables.collision_log.to_csv(folder / COLLISION_LOG_FILE, index=False, float_format="%.4f")
    tables.overlaps.to_csv(folder / OVERLAPS_FILE, index=False, float_format="%.4f")
    tables.approaches.to_csv(folder / APPROACHES_FILE, index=False, float_format="%.4f")
    write_units(folder, csv_columns(folder))  # units.csv: the unit of every column above


def vehicle_counts(scn: Scenario, own: int, loaded: int, tripinfo: pd.DataFrame) -> dict:
    """The run's vehicles, each counted once: ``vehicles`` the scenario's own ``own`` plus those of
    its route file due to depart in the run (in the demand window; with ``keep_all_demand`` those
    SUMO loaded), ``departed`` those SUMO inserted, ``arrived``, ``not_inserted`` (SUMO's backlog
    at the end) and ``never_arrived`` (inserted, still driving at the end); and the route file's
    ``in_files`` and ``in_window``. ``loaded`` [-] is how many SUMO loaded during the run."""
    demand = file_counts(scn)
    due = own + (demand["in_window"] if not scn.scenario.keep_all_demand else 0)
    vehicles = max(due, loaded)
    departed = int(tripinfo["depart"].notna().sum())
    arrived = int(tripinfo["arrival"].ge(0).sum())
    return {"vehicles": int(vehicles), **demand, "departed": departed, "arrived": arrived,
            "not_inserted": int(max(0, vehicles - departed)), "never_arrived": departed - arrived}


def games_table(game_rows: list[tuple], clusters: tuple | None) -> pd.DataFrame:
    """games.csv: GAME_COLUMNS, then CLUSTER_COLUMNS on the rows of pairs that played inside a
    cluster game (same step, both vehicles members)."""
    games = pd.DataFrame(game_rows, columns=GAME_COLUMNS)
    if not clusters:
        return games
    by_pair = {}
    for c in clusters:  # residual and gains in 4 significant digits (a gain of 1e-6 is no 0.0000)
        info = ("+".join(c.members), len(c.members), c.iterations, f"{c.residual:.4g}", c.status, c.check,
                f"{c.gain_sampled:.4g}", f"{c.gain_resolve:.4g}")
        for a in c.members:
            for b in c.members:
                by_pair[(c.time, a, b)] = info
    empty = ("", np.nan, np.nan, np.nan, "", "", np.nan, np.nan)
    rows = [by_pair.get((t, a, b), empty) for t, a, b in zip(games["time"], games["vehicle_a"], games["vehicle_b"])]
    return pd.concat([games, pd.DataFrame(rows, columns=CLUSTER_COLUMNS, index=games.index)], axis=1)


def run_summary(scn: Scenario, infos: dict, tables: RunTables, diagnostics: Diagnostics, gui=None,
                onboard_caps: int | None = None, counts: dict | None = None,
                onboard_crossing_caps: int | None = None) -> dict:
    """The run's summary.json: what ran, with which settings and versions, counts and metrics;
    ``counts``: :func:`vehicle_counts` (None: the vehicles of ``infos`` and tripinfo's)."""
    s = scn.scenario
    tripinfo, collisions, steps = tables.tripinfo, tables.collisions, tables.steps
    vehicles, pairs = tables.vehicles, tables.pairs
    step_compute = steps.groupby("time", sort=False)["compute_ms"].sum()  # [ms]
    summary = {
        "scenario": s.name, "source": scn.source, "controller": scn.controller.kind, "seed": s.seed,
        "settings": resolved_settings(scn),
        "versions": versions(),
        "counts": {**(counts or vehicle_counts(scn, len(infos), 0, tripinfo)), "collisions": int(len(collisions)),
                   "control_steps": int(steps["time"].nunique()), "junction_steps": int(len(steps)),
                   "deadline_misses": int(steps["deadline_missed"].sum()),
                   "fallbacks": int(steps["fallback"].sum()),
                   "steps_with_deferred_work": int(steps["deferred"].gt(0).sum()),
                   "safety_interventions": diagnostics.safety_interventions,
                   "box_rule_clearances": diagnostics.box_rule_clearances,
                   "pedestrian_collisions": int(collisions["type"].isin(PEDESTRIAN_COLLISIONS).sum()),
                   "pedestrian_holds": diagnostics.pedestrian_holds,
                   "onboard_caps": onboard_caps, "onboard_crossing_caps": onboard_crossing_caps},
        # SUMO's records, distinct vehicles and pairs, split by whether a vehicle under a
        # controller is involved, and our own overlap check beside them (results/collision_counts.py)
        "collisions": collision_counts(tables.collision_log, tables.overlaps),
        # control delay and LOS, fuel and CO2 from SUMO's outputs (results/engineer.py); per approach: approaches.csv
        "engineer": {**delay_summary(tables.approaches), **run_energy(tripinfo)},
        "metrics": {
            "mean_travel_time": _num(vehicles["travel_time"].mean()),
            "mean_time_loss": _num(vehicles["time_loss"].mean()),
            "min_ttc": _num(pairs["min_ttc"].min()) if len(pairs) else None,
            "min_ttc_ssm": _num(pairs["min_ttc_ssm"].min()) if len(pairs) else None,
            # [s] when SSM took it (at the first step: the vehicles' speeds as inserted, before any decision)
            "time_min_ttc_ssm": _ssm_time(pairs),
            # [ms] per control step, summed over the junctions' controllers
            "compute_ms_median": _num(step_compute.median()),
            "compute_ms_p95": _num(step_compute.quantile(0.95)),
        },
    }
    if gui is not None:
        summary["gui"] = {"simulator": "sumo-gui through TraCI", "delay_ms": gui.delay_ms}
    return summary


def _ssm_time(pairs) -> float | None:
    """[s] the time of the run's smallest SSM min TTC (None: SSM recorded no TTC)."""
    ttc = pairs["min_ttc_ssm"].astype(float) if len(pairs) else None
    if ttc is None or not ttc.notna().any():
        return None
    return _num(pairs.loc[ttc.idxmin(), "time_min_ttc_ssm"])


def _num(x) -> float | None:
    return None if x is None or (isinstance(x, float) and np.isnan(x)) else float(x)


def resolved_settings(scn: Scenario) -> dict:
    """The settings a run of ``scn`` records in summary.json's ``settings`` (scenario, network,
    controller, model and the controller's [controller.*] tables after defaults and overrides):
    what makes two runs the same run."""
    return {"scenario": to_dict(scn.scenario), "network": to_dict(scn.network), "human": to_dict(scn.human),
            "controller": to_dict(scn.controller), "model": to_dict(scn.model), "v2x": to_dict(scn.v2x),
            "controller_settings": to_dict(scn.controller_settings)
            if dataclasses.is_dataclass(scn.controller_settings) else None,
            "vtypes": [to_dict(vt) for vt in scn.vtypes]}


def versions() -> dict[str, str]:
    """The versions a run records in summary.json (this package, SUMO, Python and the numerics)."""
    import osqp
    import scipy

    return {"intersection_cosim": __version__, "sumo": sumo_version(), "python": platform.python_version(),
            "numpy": np.__version__, "scipy": scipy.__version__, "pandas": pd.__version__,
            "osqp": getattr(osqp, "__version__", "unknown")}
