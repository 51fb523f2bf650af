"""Figures of a comparison of controllers (``compare``; matplotlib, Agg backend): a metric against
demand (:func:`metric_vs_demand`) or against a scenario axis such as latency or loss
(:func:`metric_vs_axis`), one line per controller."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no display; must precede pyplot
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from intersection_cosim.report.figure_style import LINE_STYLES, TRAJECTORY_MARKERS, save_figure  # noqa: E402


def metric_vs_demand(table: pd.DataFrame, metric: str, label: str, out_png: Path) -> Path:
    """A comparison metric against demand [veh/h], one line per controller (``compare``).

    ``table``: comparison.csv's rows (columns demand_veh_h, controller, ``metric``). With a single
    demand level, one bar per controller instead.
    """
    fig, ax = plt.subplots(figsize=(7, 4.2))
    controllers = list(dict.fromkeys(table["controller"]))
    cmap = plt.get_cmap("tab10")
    demands = sorted(table["demand_veh_h"].unique())
    if len(demands) <= 1:
        values = [float(table.loc[table["controller"] == c, metric].iloc[0]) for c in controllers]
        ax.bar(range(len(controllers)), np.nan_to_num(values, nan=0.0),
               color=[cmap(i % cmap.N) for i in range(len(controllers))])
        ax.set_xticks(range(len(controllers)), controllers, rotation=20, ha="right")
        for i, v in enumerate(values):
            if not np.isfinite(v):
                ax.text(i, 0, "n/a", ha="center", va="bottom", fontsize=8)
        title = f"{label} at {demands[0]:.0f} veh/h" if demands else label
        ax.set_title(title, fontsize=10)
    else:
        for i, c in enumerate(controllers):
            rows = table[table["controller"] == c].sort_values("demand_veh_h")
            ax.plot(rows["demand_veh_h"], rows[metric].astype(float), marker="o", color=cmap(i % cmap.N), label=c)
        ax.set_xlabel("demand [veh/h]")
        ax.legend(fontsize=8)
    ax.set_ylabel(label)
    ax.grid(alpha=0.3)
    fig.tight_layout()
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
    ax.set_xticks(np.arange(len(rows)), [str(r) for r in rows])
    ax.set_ylabel(label)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return save_figure(fig, out_png)
