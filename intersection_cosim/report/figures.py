"""Figures of runs and sweeps (matplotlib, Agg backend): one function per figure, each writing a PNG;
the ``draw_*`` functions draw one figure's content into given axes and return what they drew.

Single runs: :func:`trajectory_figure` (positions every 0.5 s over a drawing of the intersection,
coloured by time, like the paper's Figs. 4 and 8) and :func:`velocity_figure` (speed against time
with the conflict-zone entry and exit marked, Figs. 5 and 9). Paper report: :func:`convergence_figure`
(residual per iteration against the tolerance, Fig. 3) and :func:`draw_ecdf` (compute-time
distributions, Fig. 7). Sweeps: :func:`kappa_tradeoff` (one vehicle's travel time against its min
TTC and PET, one point per kappa value), :func:`kappa_heatmap` (a metric over two kappa axes),
:func:`kappa_lines` (a metric against one kappa, one line per controller) and
:func:`compute_time_histogram`.
"""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path
from typing import Mapping

import matplotlib

matplotlib.use("Agg")  # no display; must precede pyplot
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import matplotlib.cm  # noqa: E402
import matplotlib.colors  # noqa: E402
import matplotlib.ticker  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Polygon, Rectangle  # noqa: E402

from intersection_cosim.network.build import NET_FILE  # noqa: E402
from intersection_cosim.network.outline import junction_outlines, read_outline  # noqa: E402
from intersection_cosim.report.net_drawing import draw_outline  # noqa: E402
from intersection_cosim.results.layout import RUN_MARKER  # noqa: E402

DPI = 120
POINT_INTERVAL = 0.5  # [s] between the trajectory figure's points
LANE_WIDTH = 4.0  # [m] of the generated net (network/spec.py); used when a run has no net file
LANES_PER_ROAD = 3
CONFLICT_HALF = 12.0  # [m] the conflict zone is |x|, |y| <= 12
ROAD_COLOUR = "#d9d9d9"
MARKING_COLOUR = "#7f7f7f"
TIME_CMAP = "viridis"  # trajectory points coloured by time
TRAJECTORY_MARKERS = ("o", "^", "D", "v", "P", "X", "<", ">", "h", "*")  # one per vehicle
LINE_STYLES = ("-", "--", "-.", ":")  # velocity lines, one per vehicle (besides its colour)
SHARED_LANE_OFFSET = 1.4  # [m] sideways between vehicles drawn on a common lane
LABELLED_VEHICLES = 12  # [-] up to this many vehicles get a start square with their id and a legend
#                          entry; more (a demand run) would print their labels over each other
SHARED_LANE_MAX = 4  # [-] a larger group of vehicles on common lanes (a demand run) is not spread:
#                      it would be drawn off its road

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


def draw_net_view(ax, net_file: Path, zones, centre: tuple[float, float], half: float) -> None:
    """A net file's lanes and junctions (network.outline) in the square of half side ``half`` [m]
    around ``centre`` [m] (the net's frame), the polygons ``zones`` (the managed junctions, n x 2
    each) outlined as conflict zones."""
    draw_outline(ax, read_outline(net_file), ROAD_COLOUR, MARKING_COLOUR, "white")
    for shape in zones:
        if len(shape):
            ax.add_patch(Polygon(shape, closed=True, fill=False, edgecolor="#c0392b", lw=1.2, ls="--", zorder=2))
    cx, cy = centre
    ax.set_xlim(cx - half, cx + half)
    ax.set_ylim(cy - half, cy + half)


def _run_network(run_dir: Path) -> dict:
    """The ``[network]`` settings a run recorded in its summary.json ({} if none)."""
    summary = Path(run_dir) / RUN_MARKER
    if not summary.is_file():
        return {}
    return (json.loads(summary.read_text()).get("settings") or {}).get("network") or {}


def _every(times: np.ndarray, interval: float) -> np.ndarray:
    """Indices of the first sample in each ``interval`` [s] bin of sorted ``times``."""
    if len(times) == 0:
        return np.zeros(0, int)
    bins = np.floor((times - times[0]) / interval + 1e-6).astype(int)
    return np.flatnonzero(np.r_[True, bins[1:] != bins[:-1]])


def shared_lane_offsets(traj: pd.DataFrame, ids: list[str] | None = None) -> dict[str, float]:
    """[m] sideways drawing offset of each vehicle: vehicles that drive on a common lane (the
    ``lane`` column) are spread SHARED_LANE_OFFSET apart around their path, in ``ids`` order, so
    their points do not hide each other; 0 for a vehicle that shares no lane or whose group has
    more than SHARED_LANE_MAX vehicles."""
    ids = ids or list(dict.fromkeys(traj["vehicle"]))
    lanes = {vid: set(traj.loc[traj["vehicle"] == vid, "lane"].dropna()) for vid in ids}
    group = {vid: {vid} for vid in ids}
    for a, b in itertools.combinations(ids, 2):
        if lanes[a] & lanes[b] and group[a] is not group[b]:
            merged = group[a] | group[b]
            for vid in merged:
                group[vid] = merged
    offsets = {}
    for vid in ids:
        members = [v for v in ids if v in group[vid]]
        spread = len(members) <= SHARED_LANE_MAX
        offsets[vid] = (members.index(vid) - (len(members) - 1) / 2) * SHARED_LANE_OFFSET if spread else 0.0
    return offsets


def _left_normals(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Unit normals to the left of the direction of travel along (x, y); a standing vehicle keeps
    the direction it last moved in (or its first one)."""
    d = np.column_stack([np.gradient(x), np.gradient(y)]) if len(x) > 1 else np.array([[1.0, 0.0]])
    norm = np.linalg.norm(d, axis=1)
    moving = np.flatnonzero(norm > 1e-6)
    if not len(moving):
        return np.tile([0.0, 1.0], (len(x), 1))
    idx = np.maximum.accumulate(np.where(norm > 1e-6, np.arange(len(x)), -1))
    idx[idx < 0] = moving[0]
    d = d[idx] / norm[idx, None]
    return np.column_stack([-d[:, 1], d[:, 0]])


def draw_trajectories(ax, traj: pd.DataFrame, vehicles: pd.DataFrame | None = None,
                      interval: float = POINT_INTERVAL) -> dict[str, pd.DataFrame]:
    """Every vehicle's points every ``interval`` [s], coloured by time (one colour scale, so points
    of one colour are simultaneous), one marker shape per vehicle, a start square labelled with its
    id (up to LABELLED_VEHICLES vehicles); vehicles sharing a lane drawn side by side
    (:func:`shared_lane_offsets`). Returns the drawn
    points per vehicle (time, x, y after the offset)."""
    ids = _vehicle_order(traj, vehicles)
    offsets = shared_lane_offsets(traj, ids)
    norm = matplotlib.colors.Normalize(0.0, max(float(traj["time"].max()) if len(traj) else 1.0, 1e-9))
    cmap = plt.get_cmap(TIME_CMAP)
    markers = {vid: TRAJECTORY_MARKERS[i % len(TRAJECTORY_MARKERS)] for i, vid in enumerate(ids)}
    drawn = {}
    for vid in ids:
        rows = traj[traj["vehicle"] == vid].sort_values("time")
        xy = rows[["x", "y"]].to_numpy(float) + offsets[vid] * _left_normals(rows["x"].to_numpy(float),
                                                                             rows["y"].to_numpy(float))
        ax.plot(xy[:, 0], xy[:, 1], color="#404040", lw=0.7, alpha=0.6, zorder=2)
        keep = _every(rows["time"].to_numpy(), interval)
        points = pd.DataFrame({"time": rows["time"].to_numpy()[keep], "x": xy[keep, 0], "y": xy[keep, 1]})
        ax.scatter(points["x"], points["y"], c=points["time"], cmap=cmap, norm=norm, marker=markers[vid], s=30,
                   edgecolors="black", linewidths=0.4, zorder=3)
        if len(points) and len(ids) <= LABELLED_VEHICLES:
            ax.scatter(points["x"].iloc[:1], points["y"].iloc[:1], s=110, marker="s", facecolor="none",
                       edgecolor="black", lw=1.3, zorder=4)
            ax.annotate(vid, (points["x"].iloc[0], points["y"].iloc[0]), xytext=(6, 6), textcoords="offset points",
                        fontsize=8, fontweight="bold", zorder=5,
                        bbox=dict(boxstyle="round,pad=0.15", facecolor="white", edgecolor="none", alpha=0.8))
        drawn[vid] = points
    if len(ids) <= LABELLED_VEHICLES:
        handles = [Line2D([], [], ls="", marker=markers[vid], markerfacecolor="#bfbfbf", markeredgecolor="black",
                          markersize=7, label=_label(vid, vehicles)) for vid in ids]
        handles += [Line2D([], [], ls="", marker="s", markerfacecolor="none", markeredgecolor="black", markersize=10,
                           label="start"),
                    Rectangle((0, 0), 1, 1, fill=False, edgecolor="#c0392b", ls="--", label="conflict zone")]
        ax.legend(handles=handles, loc="upper right", fontsize=8, framealpha=0.9)
    ax.figure.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.8, pad=0.02,
                       label="time [s]")
    return drawn


def trajectory_figure(run_dir: Path, out_png: Path, title: str | None = None) -> Path:
    """Positions of every vehicle every 0.5 s over the intersection (paper's Figs. 4 and 8).

    Reads ``trajectories.csv`` (front bumper, paper frame), ``vehicles.csv`` (kappa for the legend)
    and draws the roads from the run's ``intersection.net.xml``.
    """
    run_dir = Path(run_dir)
    traj, vehicles = _read_run(run_dir)
    network = _run_network(run_dir)
    net_file = run_dir / NET_FILE
    on_file = bool(network.get("file")) and bool(network.get("junctions")) and net_file.is_file()
    zones = junction_outlines(net_file, network["junctions"]) if on_file else {}
    sites = np.asarray([c for c, _ in zones.values()]) if zones else np.zeros((1, 2))  # [m] managed junctions
    centre = tuple((sites.min(axis=0) + sites.max(axis=0)) / 2)  # [m] the middle of the managed junctions
    span = float((sites.max(axis=0) - sites.min(axis=0)).max()) / 2  # [m] 0 for one junction
    xy = traj[["x", "y"]].to_numpy(float) - np.asarray(centre)
    reach = float(np.nanmax(np.abs(xy))) - span if len(traj) else 30.0  # [m] beyond the junctions
    if on_file:  # the vehicles' whole routes are recorded: show the junctions' control range
        reach = min(reach, float(network.get("control_range", 80.0)))
    extent = float(np.clip(reach + 5.0, 30.0, 80.0))
    fig, ax = plt.subplots(figsize=(7.4, 6.4), layout="constrained")
    if on_file:
        draw_net_view(ax, net_file, [shape for _, shape in zones.values()], centre, span + extent)
    else:
        draw_intersection(ax, net_file, extent)
        ax.set_xlim(-extent, extent)
        ax.set_ylim(-extent, extent)
    draw_trajectories(ax, traj, vehicles)
    ax.set_aspect("equal")
    frame = "the net's frame" if on_file else "paper frame"
    ax.set_xlabel(f"x [m] ({frame})")
    ax.set_ylabel("y [m]")
    shared = " (vehicles sharing a lane drawn side by side)" if len(set(shared_lane_offsets(traj).values())) > 1 \
        else ""
    ax.set_title(f"{title or f'Trajectories ({run_dir.name})'}\npoints every {POINT_INTERVAL:g} s, colour = time"
                 f"{shared}", fontsize=10)
    return _save(fig, out_png)


def zone_events(traj: pd.DataFrame) -> pd.DataFrame:
    """Per vehicle, when it entered the conflict zone (its first ``passing`` row) and left it (the
    first ``outside`` row after that), with its speeds then; NaN for what did not happen."""
    rows = []
    for vid, g in traj.sort_values("time").groupby("vehicle", sort=False):
        role = g["role"].to_numpy()
        inside = np.flatnonzero(role == "passing")
        entry = inside[0] if len(inside) else None
        after = np.flatnonzero(role[entry:] == "outside") + entry if entry is not None else np.zeros(0, int)
        leave = after[0] if len(after) else None
        t, v = g["time"].to_numpy(float), g["speed"].to_numpy(float)
        rows.append({"vehicle": vid,
                     "entry_time": t[entry] if entry is not None else np.nan,
                     "entry_speed": v[entry] if entry is not None else np.nan,
                     "exit_time": t[leave] if leave is not None else np.nan,
                     "exit_speed": v[leave] if leave is not None else np.nan})
    return pd.DataFrame(rows, columns=["vehicle", "entry_time", "entry_speed", "exit_time", "exit_speed"])


def draw_velocity(ax, traj: pd.DataFrame, vehicles: pd.DataFrame | None = None) -> pd.DataFrame:
    """Speed against time, one colour and line style per vehicle, the stretch inside the conflict
    zone drawn wide, entry (triangle) and exit (square) marked; returns :func:`zone_events`."""
    ids = _vehicle_order(traj, vehicles)
    colours = _vehicle_colours(ids)
    events = zone_events(traj).set_index("vehicle")
    for i, vid in enumerate(ids):
        rows = traj[traj["vehicle"] == vid].sort_values("time")
        ax.plot(rows["time"], rows["speed"], color=colours[vid], lw=1.6, ls=LINE_STYLES[i % len(LINE_STYLES)],
                label=_label(vid, vehicles) if len(ids) <= LABELLED_VEHICLES else None)
        ev = events.loc[vid]
        if np.isfinite(ev["entry_time"]):
            end = ev["exit_time"] if np.isfinite(ev["exit_time"]) else rows["time"].max()
            inside = rows[(rows["time"] >= ev["entry_time"]) & (rows["time"] <= end)]
            ax.plot(inside["time"], inside["speed"], color=colours[vid], lw=6, alpha=0.25, solid_capstyle="butt")
            ax.plot([ev["entry_time"]], [ev["entry_speed"]], ls="", marker=">", ms=8, color=colours[vid],
                    markeredgecolor="black", gid=f"entry:{vid}", zorder=4)
        if np.isfinite(ev["exit_time"]):
            ax.plot([ev["exit_time"]], [ev["exit_speed"]], ls="", marker="s", ms=7, color=colours[vid],
                    markeredgecolor="black", gid=f"exit:{vid}", zorder=4)
    handles, _ = ax.get_legend_handles_labels()
    handles += [Line2D([], [], ls="", marker=">", ms=8, color="#bfbfbf", markeredgecolor="black",
                       label="enters the conflict zone"),
                Line2D([], [], ls="", marker="s", ms=7, color="#bfbfbf", markeredgecolor="black",
                       label="leaves the conflict zone"),
                Line2D([], [], color="#bfbfbf", lw=6, alpha=0.6, label="inside the conflict zone")]
    if len(ids) <= LABELLED_VEHICLES:
        ax.legend(handles=handles, fontsize=8, loc="best", framealpha=0.9)
    return events.reset_index()


def velocity_figure(run_dir: Path, out_png: Path, title: str | None = None) -> Path:
    """Speed against time of every vehicle (paper's Figs. 5 and 9), from ``trajectories.csv``,
    with each vehicle's entry into and exit from the conflict zone marked."""
    run_dir = Path(run_dir)
    traj, vehicles = _read_run(run_dir)
    fig, ax = plt.subplots(figsize=(7.4, 4.4), layout="constrained")
    draw_velocity(ax, traj, vehicles)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("speed [m/s]")
    ax.set_ylim(bottom=0)
    ax.set_xlim(left=0)
    ax.grid(alpha=0.3)
    ax.set_title(title or f"Velocity ({run_dir.name})")
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


RESIDUAL_LABEL = "max change of any player's plan\nbetween iterations [m/s$^2$]"
RESIDUAL_FLOOR = 1e-4  # [m/s^2] bottom of the convergence axis; smaller residuals (and 0) are drawn on it


def draw_convergence(ax, conv: pd.DataFrame | None, tol: float, guard: float | None = None,
                     rtol: float | None = None) -> dict[str, pd.DataFrame]:
    """The residual of every pair's longest solve against the iteration (log y from RESIDUAL_FLOOR,
    integer x), with the tolerance ``tol`` [m/s^2] as a horizontal line and, when given, the guard
    [m/s^2] below which a relative cost gain under ``rtol`` also ends a game (games/settings.py
    nash_cost_guard, nash_cost_rtol); returns the drawn points per pair (iteration, residual as drawn)."""
    drawn: dict[str, pd.DataFrame] = {}
    top, last = tol, 1
    if conv is not None and len(conv):
        conv = conv.assign(pair=conv["vehicle_a"].astype(str) + "-" + conv["vehicle_b"].astype(str))
        for pair, g in conv.groupby("pair"):
            solves = g.groupby("time")
            t = solves.size().idxmax()  # the solve with the most iterations
            s = solves.get_group(t).sort_values("iteration")
            y = s["residual"].to_numpy(float).clip(min=RESIDUAL_FLOOR)
            ax.plot(s["iteration"], y, "o-", ms=6, label=f"{pair}, solve at t = {t:.2f} s ({s['status'].iloc[-1]}, "
                    f"{len(s)} iterations)")
            drawn[pair] = pd.DataFrame({"iteration": s["iteration"].to_numpy(int), "residual": y})
            top, last = max(top, float(y.max())), max(last, int(s["iteration"].max()))
    else:
        ax.text(0.5, 0.5, "no games played", ha="center", va="center", transform=ax.transAxes)
    ax.axhline(tol, color="#c0392b", ls="--", lw=1.3, gid="tolerance", label=f"tolerance {tol:g} m/s$^2$: converged below")
    if guard is not None:
        top = max(top, guard)
        gain = f"a cost gain < {rtol:.1%} " if rtol is not None else "a small cost gain "
        ax.axhline(guard, color="#595959", ls=":", lw=1.3, gid="guard",
                   label=f"{guard:g} m/s$^2$: below it {gain}also ends the game")
    ax.set_yscale("log")
    ax.set_ylim(RESIDUAL_FLOOR / 1.5, top * 2.0)
    ax.set_xlim(0.5, last + 0.5)
    ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    floor = any((d["residual"] <= RESIDUAL_FLOOR).any() for d in drawn.values())
    ax.set_xlabel("iteration" + (f"   (residuals below {RESIDUAL_FLOOR:g}, or 0, drawn at {RESIDUAL_FLOOR:g})"
                                 if floor else ""))
    ax.set_ylabel(RESIDUAL_LABEL)
    ax.grid(alpha=0.3, which="major")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.16), frameon=False)  # below: no point hidden
    return drawn


def convergence_figure(panels: list[tuple[str, pd.DataFrame | None, dict]], out_png: Path,
                       title: str | None = None) -> Path:
    """One :func:`draw_convergence` panel per (title, convergence.csv table, its keyword arguments:
    tol and optionally guard, rtol)."""
    fig, axes = plt.subplots(1, len(panels), figsize=(5.8 * len(panels), 5.4), squeeze=False, layout="constrained")
    for ax, (name, conv, limits) in zip(axes[0], panels, strict=True):
        draw_convergence(ax, conv, **limits)
        ax.set_title(name, fontsize=10)
    fig.suptitle(title or "Convergence of the pair games (the longest solve of each pair)", fontsize=11)
    return _save(fig, out_png)


def draw_ecdf(ax, samples: Mapping[str, np.ndarray], styles: Mapping[str, dict] | None = None,
              extra: Mapping[str, str] | None = None) -> dict[str, np.ndarray]:
    """Empirical CDFs of compute times [ms] (log x): the share of control steps that took at most
    x; the legend gives each sample's median and mean (and ``extra[label]``). Returns the sorted
    values drawn per label."""
    drawn = {}
    for label, values in samples.items():
        v = np.sort(np.asarray(values, float)[np.isfinite(values)])
        if not len(v):
            continue
        shown = np.clip(v, 1e-3, None)  # [ms] a log axis has no 0
        y = np.arange(1, len(v) + 1) / len(v)
        more = f", {extra[label]}" if extra and label in extra else ""
        ax.step(np.r_[shown[0], shown], np.r_[0.0, y], where="post", lw=1.6,
                label=f"{label}: median {np.median(v):.2f} ms, mean {v.mean():.2f} ms{more}",
                **(styles or {}).get(label, {}))
        drawn[label] = v
    ax.set_xscale("log")
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("compute time per control step [ms]")
    ax.set_ylabel("share of control steps\ntaking at most this long [-]")
    ax.grid(alpha=0.3, which="both")
    if drawn:
        ax.legend(fontsize=8, loc="lower right")
    return drawn


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
    return _save(fig, out_png)


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
    return _save(fig, out_png)


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
    return _save(fig, out_png)
