"""Controller comparison: every controller x seed on one or more demand scenarios.

``intersection-cosim compare SCENARIO... --controllers K1,K2 --seeds 1-5 --out DIR`` runs one sweep
per scenario (no kappa grid) into ``DIR/<scenario name>/`` through :func:`run_sweep` (so it is
resumable and runs on Dask too), then writes::

    DIR/comparison.csv                 one row per scenario x controller, aggregated over the seeds
    DIR/report.md                      the table
    DIR/figures/overview.png           every metric, one panel each: one line per controller against
                                       demand [veh/h], or bars per controller and scenario at one level
    DIR/figures/<metric>_vs_demand.png one line per controller against demand (two or more levels only)
    DIR/figures/<metric>_vs_<axis>.png against a scenario axis (--latency, --loss) taking two or more values

Aggregation over the seeds of a (scenario, controller): travel time mean and 95th percentile and
time loss mean over all arrived vehicles of all seeds; throughput = arrived vehicles per hour of
the demand window (``[scenario] duration``, summed over the seeds); SSM min TTC / min PET over all
encounters and the share of encounters with TTC < 3 s or PET < 2 s (``files.SSM_THRESHOLDS``),
leaving out the TTC 0 of encounters SSM classified as a collision (``ssm_collision_encounters``,
counted beside SUMO's own ``collisions``: at merges SSM flags encounters that never touched);
collisions summed (``pedestrian_collisions``: those of a vehicle and a person); ``late_or_stuck``:
departed vehicles that never arrived (a deadlock) or lost more than 60 s against free flow
(tripinfo's timeLoss: a queue that does not drain), whatever the length of their routes, so the
same bound holds on a small junction and on a long OSM approach;
``control_delay``: the runs' control delay (SUMO's time loss of the trips through the junctions,
results/engineer.py) averaged over the seeds, ``los`` its HCM level of service, ``queue_p95_max``
the largest 95th-percentile queue of an approach [m], fuel and CO2 per arrived trip [g] of SUMO's
emissions device; ``not_inserted``: vehicles due that SUMO never inserted (summed);
``ended_early``: runs that ended before their end because every vehicle stood still (a deadlock,
experiments.deadlock) or past scenario.memory_limit (experiments.memory_guard); compute time per
control step (summed over the junctions' controllers of a net with several) median and 95th
percentile over all steps, and
the share of junction steps (one junction's controller in one control step, each with its own
budget) that missed their deadline.
"""

from __future__ import annotations

import dataclasses
import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd

from intersection_cosim.errors import InputError
from intersection_cosim.experiments.axes import AXES
from intersection_cosim.experiments.files import SSM_THRESHOLDS
from intersection_cosim.experiments.route_window import file_counts
from intersection_cosim.experiments.sweep import (SweepOutcome, check_out, make_spec, parse_controllers, run_sweep,
                                                  sweep_jobs)
from intersection_cosim.results.engineer import level_of_service
from intersection_cosim.results.layout import APPROACHES_FILE, COMPARISON_FILE, RUN_MARKER, SSM_FILE, STEPS_FILE, VEHICLES_FILE
from intersection_cosim.results.sumo_outputs import read_ssm
from intersection_cosim.results.units import write_units
from intersection_cosim.report.compare_figures import metric_vs_axis, metric_vs_demand, overview
from intersection_cosim.results.sweep_folder import SweepSpec
from intersection_cosim.scenario import scenario_from_dict

TABLE_FILE = COMPARISON_FILE
REPORT_FILE = "report.md"
FIGURES_DIR = "figures"
OVERVIEW_PNG = "overview.png"  # every FIGURE_METRICS metric, one panel each
DEFAULT_CONTROLLERS = "nash,stackelberg,fcfs,sumo-priority,sumo-allway-stop,sumo-tls"

LATE_AFTER = 60.0  # [s] a departed vehicle that lost more than this against free flow (or never arrived) is late or stuck

COLUMNS = ["scenario", "demand_veh_h", "controller", "seeds", "runs_ok", "vehicles", "arrived", "not_inserted",
           "control_delay", "los", "queue_p95_max", "fuel_g_per_trip", "co2_g_per_trip",
           "travel_time_mean", "travel_time_p95", "time_loss_mean", "throughput_veh_h",
           "ssm_min_ttc", "ssm_min_pet", "ssm_encounters", "ssm_share_under_thresholds", "ssm_collision_encounters", "collisions",
           "pedestrian_collisions", "late_or_stuck", "ended_early", "compute_ms_median", "compute_ms_p95", "control_steps", "junction_steps",
           "deadline_misses",
           "deadline_miss_share",
           "deferred_step_share"]
# Metrics that get a figure against demand, with axis labels.
FIGURE_METRICS = {
    "travel_time_mean": "travel time, mean [s]",
    "travel_time_p95": "travel time, 95th percentile [s]",
    "time_loss_mean": "time loss, mean [s]",
    "throughput_veh_h": "throughput [veh/h]",
    "ssm_min_ttc": "min TTC, SUMO SSM [s]",
    "ssm_min_pet": "min PET, SUMO SSM [s]",
    "ssm_share_under_thresholds": "share of SSM encounters under thresholds [-]",
    "collisions": "collisions [-]",
    "compute_ms_median": "compute time per step, median [ms]",
    "compute_ms_p95": "compute time per step, 95th percentile [ms]",
    "deadline_miss_share": "share of steps missing the deadline [-]",
}
# Metrics that get a figure against each scenario axis (--latency, --loss) when a comparison has axes.
AXIS_FIGURE_METRICS = {key: FIGURE_METRICS[key] for key in ("travel_time_mean", "ssm_share_under_thresholds",
                                                            "collisions")}


@dataclasses.dataclass
class CompareOutcome:
    out: Path
    outcomes: list[SweepOutcome]
    table: pd.DataFrame

    @property
    def failed(self) -> int:
        return sum(o.failed for o in self.outcomes)

    def lines(self) -> list[str]:
        return [o.line() for o in self.outcomes] + [f"{self.out / TABLE_FILE}; {self.out / REPORT_FILE}"]


def make_specs(scenarios: list[str | Path], controllers: str = DEFAULT_CONTROLLERS, seeds: str = "1-5",
               duration: float | None = None, budget_ms: float | None = None,
               axes: dict[str, str | None] | None = None, work_clock_ms: float | None = None,
               sets: list[str] | None = None) -> list[SweepSpec]:
    """One sweep spec per scenario; every input checked (InputError) before any run starts.
    ``duration`` [s], ``budget_ms`` [ms] and ``work_clock_ms`` [ms per QP] override every run's."""
    if not scenarios:
        raise InputError("compare", "scenario", "", "give at least one scenario file")
    try:
        parse_controllers(controllers)
    except InputError as exc:
        raise InputError("--controllers", "controllers", controllers, exc.problem) from None
    overrides = {k: v for k, v in (("duration", duration), ("budget_ms", budget_ms), ("work_clock_ms", work_clock_ms))
                 if v is not None}
    specs = [make_spec(s, None, controllers, seeds, overrides, axes, sets) for s in scenarios]
    names = [s.scenario_name for s in specs]
    for name in names:
        if names.count(name) > 1:
            raise InputError("compare", "scenario", name, "two scenario files have the same [scenario] name")
    return specs


def demand_veh_h(spec: SweepSpec) -> float:
    """Total demand [veh/h] of the scenario's flows over its (possibly overridden) demand window,
    plus its hand-placed vehicles spread over that window."""
    scn = scenario_from_dict(tomllib.loads(spec.scenario_text), spec.scenario)
    duration = dict(spec.overrides).get("duration", scn.scenario.duration)
    vehicles = sum(f.rate / 3600.0 * max(0.0, min(f.end, duration) - max(f.begin, 0.0)) for f in scn.flows)
    vehicles += len(scn.vehicles)
    if scn.network.routes:  # the route files' vehicles due in the window
        vehicles += file_counts(dataclasses.replace(scn, scenario=dataclasses.replace(scn.scenario, duration=duration)))[
            "in_window"]
    return vehicles / duration * 3600.0


def _quantile(values: np.ndarray, q: float) -> float:
    values = values[np.isfinite(values)]
    return float(np.quantile(values, q)) if len(values) else math.nan


def _mean(values: np.ndarray) -> float:
    values = values[np.isfinite(values)]
    return float(values.mean()) if len(values) else math.nan


def _min(values: np.ndarray) -> float:
    values = values[np.isfinite(values)]
    return float(values.min()) if len(values) else math.nan


def _engineer(summary: dict, run: Path) -> dict:
    """A run's engineer metrics (results/engineer.py): its summary's, with the largest
    95th-percentile queue [m] of its approaches."""
    eng = dict(summary.get("engineer") or {})
    table = run / APPROACHES_FILE
    eng["queue_p95_max"] = float(pd.read_csv(table)["queue_p95"].max()) if table.is_file() and table.stat().st_size else math.nan
    return eng


def _engineer_columns(folders: list[Path]) -> dict:
    """Of the finished runs in ``folders``: vehicles never inserted (summed), control delay [s]
    (mean over the seeds) and its HCM LOS, the largest 95th-percentile queue [m], fuel and CO2 per
    arrived trip [g] (means over the seeds); NaN where no run has them."""
    summaries = [json.loads((run / RUN_MARKER).read_text()) for run in folders]
    runs = [_engineer(summary, run) for summary, run in zip(summaries, folders)]
    not_inserted = sum(int(s.get("counts", {}).get("not_inserted") or 0) for s in summaries)

    def mean(key: str) -> float:
        return _mean(np.array([r.get(key) if r.get(key) is not None else np.nan for r in runs], float))

    delay = mean("control_delay")
    table = next((r["los_table"] for r in runs if r.get("los_table")), "")
    return {"not_inserted": not_inserted if folders else math.nan,
            "control_delay": delay, "los": level_of_service(delay, table) if table else "",
            "queue_p95_max": mean("queue_p95_max"), "fuel_g_per_trip": mean("fuel_g_per_trip"),
            "co2_g_per_trip": mean("co2_g_per_trip")}


def aggregate(spec: SweepSpec, out: Path, demand: float) -> list[dict]:
    """The comparison rows of one scenario's sweep folder (one per controller, over its seeds)."""
    ttc_thr, _, pet_thr = SSM_THRESHOLDS
    rows = []
    jobs = sweep_jobs(spec, out)
    points = list(dict.fromkeys(j.axes for j in jobs))  # the scenario axes' value combinations, grid order
    for controller, point in ((c, p) for c in spec.controllers for p in points):
        mine = [j for j in jobs if j.controller == controller and j.axes == point and j.finished]
        veh, steps, ssm, window = [], [], [], 0.0  # window: [s] the demand windows summed
        vehicles = arrived = collisions = walkers_hit = late = ended = 0
        for job in mine:
            run = Path(job.run_dir)
            summary = json.loads((run / RUN_MARKER).read_text())
            counts = summary.get("counts", {})
            duration = dict(spec.overrides).get("duration") or summary["settings"]["scenario"]["duration"]
            window += float(duration)
            vehicles += int(counts.get("vehicles") or 0)
            arrived += int(counts.get("arrived") or 0)
            collisions += int(counts.get("collisions") or 0)
            walkers_hit += int(counts.get("pedestrian_collisions") or 0)  # of the collisions: with a person
            ended += summary.get("ended_early") is not None
            va = pd.read_csv(run / VEHICLES_FILE, dtype={"vehicle": str})
            late += int((va["depart"].notna() & ~(va["arrival"].notna() & (va["time_loss"] <= LATE_AFTER))).sum())
            veh.append(va)
            steps.append(_step_sums(pd.read_csv(run / STEPS_FILE)))
            if (run / SSM_FILE).exists():  # not with [scenario] ssm = false: then not measured
                ssm.append(read_ssm(run / SSM_FILE))
        v = pd.concat(veh) if veh else pd.DataFrame(columns=["arrival", "travel_time", "time_loss"])
        v = v[v["arrival"].notna()] if len(v) else v
        st = pd.concat(steps) if steps else pd.DataFrame(columns=["compute_ms", "deadline_missed", "junctions"])
        ss = pd.concat(ssm) if ssm else pd.DataFrame(columns=["min_ttc", "pet", "ssm_collision"])
        tt = v["travel_time"].to_numpy(float)
        ttc = ss["min_ttc"].to_numpy(float)
        pet = ss["pet"].to_numpy(float)
        under = (np.nan_to_num(ttc, nan=np.inf) < ttc_thr) | (np.nan_to_num(pet, nan=np.inf) < pet_thr)
        cms = st["compute_ms"].to_numpy(float)
        misses = int(st["deadline_missed"].sum()) if len(st) else 0
        junction_steps = int(st["junctions"].sum()) if len(st) else 0
        rows.append({
            "scenario": spec.scenario_name, "demand_veh_h": demand, "controller": controller, **dict(point),
            "seeds": len(spec.seeds), "runs_ok": len(mine), "vehicles": vehicles, "arrived": arrived,
            **_engineer_columns([Path(j.run_dir) for j in mine]),
            "travel_time_mean": _mean(tt), "travel_time_p95": _quantile(tt, 0.95),
            "time_loss_mean": _mean(v["time_loss"].to_numpy(float)),
            "throughput_veh_h": arrived / window * 3600.0 if window > 0 else math.nan,
            "ssm_min_ttc": _min(ttc), "ssm_min_pet": _min(pet), "ssm_encounters": len(ss) if ssm else math.nan,
            "ssm_share_under_thresholds": float(under.mean()) if len(ss) else math.nan,
            "ssm_collision_encounters": int(ss["ssm_collision"].astype(bool).sum()) if ssm else math.nan,
            "collisions": collisions if mine else math.nan,
            "pedestrian_collisions": walkers_hit if mine else math.nan,
            "late_or_stuck": late if mine else math.nan,
            "ended_early": ended if mine else math.nan,  # runs ended early: a deadlock or memory_limit
            "compute_ms_median": _quantile(cms, 0.5), "compute_ms_p95": _quantile(cms, 0.95),
            "control_steps": len(st), "junction_steps": junction_steps, "deadline_misses": misses,
            "deadline_miss_share": misses / junction_steps if junction_steps else math.nan,
            # steps in which the game controllers' anytime step left games / solo solves out
            "deferred_step_share": (float(st["deferred"].gt(0).mean())
                                    if len(st) and "deferred" in st else math.nan),
        })
    return rows


def _step_sums(steps: pd.DataFrame) -> pd.DataFrame:
    """One row per control step of a run's steps.csv (which has one per junction and step):
    compute_ms [ms] summed over the junctions, deadline_missed the junctions that missed,
    deferred the work left out, junctions how many there were."""
    steps = steps.assign(deadline_missed=steps["deadline_missed"].astype(bool).astype(int), junctions=1)
    cols = {c: "sum" for c in ("compute_ms", "deadline_missed", "deferred", "junctions") if c in steps}
    return steps.groupby("time", sort=False).agg(cols).reset_index()


def markdown_table(table: pd.DataFrame, columns: list[str] | None = None) -> str:
    """A GitHub markdown table with units in the headers and every column rounded alike (the
    report layer's table format; columns without a known unit: 3 significant digits)."""
    from intersection_cosim.report.reporting import markdown_table as table_with_units

    return table_with_units(table, columns)


def write_report(out: Path, table: pd.DataFrame, figures: list[Path]) -> Path:
    ttc_thr, _, pet_thr = SSM_THRESHOLDS
    text = ["# Controller comparison", "",
            f"One row per scenario and controller, aggregated over the seeds ({TABLE_FILE}). Travel time and time "
            "loss over the arrived vehicles of all seeds; throughput = arrived vehicles per hour of the demand "
            f"window; SSM share = encounters with TTC < {ttc_thr:g} s or PET < {pet_thr:g} s; compute time per "
            "control step.", "", markdown_table(table), ""]
    text += _negative_time_loss_note(table) + _ssm_collision_note(table)
    text += ["## Figures", ""]
    text += [f"![{p.stem}]({p.relative_to(out).as_posix()})" for p in figures]
    path = out / REPORT_FILE
    path.write_text("\n".join(text) + "\n")
    return path


def _negative_time_loss_note(table: pd.DataFrame) -> list[str]:
    """A note under the table when a controller's mean time loss is negative: SUMO counts time
    against each lane's speed limit, so its vehicles drove faster than the limits (a turn's, with
    ``[model] lane_speed_limits`` off)."""
    below = table[pd.to_numeric(table["time_loss_mean"], errors="coerce") < 0]
    if below.empty:
        return []
    who = ", ".join(sorted({f"{r.controller} ({r.scenario})" for r in below.itertuples()}))
    return [f"Negative mean time loss ({who}): SUMO measures time loss against each lane's speed limit, so "
            "these vehicles drove faster than the limits, typically through turns. `[model] lane_speed_limits = "
            "true` makes the game controllers keep them (fcfs does not).", ""]


def _ssm_collision_note(table: pd.DataFrame) -> list[str]:
    """A note under the table when SSM classified encounters as collisions: their TTC 0 is left out
    of the SSM min TTC, and SUMO's collision check (``collisions``) is the count of collisions."""
    flagged = table[pd.to_numeric(table["ssm_collision_encounters"], errors="coerce") > 0]
    if flagged.empty:
        return []
    who = ", ".join(f"{r.controller} ({r.scenario}): {r.ssm_collision_encounters:.0f} vs {r.collisions:.0f}"
                    for r in flagged.itertuples())
    return ["SSM classified encounters as collisions (type 111, TTC 0) in some runs; SSM min TTC leaves them "
            "out, and `collisions` is SUMO's own collision check (SSM-flagged encounters vs collisions: "
            f"{who}). SSM's gap estimate flags such encounters at merges, e.g. a vehicle waiting at its stop line "
            "while another passes the merge point ahead of it.", ""]


def _overview_title(table: pd.DataFrame, axes: list[str]) -> str:
    demands = sorted(table["demand_veh_h"].unique())
    where = (f"at {demands[0]:.0f} veh/h" if len(demands) == 1 else
             f"against demand ({demands[0]:.0f}-{demands[-1]:.0f} veh/h)")
    mean = f"; each the mean over {', '.join(axes)}" if axes else ""
    return f"Controller comparison {where}, over the seeds{mean}"


def draw_figures(out: Path, table: pd.DataFrame, axes: list[str]) -> list[Path]:
    """The comparison's figures in ``out/figures/``: the overview, and a figure per metric only against
    what varies (demand with two or more levels, a scenario axis with two or more values)."""
    for stale in (out / FIGURES_DIR).glob("*.png"):  # an earlier call's figures (which ones are drawn may change)
        stale.unlink()
    keys = ["scenario", "demand_veh_h", "controller"]
    per_scenario = table.groupby(keys, sort=False)[list(FIGURE_METRICS)].mean().reset_index() if axes else table
    figures = [overview(per_scenario, FIGURE_METRICS, out / FIGURES_DIR / OVERVIEW_PNG, _overview_title(table, axes))]
    if table["demand_veh_h"].nunique() > 1:  # a line against demand has something to show
        figures += [metric_vs_demand(table, metric, label, out / FIGURES_DIR / f"{metric}_vs_demand.png")
                    for metric, label in FIGURE_METRICS.items()]
    # one figure per metric against each axis that takes two or more values
    figures += [metric_vs_axis(table, metric, label, name, f"{name} [{AXES[name].unit}]",
                               out / FIGURES_DIR / f"{metric}_vs_{name}.png", tuple(a for a in axes if a != name))
                for name in axes if table[name].nunique() > 1 for metric, label in AXIS_FIGURE_METRICS.items()]
    return figures


def write_outputs(out: Path, specs: list[SweepSpec]) -> pd.DataFrame:
    """comparison.csv, report.md and the figures from the sweep folders under ``out``."""
    rows = []
    for spec in specs:
        rows += aggregate(spec, out / spec.scenario_name, demand_veh_h(spec))
    axes = list(dict.fromkeys(name for spec in specs for name, _ in spec.scenario_axes))
    columns = COLUMNS[:3] + axes + COLUMNS[3:]
    table = pd.DataFrame(rows, columns=columns).sort_values(["demand_veh_h", "scenario"], kind="stable")
    table = table.reset_index(drop=True)
    table.to_csv(out / TABLE_FILE, index=False, float_format="%.6g")
    write_units(out, {TABLE_FILE: table.columns})
    figures = draw_figures(out, table, axes)
    write_report(out, table, figures)
    return table


def run_compare(specs: list[SweepSpec], out: str | Path, *, workers: int | None = None,
                dask_scheduler: str | None = None, progress: bool = True) -> CompareOutcome:
    """Run (or continue) every scenario's sweep into ``out/<scenario name>/``; write the comparison.

    A :class:`~intersection_cosim.experiments.sweep.SweepInterrupted` propagates (finished runs kept).
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError("--out", "out", str(out), "is a file, not a folder")
    for spec in specs:  # every scenario's folder must be new or the same sweep, before any run
        check_out(spec, out / spec.scenario_name)
    outcomes = [run_sweep(spec, out / spec.scenario_name, workers=workers, dask_scheduler=dask_scheduler,
                          progress=progress) for spec in specs]
    table = write_outputs(out, specs)
    return CompareOutcome(out=out, outcomes=outcomes, table=table)
