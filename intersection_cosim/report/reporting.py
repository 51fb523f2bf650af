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
from intersection_cosim.report import figures as fig
from intersection_cosim.results.layout import (PAIRS_FILE, RUN_MARKER, SPEC_FILE, STEPS_FILE, TABLE_FILE, VEHICLES_FILE,
                                               run_folder)
from intersection_cosim.results.sweep_folder import load_spec, sweep_table

REPORT_FILE = "report.md"
FIGURES_DIR = "figures"
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
    if (folder / SPEC_FILE).is_file():
        return sweep_report(folder)
    if (folder / RUN_MARKER).is_file():
        return run_report(folder)
    problem = "no such folder" if not folder.exists() else \
        f"is neither a run folder (no {RUN_MARKER}) nor a sweep folder (no {SPEC_FILE})"
    raise InputError("report", "folder", str(folder), problem)


# --- helpers -----------------------------------------------------------------------------------

def _fmt(value, digits: int = 4) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return f"{float(value):.{digits}g}"
    return str(value).replace("|", "\\|").replace("\n", " ")


def markdown_table(df: pd.DataFrame, columns=None) -> str:
    cols = [c for c in (columns or df.columns) if c in df.columns]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for _, row in df[cols].iterrows():
        lines.append("| " + " | ".join(_fmt(row[c]) for c in cols) + " |")
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
    for metric in metrics:
        for x, y in itertools.combinations(axes, 2):
            png = figs / f"heatmap_{metric}_{x}_{y}.png"
            fig.kappa_heatmap(ok, metric, x, y, png)
            out.append((f"{fig.metric_label(metric)} over {x} and {y}", str(png.relative_to(folder))))
    for metric in metrics:
        for axis in axes:
            png = figs / f"lines_{metric}_vs_{axis}.png"
            fig.kappa_lines(ok, metric, axis, png)
            out.append((f"{fig.metric_label(metric)} against {axis}", str(png.relative_to(folder))))
    samples: dict[str, list[np.ndarray]] = {}
    for _, row in ok.iterrows():
        steps = run_folder(folder, row["run_id"]) / STEPS_FILE
        if steps.is_file():
            samples.setdefault(row["controller"], []).append(pd.read_csv(steps, usecols=["compute_ms"])["compute_ms"]
                                                             .to_numpy(float))
    png = figs / "compute_time_hist.png"
    fig.compute_time_histogram({c: np.concatenate(v) for c, v in samples.items()}, png,
                               title="Controller compute time per step (all finished runs)",
                               budget_ms=_budget(folder, ok))
    out.append(("compute time per control step", str(png.relative_to(folder))))
    return out


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
        rank_rows.append(f"| {label}{note} | `{best['run_id']}` | {_fmt(best[metric])} {unit} | "
                         f"`{worst['run_id']}` | {_fmt(worst[metric])} {unit} |")
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
    figures = [("trajectories (points every 0.5 s)", fig.trajectory_figure(folder, figs / "trajectory.png",
                                                                          f"Trajectories: {title}")),
               ("velocity", fig.velocity_figure(folder, figs / "velocity.png", f"Velocity: {title}"))]
    steps = pd.read_csv(folder / STEPS_FILE, usecols=["compute_ms"])["compute_ms"].to_numpy(float)
    budget = summary.get("settings", {}).get("controller", {}).get("budget_ms")
    figures.append(("compute time per control step",
                    fig.compute_time_histogram({summary.get("controller", "controller"): steps},
                                               figs / "compute_time_hist.png", budget_ms=budget)))
    counts = pd.DataFrame([summary.get("counts", {})])
    metrics = pd.DataFrame([summary.get("metrics", {})])
    gui = " (shown live in sumo-gui)" if summary.get("gui") else ""
    lines = [f"# Run report: {title}", "", f"- folder: `{folder}`{gui}",
             f"- versions: {', '.join(f'{k} {v}' for k, v in summary.get('versions', {}).items())}", "",
             "## Summary", "", markdown_table(counts), "", markdown_table(metrics), ""]
    for name, caption in ((VEHICLES_FILE, "Vehicles"), (PAIRS_FILE, "Conflicting pairs")):
        if (folder / name).is_file():
            lines += [f"## {caption}", "", markdown_table(pd.read_csv(folder / name, dtype={"vehicle": str})), ""]
    lines += ["## Figures", ""]
    for caption, path in figures:
        rel = Path(path).relative_to(folder)
        lines += [f"### {caption}", "", f"![{rel.stem}]({rel})", ""]
    lines += _animation_section(folder)
    return _write(folder / REPORT_FILE, "\n".join(lines))


def _animation_section(folder: Path) -> list[str]:
    """A link to the run's animation when ``intersection-cosim animate`` has made it."""
    from intersection_cosim.report.animation import ANIMATION_FILE

    if not (folder / ANIMATION_FILE).is_file():
        return []
    return ["## Animation", "", f"![animation]({ANIMATION_FILE})", ""]
