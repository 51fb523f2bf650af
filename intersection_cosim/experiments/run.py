"""One run of one scenario: SUMO inputs -> closed loop through libsumo -> CSVs and summary.

Everything is written into a temporary folder beside the output folder and renamed into place
when the run has finished, so a crashed or interrupted run leaves no half-written results.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import os
import platform
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from intersection_cosim import __version__
from intersection_cosim.control import registry
from intersection_cosim.control.base import ControlContext
from intersection_cosim.errors import InputError
from intersection_cosim.experiments.files import ROUTE_FILE, SUMOCFG_FILE, write_routes, write_sumocfg
from intersection_cosim.network.build import NET_FILE
from intersection_cosim.network.cache import cached_net
from intersection_cosim.network.paths import load_paths
from intersection_cosim.network.spec import IntersectionSpec
from intersection_cosim.report.metrics import pair_table, vehicle_table
from intersection_cosim.report.sumo_outputs import read_collisions, read_ssm, read_tripinfo
from intersection_cosim.scenario.load import default_exit_lane, generate_flow_vehicles
from intersection_cosim.scenario.model import Scenario
from intersection_cosim.settings import to_dict

log = logging.getLogger(__name__)

TRAJECTORY_COLUMNS = ["time", "vehicle", "x", "y", "speed", "accel", "heading", "lane", "role", "path", "s",
                      "accel_cmd"]
CONVERGENCE_COLUMNS = ["time", "vehicle_a", "vehicle_b", "solver", "status", "iteration", "residual"]
STEP_COLUMNS = ["time", "compute_ms", "games", "iterations", "deadline_missed", "fallback", "deferred", "qp_solves"]
RUN_MARKER = "summary.json"  # a folder holding this file is a finished run


def prepare_output(out: Path, force: bool = False) -> Path:
    """Check that ``out`` can be written and return the temporary folder to write into.

    ``out`` must be new, an empty folder or, with ``force``, a previous run's folder (replaced
    when the new run has finished); anything else is refused.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError("--out", "out", str(out), "is a file, not a folder")
    if (out / RUN_MARKER).is_file():
        if not force:
            raise InputError("--out", "out", str(out), f"holds a finished run ({RUN_MARKER}); use --force to "
                             "replace it, or another --out")
    elif out.is_dir() and any(out.iterdir()):
        raise InputError("--out", "out", str(out), "exists and is not a previous run's folder; not overwriting it")
    parent = out.parent if str(out.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=parent))
    except OSError as exc:
        raise InputError("--out", "out", str(out), f"cannot be written ({exc.strerror})") from None
    umask = os.umask(0)
    os.umask(umask)
    tmp.chmod(0o777 & ~umask)  # mkdtemp makes it private; a run folder is an ordinary folder
    return tmp


def finish_output(tmp: Path, out: Path) -> None:
    """Atomically put the finished run in place (replacing a previous run's folder)."""
    if out.exists():
        old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
        os.replace(out, old / "run")
        os.replace(tmp, out)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(tmp, out)


def resolved_settings(scn: Scenario) -> dict:
    """The settings a run of ``scn`` records in summary.json's ``settings`` (scenario, controller,
    model and solver tables after defaults and overrides): what makes two runs the same run."""
    return {"scenario": to_dict(scn.scenario), "controller": to_dict(scn.controller), "model": to_dict(scn.model),
            "solver": to_dict(scn.solver) if dataclasses.is_dataclass(scn.solver) else None}


def versions() -> dict[str, str]:
    """The versions a run records in summary.json (this package, SUMO, Python and the numerics)."""
    import osqp
    import scipy

    from intersection_cosim.network.cache import sumo_version

    return {"intersection_cosim": __version__, "sumo": sumo_version(), "python": platform.python_version(),
            "numpy": np.__version__, "scipy": scipy.__version__, "pandas": pd.__version__,
            "osqp": getattr(osqp, "__version__", "unknown")}


def run_scenario(scn: Scenario, out: str | Path, *, force: bool = False, fail_hook=None) -> dict:
    """Run ``scn`` and write its results into ``out``; return the summary dict.

    ``out`` holding a finished run is refused (InputError) unless ``force``, which replaces it.

    ``fail_hook`` (tests only) is called after the simulation loop, before the rename, so tests can
    simulate a crash at the worst moment.
    """
    out = Path(out)
    tmp = prepare_output(out, force)
    try:
        summary = _run_into(scn, tmp)
        if fail_hook is not None:
            fail_hook()
        finish_output(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return summary


def _run_into(scn: Scenario, folder: Path) -> dict:
    from intersection_cosim.network.conflicts import load_conflicts
    from intersection_cosim.sim.scheduler import StepScheduler
    from intersection_cosim.sim.sumo import SumoSimulation, VehicleInfo

    s = scn.scenario
    controller = registry.create(scn)
    net = cached_net(IntersectionSpec(junction_type=controller.junction_type))
    shutil.copyfile(net, folder / NET_FILE)
    paths = load_paths(net)
    rng = np.random.default_rng(s.seed)
    flow_vehicles = generate_flow_vehicles(scn, rng)
    write_routes(folder / ROUTE_FILE, scn, paths, flow_vehicles)
    write_sumocfg(folder / SUMOCFG_FILE, NET_FILE, scn)

    infos: dict[str, VehicleInfo] = {}
    for v in scn.vehicles:
        infos[v.id] = VehicleInfo(approach=v.approach, lane=v.lane, movement=v.movement, kappa=v.kappa,
                                  intended_path=v.path_id, controlled=controller.controls_vehicles,
                                  exit_lane=v.exit_lane, exit_fixed=v.exit_lane is not None,
                                  start_s=v.s0 if v.in_junction else None, desired_speed=v.desired_speed)
    for fv in flow_vehicles:
        pid = f"{fv['approach']}_{fv['lane']}_{fv['movement']}_{default_exit_lane(fv['lane'], fv['movement'])}"
        infos[fv["id"]] = VehicleInfo(approach=fv["approach"], lane=fv["lane"], movement=fv["movement"],
                                      kappa=fv["kappa"], intended_path=pid,
                                      controlled=controller.controls_vehicles)

    period_steps = max(1, int(round(scn.controller.period / s.step_length)))
    if abs(period_steps * s.step_length - scn.controller.period) > 1e-9:
        raise InputError(scn.source, "controller.period", scn.controller.period,
                         f"must be a multiple of scenario.step_length ({s.step_length:g} s)")
    controller.setup(ControlContext(paths=paths, net_file=str(net), model=scn.model, control_period=scn.controller.period,
                                    solver=scn.solver, etm=scn.controller.etm))
    scheduler = StepScheduler(controller, scn.controller.budget_ms, scn.controller.realtime)
    sim = SumoSimulation(paths=paths, vehicles=infos, step_length=s.step_length, exit_distance=s.exit_distance)

    traj_rows: list[tuple] = []
    step_rows: list[tuple] = []
    game_steps: dict[tuple[str, str], int] = {}
    end_time = s.duration + s.drain
    try:
        sim.start(str(folder / SUMOCFG_FILE))  # SUMO resolves the config's paths against its folder
        sim.advance()  # time 0: insert the vehicles that depart at once
        k = 0
        while sim.time < end_time - 1e-9 and (sim.remaining() > 0):
            if k % period_steps == 0:
                world = sim.world()  # read
                decisions, record = scheduler.step(world)  # decide
                sim.command(decisions)
                for i, vid in enumerate(world.ids):
                    traj_rows.append((world.time, vid, world.x[i], world.y[i], world.v[i], world.a[i],
                                      world.heading[i], world.lanes[i], world.role[i],
                                      world.path_ids[i], world.s[i], decisions.accel.get(vid, np.nan)))
                step_rows.append(dataclasses.astuple(record))
                for a, b in decisions.pairs:
                    key = (a, b) if a < b else (b, a)
                    game_steps[key] = game_steps.get(key, 0) + 1
            sim.write()  # write
            scheduler.pace(sim.time)
            sim.advance()  # step
            k += 1
        final_paths = dict(sim.current_path)
        exit_lanes = dict(sim.exit_lane_taken)
    finally:
        sim.close()

    traj = pd.DataFrame(traj_rows, columns=TRAJECTORY_COLUMNS)
    steps = pd.DataFrame(step_rows, columns=STEP_COLUMNS)
    tripinfo = read_tripinfo(folder / "tripinfo.xml")
    ssm = read_ssm(folder / "ssm.xml")
    collisions = read_collisions(folder / "collisions.xml")
    vehicles = vehicle_table(infos, tripinfo, exit_lanes, collisions)
    pairs = pair_table(traj, final_paths, paths, load_conflicts(net, scn.model.vehicle_width), scn.model,
                       ssm, game_steps)

    traj.to_csv(folder / "trajectories.csv", index=False, float_format="%.4f")
    records = getattr(controller, "convergence", None)
    if records is not None:
        rows = [(r.time, r.vehicle_a, r.vehicle_b, r.solver, r.status, m + 1, res)
                for r in records for m, res in enumerate(r.residuals)]
        pd.DataFrame(rows, columns=CONVERGENCE_COLUMNS).to_csv(folder / "convergence.csv", index=False,
                                                               float_format="%.6g")
    steps.to_csv(folder / "steps.csv", index=False, float_format="%.4f")
    vehicles.to_csv(folder / "vehicles.csv", index=False, float_format="%.4f")
    pairs.to_csv(folder / "pairs.csv", index=False, float_format="%.4f")

    summary = {
        "scenario": s.name, "source": scn.source, "controller": scn.controller.kind, "seed": s.seed,
        "settings": resolved_settings(scn),
        "versions": versions(),
        "counts": {"vehicles": int(len(infos)), "departed": int(tripinfo["depart"].notna().sum()),
                   "arrived": int(tripinfo["arrival"].ge(0).sum()), "collisions": int(len(collisions)),
                   "control_steps": int(len(steps)), "deadline_misses": int(steps["deadline_missed"].sum()),
                   "fallbacks": int(steps["fallback"].sum()),
                   "steps_with_deferred_work": int(steps["deferred"].gt(0).sum()),
                   "safety_interventions": getattr(controller, "filtered", None),
                   "box_rule_clearances": getattr(controller, "cleared", None)},
        "metrics": {
            "mean_travel_time": _num(vehicles["travel_time"].mean()),
            "min_ttc": _num(pairs["min_ttc"].min()) if len(pairs) else None,
            "min_ttc_ssm": _num(pairs["min_ttc_ssm"].min()) if len(pairs) else None,
            "compute_ms_median": _num(steps["compute_ms"].median()),
            "compute_ms_p95": _num(steps["compute_ms"].quantile(0.95)),
        },
    }
    with open(folder / RUN_MARKER, "w") as fh:
        json.dump(summary, fh, indent=2)
    return summary


def _num(x) -> float | None:
    return None if x is None or (isinstance(x, float) and np.isnan(x)) else float(x)
