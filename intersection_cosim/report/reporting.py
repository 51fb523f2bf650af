"""``intersection-cosim report DIR``: figures (PNG, in ``DIR/figures/``) and ``DIR/report.md``.

A sweep folder (it holds ``sweep.json``) gets: per metric, a heatmap over every pair of kappa axes
and lines against every kappa axis (one line per controller), a histogram of the controllers'
per-step compute times, the best and worst runs by mean travel time and by min TTC, the summary
table and the failed runs. A run folder (it holds ``summary.json``) gets its trajectory, velocity
and compute-time figures with its counts, metrics, vehicles and pairs.

The report only reads: the sweep's table is rebuilt in memory from the run folders, exactly as
``sweep.csv`` is.
"""

from __future__ import annotations

import itertools
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd

from intersection_cosim.errors import InputError
from intersection_cosim.report.run_figures import trajectory_figure, velocity_figure
from intersection_cosim.report.solver_figures import compute_time_histogram
from intersection_cosim.report.stress_figures import stress_report
from intersection_cosim.report.sweep_figures import kappa_heatmap, kappa_lines, kappa_tradeoff, metric_label
from intersection_cosim.results.layout import (COMPARISON_FILE, PAIRS_FILE, RUN_MARKER, SPEC_FILE, STEPS_FILE,
                                               STRESS_SPEC_FILE, TABLE_FILE, VEHICLES_FILE, run_folder,
                                               trajectories_file)
from intersection_cosim.results.sweep_folder import load_spec, sweep_table

REPORT_FILE = "report.md"
FIGURES_DIR = "figures"
TRADEOFF_PNG = "kappa_tradeoff_{vehicle}.png"  # a sweep's trade-off figure, in FIGURES_DIR
SWEEP_METRICS = ("mean_travel_time", "min_ttc", "min_ttc_ssm", "collisions")  # heatmaps and lines
# (metric, label, unit, higher is better)
RANKINGS = (("mean_travel_time", "mean travel time", "s", False),
            ("min_ttc", "min TTC (ours)", "s", True),
            ("min_ttc_ssm", "min TTC (SUMO SSM)", "s", True))
TABLE_COLUMNS = ("run_id", "mean_travel_time", "min_ttc", "min_ttc_ssm", "min_pet", "collisions",
                 "compute_ms_median", "compute_ms_p95", "deadline_misses", "status")
MAX_TABLE_ROWS = 500


def write_report(folder: str | Path) -> Path:
    """Write the report of a run or a sweep folder; return the path of ``report.md``."""
    folder = Path(folder)
    if (folder / STRESS_SPEC_FILE).is_file():
        return stress_report(folder, FIGURES_DIR, REPORT_FILE)
    if (folder / SPEC_FILE).is_file():
        return sweep_report(folder)
    if (folder / RUN_MARKER).is_file():
        return run_report(folder)
    if (folder / COMPARISON_FILE).is_file():
        inner = sorted(p.name for p in folder.iterdir() if (p / SPEC_FILE).is_file())
        problem = (f"is a compare folder: compare writes its {REPORT_FILE} (the same compare command again "
                   f"refreshes it, skipping finished runs); report takes each scenario's sweep folder in it "
                   f"({', '.join(inner) or 'none'})")
    elif not folder.exists():
        problem = "no such folder"
    else:
        problem = f"is neither a run folder (no {RUN_MARKER}) nor a sweep folder (no {SPEC_FILE})"
    raise InputError("report", "folder", str(folder), problem)


# --- helpers -----------------------------------------------------------------------------------

# Table headers and rounding: every report.md table shows a column's unit and rounds it alike.
# (name or prefix, header, decimals): decimals None = an integer count; a prefix ends in "_" and the
# rest of the column name (a vehicle, a pair "V1_V2") goes into the header.
COLUMN_FORMATS = (
    ("paper_min_ttc", "min TTC, paper [s]", 2), ("time_min_ttc_ssm", "min TTC taken at, SSM [s]", 2), ("pet", "PET, ours [s]", 2),
    ("ratio_paper_min_ttc", "min TTC ratio, paper [-]", 2), ("ratio_min_ttc", "min TTC ratio, ours [-]", 2),
    ("ratio_pet", "PET ratio, ours [-]", 2),
    ("run_id", "run", "text"), ("seed", "seed", "text"), ("exit_lane", "exit lane", "text"),
    ("vehicle_a", "vehicle a", "text"), ("vehicle_b", "vehicle b", "text"), ("kappa_", "κ {} [-]", 2), ("kappa", "κ [-]", 2),
    ("mean_travel_time", "mean travel time [s]", 2), ("travel_time_mean", "travel time, mean [s]", 2),
    ("travel_time_p95", "travel time, p95 [s]", 2), ("travel_time_", "travel time {} [s]", 2),
    ("travel_time", "travel time [s]", 2), ("time_loss_mean", "time loss, mean [s]", 2),
    ("time_loss", "time loss [s]", 2), ("depart", "depart [s]", 2), ("arrival", "arrival [s]", 2),
    ("min_ttc_ssm_", "min TTC {}, SSM [s]", 2), ("min_ttc_ssm", "min TTC, SSM [s]", 2),
    ("ssm_min_ttc", "min TTC, SSM [s]", 2), ("min_ttc_", "min TTC {}, ours [s]", 2),
    ("min_ttc", "min TTC, ours [s]", 2), ("pet_ssm", "PET, SSM [s]", 2), ("pet_", "PET {}, SSM [s]", 2),
    ("min_pet", "min PET, SSM [s]", 2), ("ssm_min_pet", "min PET, SSM [s]", 2),
    ("compute_ms_median", "compute median [ms]", 2), ("compute_ms_p95", "compute p95 [ms]", 2),
    ("throughput_veh_h", "throughput [veh/h]", 0), ("demand_veh_h", "demand [veh/h]", 0),
    ("ssm_share_under_thresholds", "share of SSM encounters under thresholds [-]", 3),
    ("deadline_miss_share", "share of steps missing the deadline [-]", 4),
    ("deferred_step_share", "share of steps with deferred work [-]", 4),
    *((name, f"{name.replace('_', ' ')} [-]", None) for name in (
        "collisions", "arrived", "vehicles", "departed", "deadline_misses", "fallbacks", "control_steps",
        "game_steps", "seeds", "runs_ok", "ssm_encounters", "ssm_collision_encounters", "late_or_stuck", "ended_early", "steps_with_deferred_work",
        "safety_interventions", "box_rule_clearances", "pedestrian_collisions", "pedestrian_holds", "junction_steps",
        "games")),
    ("junction", "junction", "text"), ("mean_delay", "mean delay [s]", 2),
)


def column_format(column: str) -> tuple[str, int | str | None]:
    """(header with unit, decimals) of a table column; decimals None: an integer, "text": as is,
    "sig": 3 significant digits (a column without a known unit keeps its name)."""
    for name, header, decimals in COLUMN_FORMATS:
        if column == name:
            return header.replace(" {}", ""), decimals
        if name.endswith("_") and column.startswith(name):
            return header.format(column[len(name):].replace("_", "-")), decimals
    return column, "sig"


def format_cell(value, decimals: int | str | None = "sig") -> str:
    if value is None or (isinstance(value, (float, np.floating)) and math.isnan(value)):
        return ""
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (int, np.integer, float, np.floating)) and decimals != "text":
        if decimals == "sig":
            if isinstance(value, (int, np.integer)):
                return str(int(value))
            return f"{float(value):.3g}" if abs(value) < 1000 else f"{float(value):.0f}"
        return f"{float(value):.0f}" if decimals is None else f"{float(value):.{decimals}f}"
    return str(value).replace("|", "\\|").replace("\n", " ")


def _fmt(value, column: str = "") -> str:
    return format_cell(value, column_format(column)[1])


def markdown_table(df: pd.DataFrame, columns=None) -> str:
    """A markdown table with units in the headers and each column rounded by :func:`column_format`."""
    cols = [c for c in (columns or df.columns) if c in df.columns]
    formats = [column_format(c) for c in cols]
    lines = ["| " + " | ".join(h for h, _ in formats) + " |", "|" + "---|" * len(cols)]
    for _, row in df[cols].iterrows():
        lines.append("| " + " | ".join(format_cell(row[c], d) for c, (_, d) in zip(cols, formats, strict=True)) + " |")
    return "\n".join(lines)


def _fresh_figures(folder: Path) -> Path:
    figs = folder / FIGURES_DIR
    shutil.rmtree(figs, ignore_errors=True)
    figs.mkdir(parents=True)
    return figs


def _write(path: Path, text: str) -> Path:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    tmp.replace(path)
    return path


def best_and_worst(table: pd.DataFrame, metric: str, higher_is_better: bool) -> tuple[pd.Series, pd.Series] | None:
    """The best and the worst finished runs by ``metric`` (ties: the first in grid order)."""
    ok = table[(table["status"] == "ok") & table[metric].notna()] if metric in table else table.iloc[0:0]
    if ok.empty:
        return None
    values = ok[metric].astype(float)
    hi, lo = ok.loc[values.idxmax()], ok.loc[values.idxmin()]
    return (hi, lo) if higher_is_better else (lo, hi)


# --- sweep -------------------------------------------------------------------------------------

def sweep_figures(folder: Path, table: pd.DataFrame, spec) -> list[tuple[str, str]]:
    """Write the sweep's figures; return (caption, path relative to ``folder``)."""
    figs = _fresh_figures(folder)
    ok = table[table["status"] == "ok"]
    out: list[tuple[str, str]] = []
    metrics = [m for m in SWEEP_METRICS if m in ok and ok[m].notna().any()]
    axes = spec.axes
    vehicle = tradeoff_vehicle(spec)
    if vehicle is not None and len(ok):
        png = figs / TRADEOFF_PNG.format(vehicle=vehicle)
        kappa_tradeoff(ok, vehicle, png)
        out.append((f"Trade-off: {vehicle}'s travel time against its min TTC and PET, one point per kappa value "
                    "(more aggressive: faster, closer)", str(png.relative_to(folder))))
    for metric in metrics:
        for x, y in itertools.combinations(axes, 2):
            png = figs / f"heatmap_{metric}_{x}_{y}.png"
            kappa_heatmap(ok, metric, x, y, png)
            out.append((f"{metric_label(metric)} over {x} and {y}", str(png.relative_to(folder))))
    at_start = SSM_AT_START if "min_ttc_ssm" in metrics and _ssm_before_control(folder, table) else ""
    for metric in metrics:
        for axis in axes:
            png = figs / f"lines_{metric}_vs_{axis}.png"
            kappa_lines(ok, metric, axis, png)
            out.append((f"{metric_label(metric)} against {axis}" + (at_start if metric == "min_ttc_ssm" else ""),
                        str(png.relative_to(folder))))
    samples: dict[str, list[np.ndarray]] = {}
    for _, row in ok.iterrows():
        steps = run_folder(folder, row["run_id"]) / STEPS_FILE
        if steps.is_file():
            per_step = pd.read_csv(steps).groupby("time", sort=False)["compute_ms"].sum()  # [ms] over the junctions
            samples.setdefault(row["controller"], []).append(per_step.to_numpy(float))
    png = figs / "compute_time_hist.png"
    compute_time_histogram({c: np.concatenate(v) for c, v in samples.items()}, png,
                               title="Controller compute time per step (all finished runs)",
                               budget_ms=_budget(folder, ok))
    out.append(("compute time per control step", str(png.relative_to(folder))))
    return out


SSM_AT_START = (" (in every run taken before the first decision acted: the vehicles' speeds as inserted, "
                "not a margin the controller kept)")


def _ssm_before_control(folder: Path, table: pd.DataFrame) -> bool:
    """True when every finished run with an SSM min TTC took it at or before its first control
    step [s] (summary.json ``time_min_ttc_ssm``; steps.csv's first time)."""
    ok = table[(table["status"] == "ok") & table["min_ttc_ssm"].notna()] if "min_ttc_ssm" in table else table.iloc[0:0]
    if ok.empty or "time_min_ttc_ssm" not in ok or ok["time_min_ttc_ssm"].isna().any():
        return False
    for run_id, at in zip(ok["run_id"], ok["time_min_ttc_ssm"].astype(float)):
        steps = run_folder(folder, run_id) / STEPS_FILE
        first = pd.read_csv(steps, nrows=1)["time"] if steps.is_file() else pd.Series(dtype=float)
        if first.empty or at > float(first.iloc[0]) + 1e-9:
            return False
    return True


def tradeoff_vehicle(spec) -> str | None:
    """The vehicle whose kappa the sweep varies, when it varies exactly one vehicle's (others may be
    set to one value): the sweep then gets the kappa trade-off figure."""
    varied = [vid for vid, values in spec.kappa if len(values) > 1]
    return varied[0] if len(varied) == 1 else None


def _budget(folder: Path, ok: pd.DataFrame) -> float | None:
    if ok.empty:
        return None
    try:
        summary = json.loads((run_folder(folder, ok["run_id"].iloc[0]) / RUN_MARKER).read_text())
        return float(summary["settings"]["controller"]["budget_ms"])
    except (OSError, KeyError, TypeError, ValueError):
        return None


def sweep_report(folder: Path) -> Path:
    folder = Path(folder)
    spec = load_spec(folder)
    table = sweep_table(folder, spec)
    figures = sweep_figures(folder, table, spec)
    ok = table[table["status"] == "ok"]
    failed = table[table["status"] == "failed"]
    grid = "; ".join(f"{vid} = {', '.join(f'{v:g}' for v in values)}" for vid, values in spec.kappa) or "none"
    lines = [f"# Sweep report: {spec.scenario_name}", "",
             f"- scenario: `{spec.scenario}` (sha256 {spec.scenario_sha256[:12]})",
             f"- controllers: {', '.join(spec.controllers)}; seeds: {', '.join(map(str, spec.seeds))}",
             f"- kappa grid: {grid}",
             f"- runs: {spec.total} in the grid, {len(ok)} finished, {len(failed)} failed, "
             f"{spec.total - len(table)} not run", "",
             "## Best and worst runs", ""]
    rank_rows = []
    for metric, label, unit, higher in RANKINGS:
        bw = best_and_worst(table, metric, higher)
        if bw is None:
            rank_rows.append(f"| {label} | - | | - | |")
            continue
        best, worst = bw
        note = " (all runs tie)" if best[metric] == worst[metric] else ""
        if metric == "min_ttc_ssm" and _ssm_before_control(folder, table):
            note += SSM_AT_START
        rank_rows.append(f"| {label}{note} | `{best['run_id']}` | {_fmt(best[metric], metric)} {unit} | "
                         f"`{worst['run_id']}` | {_fmt(worst[metric], metric)} {unit} |")
    lines += ["| by | best | value | worst | value |", "|---|---|---|---|---|", *rank_rows, "",
              "Lower mean travel time is better; a higher min TTC is better. Ties go to the first run in grid "
              "order.", "", "## Figures", ""]
    if len(spec.axes) < 2:
        lines += ["(No heatmaps: they need at least two swept kappa axes.)", ""]
    for caption, path in figures:
        lines += [f"### {caption}", "", f"![{Path(path).stem}]({path})", ""]
    lines += ["## Summary table", "",
              f"Every column (per-vehicle travel times, per-pair TTC and PET) is in [{TABLE_FILE}]({TABLE_FILE}).", ""]
    shown = table.head(MAX_TABLE_ROWS)
    lines += [markdown_table(shown, ["run_id", "controller", "seed", *spec.axes,
                                     *[c for c in TABLE_COLUMNS if c != "run_id"]]), ""]
    if len(table) > MAX_TABLE_ROWS:
        lines += [f"({len(table) - MAX_TABLE_ROWS} more rows in {TABLE_FILE})", ""]
    if len(failed):
        lines += ["## Failed runs", ""] + [f"- `{r['run_id']}`: {r['error']}" for _, r in failed.iterrows()] + [""]
    return _write(folder / REPORT_FILE, "\n".join(lines))


# --- single run --------------------------------------------------------------------------------

def run_report(folder: Path) -> Path:
    folder = Path(folder)
    summary = json.loads((folder / RUN_MARKER).read_text())
    figs = _fresh_figures(folder)
    title = f"{summary.get('scenario', folder.name)}, {summary.get('controller', '')}, seed {summary.get('seed', '')}"
    figures = [("trajectories (points every 0.5 s, colour = time)", trajectory_figure(folder, figs / "trajectory.png",
                                                                          f"Trajectories: {title}")),
               ("velocity (entry into and exit from the conflict zone marked)", velocity_figure(folder, figs / "velocity.png", f"Velocity: {title}"))]
    step_rows = pd.read_csv(folder / STEPS_FILE)
    # [ms] per control step, summed over the junctions' controllers (steps.csv has one row per junction)
    steps = step_rows.groupby("time", sort=False)["compute_ms"].sum().to_numpy(float)
    budget = summary.get("settings", {}).get("controller", {}).get("budget_ms")
    figures.append(("compute time per control step",
                    compute_time_histogram({summary.get("controller", "controller"): steps},
                                               figs / "compute_time_hist.png", budget_ms=budget)))
    counts = pd.DataFrame([summary.get("counts", {})])
    metrics = pd.DataFrame([summary.get("metrics", {})])
    gui = " (shown live in sumo-gui)" if summary.get("gui") else ""
    lines = [f"# Run report: {title}", "", f"- folder: `{folder}`{gui}",
             f"- versions: {', '.join(f'{k} {v}' for k, v in summary.get('versions', {}).items())}", "",
             "## Summary", "", markdown_table(counts), "", markdown_table(metrics), ""]
    lines += _engineer_section(folder, summary, figs, figures, title)
    lines += _junction_section(folder, summary, step_rows, figs, figures, title)
    for name, caption in ((VEHICLES_FILE, "Vehicles"), (PAIRS_FILE, "Conflicting pairs")):
        if (folder / name).is_file():
            lines += [f"## {caption}", "", markdown_table(pd.read_csv(folder / name, dtype={"vehicle": str})), ""]
    lines += ["## Figures", ""]
    for caption, path in figures:
        rel = Path(path).relative_to(folder)
        lines += [f"### {caption}", "", f"![{rel.stem}]({rel})", ""]
    lines += _animation_section(folder)
    return _write(folder / REPORT_FILE, "\n".join(lines))


def _junction_section(folder: Path, summary: dict, steps: pd.DataFrame, figs: Path, figures: list,
                      title: str) -> list[str]:
    """A run on a net file with several managed junctions: the per-junction table, and the
    network figure (junctions coloured by mean delay) appended to ``figures``."""
    settings = summary.get("settings", {})
    network = settings.get("network", {})
    if not network.get("file") or len(network.get("junctions") or ()) < 2:
        return []
    from intersection_cosim.network.build import NET_FILE
    from intersection_cosim.network.junction_net import load_movements
    from intersection_cosim.report.network_figure import junction_delay_figure
    from intersection_cosim.results.junction_metrics import junction_table

    net = folder / NET_FILE
    movements = load_movements(net, tuple(network["junctions"]), network["control_range"])
    traj = pd.read_csv(trajectories_file(folder), usecols=["vehicle", "path", "speed"], dtype={"vehicle": str})
    v_max = float(settings.get("model", {}).get("v_max", 10.0))  # [m/s]
    v_free, against = _free_speeds(network, movements, v_max)
    table = junction_table(steps, traj, movements, settings["controller"]["period"], v_free)
    figures.append(("junctions coloured by the mean delay of the vehicles that passed them",
                    junction_delay_figure(net, table, figs / "junction_delay.png", f"Mean delay per junction: {title}")))
    return ["## Junctions", "",
            f"One controller per junction. Delay: time lost against {against} while on the junction's "
            "movement paths (control range, junction, exit lane); compute time per junction and control step.",
            "", markdown_table(table), ""]


def _free_speeds(network: dict, movements, v_max: float) -> tuple[float | dict[str, float], str]:
    """The free speed [m/s] a junction's delay is counted against, with its words for the report:
    the model's v_max, or, where the user's route-file vehicles desire their roads' limits
    ([network] desired_speed "road"; a summary without the key is older, of "v_max"), each path's
    approach lane limit, as they do."""
    if not network.get("routes") or network.get("desired_speed", "v_max") != "road":
        return v_max, f"{v_max:g} m/s"
    free = {pid: p.speed_limits[p.stop_index - 1] if p.speed_limits else v_max for pid, p in movements.paths.items()}
    return free, "the speed limit of each approach lane (the route-file vehicles' desired speed)"


def _engineer_section(folder: Path, summary: dict, figs: Path, figures: list, title: str) -> list[str]:
    """The traffic engineer's view (results/engineer.py): control delay, LOS, fuel and CO2 of the
    run, the per-approach table, and the delay-per-approach figure appended to ``figures``."""
    from intersection_cosim.report.engineer_figures import approach_delay_figure
    from intersection_cosim.results.layout import APPROACHES_FILE

    eng = summary.get("engineer")
    if eng is None or not (folder / APPROACHES_FILE).is_file():
        return []
    table = pd.read_csv(folder / APPROACHES_FILE, dtype={"junction": str, "approach": str})
    fig = approach_delay_figure(table, figs / "approach_delay.png", f"Control delay per approach: {title}")
    if fig is not None:
        figures.append(("control delay per approach, coloured by HCM level of service", fig))
    classes = ", ".join(f"{k}: {v}" for k, v in (eng.get("emission_classes") or {}).items())
    run = pd.DataFrame([{k: v for k, v in eng.items() if k != "emission_classes"}])
    return ["## Traffic engineer's view", "",
            "Control delay: SUMO's time loss (tripinfo) of the arrived trips, per approach and movement; "
            f"level of service by the {eng.get('los_table') or 'HCM'} table; queues [m] from SUMO's queue "
            "output of the approach edge (95th percentile over the steps with a queue, maximum); throughput "
            "[veh/h] of the demand window; fuel [g] and CO2 [kg] from SUMO's emissions device (HBEFA; "
            f"emission classes {classes or 'not recorded'}).", "",
            markdown_table(run), "", markdown_table(table), ""]


def _animation_section(folder: Path) -> list[str]:
    """A link to the run's animation when ``intersection-cosim animate`` has made it."""
    from intersection_cosim.report.animation import ANIMATION_FILE

    if not (folder / ANIMATION_FILE).is_file():
        return []
    return ["## Animation", "", f"![animation]({ANIMATION_FILE})", ""]
