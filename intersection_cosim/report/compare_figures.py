"""Figures of a comparison of controllers (``compare``; matplotlib, Agg backend): every metric in one
small-multiples panel (:func:`overview`), a metric against demand (:func:`metric_vs_demand`) or
against a scenario axis such as latency or loss (:func:`metric_vs_axis`), one line per controller."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no display; must precede pyplot
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from intersection_cosim.report.figure_style import LINE_STYLES, TRAJECTORY_MARKERS, save_figure  # noqa: E402


def _draw_metric(ax, table: pd.DataFrame, metric: str, controllers: list[str]) -> None:
    """One metric on ``ax``: one line per controller against demand [veh/h], or one bar per
    controller (grouped by scenario) when all rows share one demand level ("n/a" where not measured)."""
    cmap = plt.get_cmap("tab10")
    colour = {c: cmap(i % cmap.N) for i, c in enumerate(controllers)}
    if table["demand_veh_h"].nunique() > 1:
        for c in controllers:
            rows = table[table["controller"] == c].sort_values("demand_veh_h")
            ax.plot(rows["demand_veh_h"], rows[metric].astype(float), marker="o", color=colour[c], label=c)
        ax.set_xlabel("demand [veh/h]")
        return
    scenarios = list(dict.fromkeys(table["scenario"]))
    width = 0.8 / max(1, len(controllers))
    for j, c in enumerate(controllers):
        values = [table.loc[(table["controller"] == c) & (table["scenario"] == sc), metric].astype(float)
                  for sc in scenarios]
        values = [float(v.iloc[0]) if len(v) else np.nan for v in values]
        x = np.arange(len(scenarios)) + (j - (len(controllers) - 1) / 2) * width
        bars = ax.bar(x, np.nan_to_num(values, nan=0.0), width=width, color=colour[c], label=c)
        ax.bar_label(bars, [f"{v:.3g}" if np.isfinite(v) else "n/a" for v in values], fontsize=7)
    ax.set_xticks(range(len(scenarios)), scenarios, fontsize=8)


def metric_vs_demand(table: pd.DataFrame, metric: str, label: str, out_png: Path) -> Path:
    """A comparison metric against demand [veh/h], one line per controller (``compare``; drawn only
    when the table has two or more demand levels, else :func:`overview` shows it).

    ``table``: comparison.csv's rows (columns scenario, demand_veh_h, controller, ``metric``).
    """
    fig, ax = plt.subplots(figsize=(7, 4.2))
    _draw_metric(ax, table, metric, list(dict.fromkeys(table["controller"])))
    ax.legend(fontsize=8)
    ax.set_ylabel(label)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, out_png)


def overview(table: pd.DataFrame, metrics: dict[str, str], out_png: Path, title: str) -> Path:
    """Every metric of ``metrics`` (column -> axis label with its unit) in one small-multiples figure:
    per panel one line per controller against demand, or bars per controller and scenario when
    there is one demand level; one legend for all panels."""
    controllers = list(dict.fromkeys(table["controller"]))
    cols = 3
    rows = -(-len(metrics) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.0 * rows + 0.8), squeeze=False, layout="constrained")
    for ax, (metric, label) in zip(axes.flat, metrics.items()):
        _draw_metric(ax, table, metric, controllers)
        ax.set_title(label, fontsize=9)
        ax.tick_params(labelsize=8)
        ax.xaxis.label.set_size(8)
        ax.grid(alpha=0.3)
        if metric in ("collisions", "ssm_share_under_thresholds", "deadline_miss_share"):
            ax.set_ylim(bottom=0)
    for ax in list(axes.flat)[len(metrics):]:
        ax.set_visible(False)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(controllers), 6), fontsize=9)
    fig.suptitle(title, fontsize=11)
    return save_figure(fig, out_png)


def metric_vs_axis(table: pd.DataFrame, metric: str, label: str, axis: str, axis_label: str, out_png: Path,
                   others: tuple[str, ...] = ()) -> Path:
    """A comparison metric against the scenario axis ``axis`` (``compare --latency`` / ``--loss``).

    ``table``: comparison.csv's rows (columns scenario, controller, ``axis``, the ``others`` axes
    and ``metric``). One line per scenario, controller and value of the other axes (each mean over
    the seeds); the legend names them.
    """
    keys = ["scenario", "controller", *others]
    groups = list(table.groupby(keys, sort=False))
    scenarios = table["scenario"].nunique()
    fig, ax = plt.subplots(figsize=(7, 4.2))
    cmap = plt.get_cmap("tab10")
    for i, (key, rows) in enumerate(groups):
        key = dict(zip(keys, key if isinstance(key, tuple) else (key,)))
        name = ", ".join([key["controller"]] + ([key["scenario"]] if scenarios > 1 else [])
                         + [f"{o} {key[o]:g}" for o in others])
        rows = rows.sort_values(axis)
        ax.plot(rows[axis], rows[metric].astype(float), marker=TRAJECTORY_MARKERS[i % len(TRAJECTORY_MARKERS)],
                color=cmap(i % cmap.N), linestyle=LINE_STYLES[(i // cmap.N) % len(LINE_STYLES)], label=name)
    ax.set_xlabel(axis_label)
    ax.set_ylabel(label)
    if metric in ("collisions", "ssm_share_under_thresholds"):
        ax.set_ylim(bottom=0)
    if metric == "collisions":
        ax.yaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    ax.set_title(f"{label} against {axis}", fontsize=10)
    ax.legend(fontsize=8, ncol=2 if len(groups) > 6 else 1)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, out_png)


def grouped_bars(values: pd.DataFrame, label: str, out_png: Path) -> Path:
    """One group of bars per row of ``values`` (e.g. a scenario), one bar per column (a controller)."""
    rows, cols = list(values.index), list(values.columns)
    fig, ax = plt.subplots(figsize=(max(6.0, 1.2 * len(rows) * max(1, len(cols)) / 3), 4.2))
    width = 0.8 / max(1, len(cols))
    cmap = plt.get_cmap("tab10")
    for k, col in enumerate(cols):
        x = np.arange(len(rows)) + (k - (len(cols) - 1) / 2) * width
        ax.bar(x, values[col].to_numpy(float), width, label=str(col), color=cmap(k % 10))
    names = [str(r) for r in rows]
    crowded = sum(len(n) for n in names) > 8 * len(names) or len(names) > 6  # long names run together
    ax.set_xticks(np.arange(len(rows)), names, rotation=30 if crowded else 0, ha="right" if crowded else "center")
    ax.set_ylabel(label)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, out_png)
