"""The report of a stress folder (``stress.json``): the margin of every run against each drawn
parameter, the failure count per parameter bin, and ``report.md`` with the failures found.

It reads ``stress.csv`` and ``summary.json`` only."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from intersection_cosim.report.figure_style import plt, save_figure
from intersection_cosim.results.layout import STRESS_SPEC_FILE, STRESS_SUMMARY_FILE, STRESS_TABLE_FILE

BINS = 5  # [-] bins per parameter of the failure-count figure
COLUMNS = 4  # [-] panels per row
MARGIN_PNG = "margin_by_parameter.png"
FAILURES_PNG = "failures_by_parameter_bin.png"


def _grid(n: int, size: float = 3.0):
    rows = max(1, math.ceil(n / COLUMNS))
    fig, axes = plt.subplots(rows, COLUMNS, figsize=(COLUMNS * size, rows * size * 0.8), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    return fig, axes.flat


def margin_figure(table: pd.DataFrame, params: list[dict], out_png: Path) -> Path:
    """Per parameter: each finished run's margin [s] against its value; runs with a failure in red."""
    fig, axes = _grid(len(params))
    failed = table["failures"].fillna("").astype(str) != ""
    for ax, p in zip(axes, params):
        ax.scatter(table.loc[~failed, p["name"]], table.loc[~failed, "margin"], s=12, color="tab:blue",
                   label="no failure")
        ax.scatter(table.loc[failed, p["name"]], table.loc[failed, "margin"], s=14, color="tab:red", marker="x",
                   label="failure")
        ax.set_xlabel(p["name"], fontsize=8)
        ax.set_ylabel("margin [s]", fontsize=8)
        ax.tick_params(labelsize=7)
    if params:
        axes[0].legend(fontsize=7)
    fig.suptitle("margin (least PET / time gap; -1: collision, overlap or lock) per drawn parameter")
    fig.tight_layout()
    return save_figure(fig, out_png)


def bin_counts(values: pd.Series, failed: pd.Series, low: float, high: float,
               bins: int = BINS) -> tuple[np.ndarray, np.ndarray]:
    """(runs, runs with a failure) per equal-width bin of [``low``, ``high``]."""
    edges = np.linspace(low, high, bins + 1) if high > low else np.array([low - 0.5, low + 0.5])
    idx = np.clip(np.searchsorted(edges, values.to_numpy(float), side="right") - 1, 0, len(edges) - 2)
    runs = np.bincount(idx, minlength=len(edges) - 1)
    fails = np.bincount(idx, weights=failed.to_numpy(float), minlength=len(edges) - 1)
    return runs, fails.astype(int)


def failures_figure(table: pd.DataFrame, params: list[dict], out_png: Path) -> Path:
    """Per parameter: runs (grey) and runs with a failure (red) per bin of its range."""
    fig, axes = _grid(len(params))
    failed = table["failures"].fillna("").astype(str) != ""
    for ax, p in zip(axes, params):
        runs, fails = bin_counts(table[p["name"]], failed, p["low"], p["high"])
        x = np.arange(len(runs))
        ax.bar(x, runs, color="0.8", label="runs")
        ax.bar(x, fails, color="tab:red", label="with a failure")
        edges = np.linspace(p["low"], p["high"], len(runs) + 1)
        ax.set_xticks(x, [f"{a:.3g}" for a in edges[:-1]], fontsize=7)
        ax.set_xlabel(f"{p['name']} (bin start)", fontsize=8)
        ax.tick_params(labelsize=7)
    if params:
        axes[0].legend(fontsize=7)
    fig.suptitle("runs and runs with a failure per parameter bin")
    fig.tight_layout()
    return save_figure(fig, out_png)


def _failures_md(summary: dict) -> list[str]:
    if not summary["failures"]:
        return ["No failure found."]
    lines = ["| kind | place | time [s] | vehicles | runs | file | why |", "|---|---|---|---|---|---|---|"]
    for f in summary["failures"]:
        lines.append(f"| {f['kind']} | {f['place']} | {f['time']:.2f} | {', '.join(f['vehicles'][:4])} | {f['runs']} "
                     f"| [{f['file']}]({f['file']}) | {f['why']} |")
    return lines


def stress_report(folder: Path, figures_dir: str = "figures", report_file: str = "report.md") -> Path:
    """Write the figures and report.md of the stress folder ``folder``; return report.md's path."""
    spec = json.loads((folder / STRESS_SPEC_FILE).read_text())
    summary = json.loads((folder / STRESS_SUMMARY_FILE).read_text())
    table = pd.read_csv(folder / STRESS_TABLE_FILE)
    ok = table[table["status"] == "ok"]
    params = [p for p in spec["params"] if p["name"] in ok.columns]
    figs = [margin_figure(ok, params, folder / figures_dir / MARGIN_PNG),
            failures_figure(ok, params, folder / figures_dir / FAILURES_PNG)]
    counts = ", ".join(f"{k} {n}" for k, n in summary["runs_with_failure"].items())
    near = ", ".join(f"{k} {n}" for k, n in summary.get("runs_with_near_miss", {}).items()) or "none recorded"
    lines = [f"# Stress search of {spec['scenario_name']}", "",
             f"Search {spec['search']}, seed {spec['seed']}, {summary['runs_finished']}/{spec['runs']} runs finished "
             f"({summary['runs_crashed']} crashed), demand window {spec['duration']:g} s"
             + (f", settings {' '.join(spec['sets'])}" if spec["sets"] else "") + ".", "",
             f"Smallest margin {summary['min_margin']:.3f} s, median {summary['median_margin']:.3f} s. "
             f"Runs with a failure, by kind: {counts}. Runs with a near miss (no failure), by kind: {near}.", "", "## Failures (de-duplicated by kind and place)", "",
             *_failures_md(summary), "", "## Figures", ""]
    lines += [f"![{p.stem}]({figures_dir}/{p.name})" for p in figs]
    out = folder / report_file
    out.write_text("\n".join(lines) + "\n")
    return out
