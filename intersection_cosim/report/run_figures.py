"""Figures of one run (matplotlib, Agg backend), each writing a PNG; the ``draw_*`` functions draw
one figure's content into given axes and return what they drew.

:func:`trajectory_figure` (positions every 0.5 s over a drawing of the intersection, coloured by
time, like the paper's Figs. 4 and 8) and :func:`velocity_figure` (speed against time with the
conflict-zone entry and exit marked, Figs. 5 and 9).
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no display; must precede pyplot
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.cm  # noqa: E402
import matplotlib.colors  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Polygon, Rectangle  # noqa: E402

from intersection_cosim.network.build import NET_FILE  # noqa: E402
from intersection_cosim.network.outline import junction_outlines, read_outline  # noqa: E402
from intersection_cosim.report.figure_style import LINE_STYLES, TRAJECTORY_MARKERS, save_figure  # noqa: E402
from intersection_cosim.report.net_drawing import draw_outline  # noqa: E402
from intersection_cosim.results.layout import RUN_MARKER, trajectories_file  # noqa: E402

POINT_INTERVAL = 0.5  # [s] between the trajectory figure's points
LANE_WIDTH = 4.0  # [m] of the generated net (network/spec.py); used when a run has no net file
LANES_PER_ROAD = 3
CONFLICT_HALF = 12.0  # [m] the conflict zone is |x|, |y| <= 12
ROAD_COLOUR = "#d9d9d9"
MARKING_COLOUR = "#7f7f7f"
TIME_CMAP = "viridis"  # trajectory points coloured by time
SHARED_LANE_OFFSET = 1.4  # [m] sideways between vehicles drawn on a common lane
LABELLED_VEHICLES = 12  # [-] up to this many vehicles get a start square with their id and a legend
#                          entry; more (a demand run) would print their labels over each other
SHARED_LANE_MAX = 4  # [-] a larger group of vehicles on common lanes (a demand run) is not spread:
#                      it would be drawn off its road



def _vehicle_colours(ids) -> dict[str, tuple]:
    cmap = plt.get_cmap("tab10" if len(ids) <= 10 else "tab20")
    return {vid: cmap(i % cmap.N) for i, vid in enumerate(ids)}


def _read_run(run_dir: Path) -> tuple[pd.DataFrame, pd.DataFrame | None]:
    traj = pd.read_csv(trajectories_file(run_dir), dtype={"vehicle": str})
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
    return save_figure(fig, out_png)


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
    return save_figure(fig, out_png)
