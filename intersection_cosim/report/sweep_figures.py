"""Figures of a kappa sweep (matplotlib, Agg backend), each writing a PNG; the ``draw_*`` functions
draw one figure's content into given axes and return what they drew.

:func:`kappa_tradeoff` (one vehicle's travel time against its min TTC and PET, one point per kappa
value), :func:`kappa_heatmap` (a metric over two kappa axes) and :func:`kappa_lines` (a metric
against one kappa, one line per controller).
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no display; must precede pyplot
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.cm  # noqa: E402
import matplotlib.colors  # noqa: E402
import matplotlib.ticker  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from intersection_cosim.report.figure_style import TRAJECTORY_MARKERS, save_figure  # noqa: E402

METRIC_LABELS = {
    "mean_travel_time": "mean travel time [s]",
    "min_ttc": "min TTC, ours [s]",
    "min_ttc_ssm": "min TTC, SUMO SSM [s]",
    "min_pet": "min PET, SUMO SSM [s]",
    "collisions": "collisions [-]",
    "compute_ms_median": "compute time, median [ms]",
    "compute_ms_p95": "compute time, 95th percentile [ms]",
    "deadline_misses": "deadline misses [-]",
}


def metric_label(metric: str) -> str:
    return METRIC_LABELS.get(metric, metric)


def _ok(table: pd.DataFrame) -> pd.DataFrame:
    return table[table["status"] == "ok"] if "status" in table else table


def kappa_heatmap(table: pd.DataFrame, metric: str, x: str, y: str, out_png: Path,
                  title: str | None = None) -> Path:
    """``metric`` over the kappa axes ``x`` and ``y`` (sweep.csv columns), one panel per controller;
    each cell is the mean over seeds and the other axes; one colour scale for all panels."""
    ok = _ok(table)
    controllers = list(dict.fromkeys(ok["controller"])) or ["(none)"]
    xs = sorted(ok[x].unique()) if len(ok) else []
    ys = sorted(ok[y].unique()) if len(ok) else []
    grids = {}
    for c in controllers:
        sub = ok[ok["controller"] == c]
        piv = sub.pivot_table(index=y, columns=x, values=metric, aggfunc="mean") if len(sub) else pd.DataFrame()
        grids[c] = piv.reindex(index=ys, columns=xs).to_numpy(float) if len(xs) and len(ys) else np.full((1, 1), np.nan)
    finite = np.concatenate([g[np.isfinite(g)] for g in grids.values()]) if grids else np.zeros(0)
    vmin, vmax = (float(finite.min()), float(finite.max())) if len(finite) else (0.0, 1.0)
    if vmin == vmax:
        vmin, vmax = vmin - 0.5, vmax + 0.5
    n = len(controllers)
    fig, axes = plt.subplots(1, n, figsize=(1.0 + 3.8 * n, 3.8), squeeze=False, layout="constrained")
    im = None
    for ax, c in zip(axes[0], controllers, strict=True):
        g = grids[c]
        im = ax.imshow(g, origin="lower", cmap="viridis", vmin=vmin, vmax=vmax, aspect="auto")
        ax.set_xticks(range(len(xs)), [f"{v:g}" for v in xs], rotation=45 if len(xs) > 6 else 0)
        ax.set_yticks(range(len(ys)), [f"{v:g}" for v in ys])
        ax.set_xlabel(_axis_label(x))
        ax.set_ylabel(_axis_label(y))
        ax.set_title(c)
        if g.size <= 100:
            for (i, j) in itertools.product(range(g.shape[0]), range(g.shape[1])):
                if np.isfinite(g[i, j]):
                    ax.text(j, i, f"{g[i, j]:.3g}", ha="center", va="center", fontsize=7,
                            color="white" if g[i, j] < (vmin + vmax) / 2 else "black")
    fig.colorbar(im, ax=axes[0].tolist(), label=metric_label(metric))
    fig.suptitle(title or f"{metric_label(metric)} (mean over seeds and other axes)")
    return save_figure(fig, out_png)


COUNT_METRICS = ("collisions", "deadline_misses", "fallbacks", "arrived", "vehicles")  # integer y axis
FEW_POINTS = 6  # [-] lines with at most this many points get large markers and their values written


def _axis_label(column: str) -> str:
    return column.replace("kappa_", "$\\kappa$ of ") if column.startswith("kappa_") else column


VALUE_LABEL_PLACES = ((0, 7, "center"), (0, -14, "center"), (9, -3, "left"))  # above, below, right [pt]


def _label_values(ax, means: dict, metric: str) -> None:
    """Write each controller's mean (``means``: controller -> (Series over x, colour)) at its
    point: at each x the highest above its point, the lowest below, a third one to the right, so
    the labels of nearly equal values do not print over each other."""
    xs = sorted({x for series, _ in means.values() for x in series.index})
    for x in xs:
        at = [(float(s[x]), colour) for s, colour in means.values() if x in s.index and np.isfinite(s[x])]
        order = sorted(range(len(at)), key=lambda i: -at[i][0])
        places = [VALUE_LABEL_PLACES[0]] if len(at) == 1 else \
            [VALUE_LABEL_PLACES[0], *VALUE_LABEL_PLACES[2:len(at)], VALUE_LABEL_PLACES[1]]
        for rank, i in enumerate(order):
            y, colour = at[i]
            dx, dy, ha = places[rank]
            ax.annotate(_short(y, metric), (x, y), xytext=(dx, dy), textcoords="offset points", ha=ha,
                        fontsize=8, color=colour, gid="value-label")


def kappa_lines(table: pd.DataFrame, metric: str, axis: str, out_png: Path, title: str | None = None) -> Path:
    """``metric`` against the kappa axis ``axis`` (:func:`draw_kappa_lines`), written to ``out_png``."""
    fig, ax = plt.subplots(figsize=(6.4, 4.0), layout="constrained")
    draw_kappa_lines(ax, table, metric, axis)
    ax.set_title(title or f"{metric_label(metric)} against {_axis_label(axis)}")
    return save_figure(fig, out_png)


def draw_kappa_lines(ax, table: pd.DataFrame, metric: str, axis: str) -> None:
    """``metric`` against the kappa axis ``axis``, one line per controller: the mean over seeds and
    the other axes, with their min-max range shaded. Few points get large markers with their
    values; a metric that is the same in every run gets an axis from 0 and says so."""
    ok = _ok(table)
    controllers = list(dict.fromkeys(ok["controller"]))
    xs = sorted(ok[axis].unique()) if len(ok) else []
    few = len(xs) <= FEW_POINTS
    values = ok[metric].astype(float).to_numpy() if metric in ok else np.zeros(0)
    values = values[np.isfinite(values)]
    constant = bool(len(values)) and values.min() == values.max()
    means = {}
    for c in controllers:
        g = ok[ok["controller"] == c].groupby(axis)[metric].agg(["mean", "min", "max"]).sort_index()
        line, = ax.plot(g.index, g["mean"], marker="o", ms=8 if few else 5, lw=1.6, label=c)
        if (g["max"] > g["min"]).any():
            ax.fill_between(g.index, g["min"], g["max"], color=line.get_color(), alpha=0.15, lw=0)
        means[c] = (g["mean"], line.get_color())
    if few and len(controllers) <= 3 and not constant:
        _label_values(ax, means, metric)
    if constant:  # the same in every run: an axis from 0, not -0.04..0.04 around the value
        c = float(values[0])
        lo, hi = (0.0, max(1.0, 2.0 * c)) if c >= 0 else (2.0 * c, 0.0)
        ax.set_ylim(lo - 0.04 * (hi - lo), hi)
        ax.text(0.5, 0.92, f"{_short(c, metric)} in every run ({len(values)} runs)", ha="center", va="top",
                transform=ax.transAxes, fontsize=9, bbox=dict(facecolor="white", edgecolor="#bfbfbf"))
    if metric in COUNT_METRICS:
        ax.yaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    if len(xs) <= 10:
        ax.set_xticks(xs, [f"{x:g}" for x in xs])
    if few and not constant:
        ax.margins(y=0.15)  # room for the values written above the points
    ax.set_xlabel(_axis_label(axis))
    ax.set_ylabel(metric_label(metric))
    ax.grid(alpha=0.3)
    ax.legend(title="controller", fontsize=8)


def _short(value: float, metric: str) -> str:
    return f"{value:.0f}" if metric in COUNT_METRICS else f"{value:.2f}"


def vehicle_pair_columns(table: pd.DataFrame, vehicle: str, measure: str) -> list[str]:
    """sweep.csv's per-pair columns of ``measure`` (``min_ttc`` or ``pet``) for pairs with ``vehicle``."""
    out = []
    for col in table.columns:
        if col.startswith(f"{measure}_") and not col.startswith("min_ttc_ssm_"):
            pair = col[len(measure) + 1:]  # "<a>_<b>"
            if pair.startswith(f"{vehicle}_") or pair.endswith(f"_{vehicle}"):
                out.append(col)
    return out


def tradeoff_points(table: pd.DataFrame, vehicle: str) -> pd.DataFrame:
    """One row per controller and kappa value of ``vehicle``: the means over seeds and other axes
    of its travel time [s] and of the smallest min TTC (ours) and SSM PET [s] over its pairs (the
    run's minimum where sweep.csv has no pair columns for it)."""
    ok = _ok(table)
    axis = f"kappa_{vehicle}"
    rows = ok[["controller", axis]].copy()
    rows["travel_time"] = ok.get(f"travel_time_{vehicle}", ok.get("mean_travel_time"))
    for measure, fallback, name in (("min_ttc", "min_ttc", "min_ttc"), ("pet", "min_pet", "min_pet")):
        cols = vehicle_pair_columns(ok, vehicle, measure)
        rows[name] = ok[cols].astype(float).min(axis=1) if cols else ok.get(fallback, np.nan)
    points = rows.groupby(["controller", axis], sort=False).mean(numeric_only=True).reset_index()
    return points.rename(columns={axis: "kappa"}).sort_values(["controller", "kappa"], kind="stable")


LABEL_OFFSETS = ((7, 5), (7, -12), (-7, 5), (-7, -12), (7, 15), (7, -22), (-7, 15), (-7, -22))  # [pt]


def kappa_label_groups(px: np.ndarray, kappa: np.ndarray, near: float = 14.0) -> list[tuple[int, str]]:
    """(index, text) labels of points at display positions ``px`` (n, 2) [px] in kappa order: a
    run of consecutive points within ``near`` [px] of the run's first point is labelled once, at
    its first point, with its kappa range ("kappa 0.7-0.9"); single labels would print over each
    other (an aggressive end that the safety filter's gap holds in one place)."""
    out, start = [], 0
    for i in range(1, len(px) + 1):
        if i < len(px) and math.hypot(*(px[i] - px[start])) <= near:
            continue
        text = f"{kappa[start]:g}" if i - 1 == start else f"{kappa[start]:g}-{kappa[i - 1]:g}"
        out.append((start, f"$\\kappa$ {text}"))
        start = i
    return out


def place_labels(ax, xy: np.ndarray, kappa: np.ndarray, taken: list) -> None:
    """Annotate the points ``xy`` (n, 2, data units, kappa order) with their kappa values
    (:func:`kappa_label_groups`), each label at the first offset of LABEL_OFFSETS whose box
    overlaps no label placed before and no point's marker; ``taken``: boxes [px] already used."""
    scale = ax.figure.dpi / 72.0  # [px/pt]
    px = ax.transData.transform(xy)
    taken.extend((x - 6, y - 6, x + 6, y + 6) for x, y in px)  # the markers
    for k, (i, text) in enumerate(kappa_label_groups(px, kappa)):
        width, height = 5.2 * len(text.replace("$\\kappa$", "k")) * scale, 9.0 * scale  # [px] of a fontsize-8 label
        for dx, dy in LABEL_OFFSETS[k % 2:] + LABEL_OFFSETS[:k % 2]:  # alternate above and below first
            x0 = px[i, 0] + dx * scale - (width if dx < 0 else 0.0)
            y0 = px[i, 1] + dy * scale
            box = (x0, y0, x0 + width, y0 + height)
            if not any(box[0] < b[2] and b[0] < box[2] and box[1] < b[3] and b[1] < box[3] for b in taken):
                break
        taken.append(box)
        ax.annotate(text, tuple(xy[i]), xytext=(dx, dy), textcoords="offset points", fontsize=8,
                    ha="right" if dx < 0 else "left", gid="kappa-label")


def draw_kappa_tradeoff(axes, table: pd.DataFrame, vehicle: str) -> pd.DataFrame:
    """Two panels: ``vehicle``'s travel time against its min TTC (``axes[0]``) and min PET
    (``axes[1]``), one point per kappa value labelled with it, joined in kappa order, one marker
    per controller (a kappa value is labelled at its first controller's point only: the
    controllers' points of one value often coincide, and their labels would print over each
    other; the colour names the value at every point); returns :func:`tradeoff_points`."""
    points = tradeoff_points(table, vehicle)
    norm = matplotlib.colors.Normalize(0.0, 1.0)
    cmap = plt.get_cmap("coolwarm")  # blue cautious, red aggressive
    panels = []
    for ax, column, label in ((axes[0], "min_ttc", f"min TTC of {vehicle}'s conflicts, ours [s]"),
                              (axes[1], "min_pet", f"min PET of {vehicle}'s conflicts, SUMO SSM [s]")):
        labelled, todo = set(), []
        for i, (c, g) in enumerate(points.groupby("controller", sort=False)):
            g = g[np.isfinite(g[column]) & np.isfinite(g["travel_time"])]
            ax.plot(g["travel_time"], g[column], color="#7f7f7f", lw=0.9, zorder=2)
            ax.scatter(g["travel_time"], g[column], c=g["kappa"], cmap=cmap, norm=norm, s=70, zorder=3,
                       marker=TRAJECTORY_MARKERS[i % len(TRAJECTORY_MARKERS)], edgecolors="black", linewidths=0.6,
                       label=c)
            todo.append(g[~g["kappa"].isin(labelled)])
            labelled.update(g["kappa"])
        if not np.isfinite(points[column]).any():
            ax.text(0.5, 0.5, "not recorded (no conflict measured)", ha="center", va="center",
                    transform=ax.transAxes)
        ax.margins(0.12)  # room for the kappa labels
        ax.set_xlabel(f"travel time of {vehicle} [s]")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.text(0.02, 0.98, "better: up and to the left", ha="left", va="top", transform=ax.transAxes, fontsize=8,
                color="#595959")
        if points["controller"].nunique() > 1:
            ax.legend(title="controller", fontsize=8, loc="lower right")
        panels.append((ax, column, todo))
    axes[0].figure.canvas.draw()  # the final limits and layout, so that the label boxes are in place
    for ax, column, todo in panels:
        taken: list = []
        for g in todo:
            place_labels(ax, g[["travel_time", column]].to_numpy(float), g["kappa"].to_numpy(float), taken)
    return points


def kappa_tradeoff(table: pd.DataFrame, vehicle: str, out_png: Path, title: str | None = None) -> Path:
    """The paper's thesis in one picture (:func:`draw_kappa_tradeoff`): how ``vehicle``'s
    aggressiveness trades its safety margins for its passing time."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6), layout="constrained")
    # the colour bar and title first: the labels are placed in the final layout
    fig.colorbar(matplotlib.cm.ScalarMappable(norm=matplotlib.colors.Normalize(0, 1), cmap="coolwarm"),
                 ax=axes.tolist(), shrink=0.85, label=f"$\\kappa$ of {vehicle} (aggressiveness)")
    kappas = tradeoff_points(table, vehicle)["kappa"]
    span = f"{kappas.min():g}-{kappas.max():g}" if len(kappas) else "none"
    fig.suptitle(title or f"Aggressiveness against safety: {vehicle}'s kappa {span} (mean over seeds)", fontsize=11)
    draw_kappa_tradeoff(axes, table, vehicle)
    return save_figure(fig, out_png)
