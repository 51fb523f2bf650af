"""Figures of runs and sweeps (matplotlib, Agg backend): one function per figure, each writing a PNG.

Single runs: :func:`trajectory_figure` (positions every 0.5 s over a drawing of the intersection,
like the paper's Figs. 4 and 8) and :func:`velocity_figure` (speed against time, Figs. 5 and 9).
Sweeps: :func:`kappa_heatmap` (a metric over two kappa axes), :func:`kappa_lines` (a metric against
one kappa, one line per controller) and :func:`compute_time_histogram`.
"""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Mapping

import matplotlib

matplotlib.use("Agg")  # no display; must precede pyplot
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.patches import Polygon, Rectangle  # noqa: E402

DPI = 120
POINT_INTERVAL = 0.5  # [s] between the trajectory figure's points
LANE_WIDTH = 4.0  # [m] of the generated net (network/spec.py); used when a run has no net file
LANES_PER_ROAD = 3
CONFLICT_HALF = 12.0  # [m] the conflict zone is |x|, |y| <= 12
ROAD_COLOUR = "#d9d9d9"
MARKING_COLOUR = "#7f7f7f"

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


def _save(fig, out_png: Path) -> Path:
    out_png = Path(out_png)
    out_png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png, dpi=DPI)
    plt.close(fig)
    return out_png


def _vehicle_colours(ids) -> dict[str, tuple]:
    cmap = plt.get_cmap("tab10" if len(ids) <= 10 else "tab20")
    return {vid: cmap(i % cmap.N) for i, vid in enumerate(ids)}


def _read_run(run_dir: Path) -> tuple[pd.DataFrame, pd.DataFrame | None]:
    traj = pd.read_csv(Path(run_dir) / "trajectories.csv", dtype={"vehicle": str})
    veh_file = Path(run_dir) / "vehicles.csv"
    vehicles = pd.read_csv(veh_file, dtype={"vehicle": str}) if veh_file.is_file() else None
    return traj, vehicles


def _vehicle_order(traj: pd.DataFrame, vehicles: pd.DataFrame | None) -> list[str]:
    if vehicles is not None:
        present = set(traj["vehicle"])
        return [v for v in vehicles["vehicle"] if v in present]
    return list(dict.fromkeys(traj["vehicle"]))


def _label(vid: str, vehicles: pd.DataFrame | None) -> str:
    if vehicles is None:
        return vid
    row = vehicles.loc[vehicles["vehicle"] == vid]
    if row.empty or pd.isna(row["kappa"].iloc[0]):
        return vid
    return f"{vid} ($\\kappa$ = {row['kappa'].iloc[0]:.2f})"


def _lane_polygon(shape: np.ndarray, width: float) -> np.ndarray:
    """The outline of a lane of ``width`` around its centre polyline ``shape`` (n x 2)."""
    d = np.gradient(shape, axis=0)
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    normal = np.column_stack([-d[:, 1], d[:, 0]]) * (width / 2)
    return np.vstack([shape + normal, (shape - normal)[::-1]])


def draw_intersection(ax, net_file: Path | None = None, extent: float = 50.0) -> None:
    """Roads (from the net's lane shapes when ``net_file`` exists), lane markings, lane centre lines
    at +-2/+-6/+-10 m and the 24 m square conflict zone, in the paper frame."""
    drawn = False
    if net_file is not None and Path(net_file).is_file():
        try:
            import sumolib

            net = sumolib.net.readNet(str(net_file), withInternal=False)
            for edge in net.getEdges():
                for lane in edge.getLanes():
                    shape = np.asarray([p[:2] for p in lane.getShape()], float)
                    ax.add_patch(Polygon(_lane_polygon(shape, lane.getWidth()), closed=True, facecolor=ROAD_COLOUR,
                                         edgecolor="none", zorder=0))
            for node in net.getNodes():
                shape = node.getShape()
                if len(shape) >= 3:
                    ax.add_patch(Polygon(np.asarray([p[:2] for p in shape]), closed=True, facecolor=ROAD_COLOUR,
                                         edgecolor="none", zorder=0))
            drawn = True
        except Exception:  # noqa: BLE001 - an unreadable net falls back to the schematic
            drawn = False
    half = LANE_WIDTH * LANES_PER_ROAD
    if not drawn:
        ax.add_patch(Rectangle((-extent, -half), 2 * extent, 2 * half, facecolor=ROAD_COLOUR, edgecolor="none",
                               zorder=0))
        ax.add_patch(Rectangle((-half, -extent), 2 * half, 2 * extent, facecolor=ROAD_COLOUR, edgecolor="none",
                               zorder=0))
    # Markings on the arms: lane boundaries dashed, the axis solid, lane centres dotted.
    for arm_start, arm_end in ((CONFLICT_HALF, extent), (-extent, -CONFLICT_HALF)):
        for k in range(-LANES_PER_ROAD, LANES_PER_ROAD + 1):
            off = k * LANE_WIDTH
            style = dict(color=MARKING_COLOUR, lw=0.9, zorder=1)
            if k == 0:
                style.update(color="#595959", lw=1.4)
            elif abs(k) < LANES_PER_ROAD:
                style.update(ls=(0, (4, 4)))
            ax.plot([arm_start, arm_end], [off, off], **style)
            ax.plot([off, off], [arm_start, arm_end], **style)
        for k in range(LANES_PER_ROAD):
            for sign in (-1, 1):
                c = sign * LANE_WIDTH * (k + 0.5)  # +-2, +-6, +-10
                ax.plot([arm_start, arm_end], [c, c], color="white", lw=0.6, ls=":", zorder=1)
                ax.plot([c, c], [arm_start, arm_end], color="white", lw=0.6, ls=":", zorder=1)
    ax.add_patch(Rectangle((-CONFLICT_HALF, -CONFLICT_HALF), 2 * CONFLICT_HALF, 2 * CONFLICT_HALF, fill=False,
                           edgecolor="#c0392b", lw=1.2, ls="--", zorder=2, label="conflict zone"))


def _every(times: np.ndarray, interval: float) -> np.ndarray:
    """Indices of the first sample in each ``interval`` [s] bin of sorted ``times``."""
    if len(times) == 0:
        return np.zeros(0, int)
    bins = np.floor((times - times[0]) / interval + 1e-6).astype(int)
    return np.flatnonzero(np.r_[True, bins[1:] != bins[:-1]])


def trajectory_figure(run_dir: Path, out_png: Path, title: str | None = None) -> Path:
    """Positions of every vehicle every 0.5 s over the intersection (paper's Figs. 4 and 8).

    Reads ``trajectories.csv`` (front bumper, paper frame), ``vehicles.csv`` (kappa for the legend)
    and draws the roads from the run's ``intersection.net.xml``.
    """
    run_dir = Path(run_dir)
    traj, vehicles = _read_run(run_dir)
    ids = _vehicle_order(traj, vehicles)
    colours = _vehicle_colours(ids)
    reach = float(np.nanmax(np.abs(traj[["x", "y"]].to_numpy()))) if len(traj) else 30.0
    extent = float(np.clip(reach + 5.0, 30.0, 80.0))
    fig, ax = plt.subplots(figsize=(6.4, 6.4), layout="constrained")
    draw_intersection(ax, run_dir / "intersection.net.xml", extent)
    for vid in ids:
        rows = traj[traj["vehicle"] == vid].sort_values("time")
        keep = rows.iloc[_every(rows["time"].to_numpy(), POINT_INTERVAL)]
        ax.scatter(keep["x"], keep["y"], s=14, color=colours[vid], zorder=3,
                   label=_label(vid, vehicles) if len(ids) <= 12 else None)
        ax.scatter(keep["x"].iloc[:1], keep["y"].iloc[:1], s=60, marker="s", facecolor="none",
                   edgecolor=colours[vid], zorder=3)
    ax.set_xlim(-extent, extent)
    ax.set_ylim(-extent, extent)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title or f"Trajectories ({run_dir.name}), points every {POINT_INTERVAL:g} s")
    if len(ids) <= 12:
        ax.legend(loc="upper right", fontsize=8, framealpha=0.9)
    return _save(fig, out_png)


def velocity_figure(run_dir: Path, out_png: Path, title: str | None = None) -> Path:
    """Speed against time of every vehicle (paper's Figs. 5 and 9), from ``trajectories.csv``."""
    run_dir = Path(run_dir)
    traj, vehicles = _read_run(run_dir)
    ids = _vehicle_order(traj, vehicles)
    colours = _vehicle_colours(ids)
    fig, ax = plt.subplots(figsize=(7.0, 4.0), layout="constrained")
    for vid in ids:
        rows = traj[traj["vehicle"] == vid].sort_values("time")
        ax.plot(rows["time"], rows["speed"], color=colours[vid], lw=1.6,
                label=_label(vid, vehicles) if len(ids) <= 12 else None)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("speed [m/s]")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.set_title(title or f"Velocity ({run_dir.name})")
    if len(ids) <= 12:
        ax.legend(fontsize=8)
    return _save(fig, out_png)


def compute_time_histogram(samples: Mapping[str, np.ndarray], out_png: Path, title: str | None = None,
                           budget_ms: float | None = None) -> Path:
    """Histogram of per-step controller compute times [ms], one per label (e.g. per controller),
    on log-spaced bins; the deadline ``budget_ms`` as a vertical line when given."""
    fig, ax = plt.subplots(figsize=(7.0, 4.0), layout="constrained")
    values = {k: np.asarray(v, float)[np.isfinite(v)] for k, v in samples.items()}
    allv = np.concatenate([v for v in values.values() if len(v)] or [np.zeros(0)])
    pos = allv[allv > 0]
    if len(pos):
        lo, hi = pos.min(), max(pos.max(), budget_ms or 0.0)
        bins = np.geomspace(lo / 1.5, hi * 1.5, 50)
        for label, v in values.items():
            ax.hist(np.clip(v, bins[0], None), bins=bins, histtype="step", lw=1.6, label=f"{label} (n = {len(v)})")
        ax.set_xscale("log")
        if budget_ms:
            ax.axvline(budget_ms, color="#c0392b", ls="--", lw=1.2, label=f"budget {budget_ms:g} ms")
        ax.legend(fontsize=8)
    else:
        ax.text(0.5, 0.5, "no compute-time samples", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel("compute time per control step [ms]")
    ax.set_ylabel("control steps")
    ax.grid(alpha=0.3)
    ax.set_title(title or "Controller compute time per step")
    return _save(fig, out_png)


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
        ax.set_xlabel(x.replace("kappa_", "$\\kappa$ ") if x.startswith("kappa_") else x)
        ax.set_ylabel(y.replace("kappa_", "$\\kappa$ ") if y.startswith("kappa_") else y)
        ax.set_title(c)
        if g.size <= 100:
            for (i, j) in itertools.product(range(g.shape[0]), range(g.shape[1])):
                if np.isfinite(g[i, j]):
                    ax.text(j, i, f"{g[i, j]:.3g}", ha="center", va="center", fontsize=7,
                            color="white" if g[i, j] < (vmin + vmax) / 2 else "black")
    fig.colorbar(im, ax=axes[0].tolist(), label=metric_label(metric))
    fig.suptitle(title or f"{metric_label(metric)} (mean over seeds and other axes)")
    return _save(fig, out_png)


def kappa_lines(table: pd.DataFrame, metric: str, axis: str, out_png: Path, title: str | None = None) -> Path:
    """``metric`` against the kappa axis ``axis``, one line per controller: the mean over seeds and
    the other axes, with their min-max range shaded."""
    ok = _ok(table)
    fig, ax = plt.subplots(figsize=(6.4, 4.0), layout="constrained")
    for c in dict.fromkeys(ok["controller"]):
        g = ok[ok["controller"] == c].groupby(axis)[metric].agg(["mean", "min", "max"]).sort_index()
        line, = ax.plot(g.index, g["mean"], marker="o", lw=1.6, label=c)
        if (g["max"] > g["min"]).any():
            ax.fill_between(g.index, g["min"], g["max"], color=line.get_color(), alpha=0.15, lw=0)
    ax.set_xlabel(axis.replace("kappa_", "$\\kappa$ ") if axis.startswith("kappa_") else axis)
    ax.set_ylabel(metric_label(metric))
    ax.grid(alpha=0.3)
    ax.legend(title="controller", fontsize=8)
    ax.set_title(title or f"{metric_label(metric)} against {axis}")
    return _save(fig, out_png)


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
    return _save(fig, out_png)
