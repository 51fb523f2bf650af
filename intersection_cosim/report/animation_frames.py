"""One frame of a run's animation drawn with matplotlib (Agg): net, vehicles, games, time, kappa scale.

:class:`FrameDrawer` draws the static parts (lanes, junction, colour bar, legend) once and, per
frame, only the vehicles, game lines, labels and time stamp; :meth:`FrameDrawer.draw` returns the
frame as an RGB array. Coordinates are the paper frame [m] of the trajectories and the net.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import ListedColormap, Normalize
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, Polygon

from intersection_cosim.colors import GAME, KAPPA_RANGE, UNCONTROLLED, kappa_color
from intersection_cosim.report.net_drawing import draw_outline

DPI = 100  # [px per inch] of the frames
ROAD = "#4d4d4d"  # asphalt
MARKING = "#f2f2f2"  # lane boundaries
PATH_LINE = "#9a9a9a"  # the junction's internal lanes (the movements' paths)
PERSON = "#d62728"  # a person at a crossing
PERSON_SIZE = 28.0  # [pt^2] its marker
TIME_DECIMALS = 4  # trajectories.csv and games.csv write times to 4 decimals


def _rgb(colour: tuple[int, int, int]) -> tuple[float, float, float]:
    return tuple(c / 255 for c in colour)


def kappa_colormap(n: int = 256) -> ListedColormap:
    """The kappa scale of :func:`~intersection_cosim.colors.kappa_color` as a matplotlib colormap."""
    lo, hi = KAPPA_RANGE
    return ListedColormap([_rgb(kappa_color(lo + (hi - lo) * i / (n - 1))) for i in range(n)], name="kappa")


def body_corners(x: float, y: float, heading: float, length: float, width: float) -> np.ndarray:
    """[m] the 4 corners of a vehicle whose front bumper centre is at (x, y), heading [rad] from east."""
    c, s = math.cos(heading), math.sin(heading)
    fwd, left = np.array([c, s]), np.array([-s, c])
    front = np.array([x, y])
    rear = front - length * fwd
    half = width / 2 * left
    return np.array([front + half, front - half, rear - half, rear + half])


class FrameDrawer:
    """Draws the frames of one run (a :class:`~intersection_cosim.report.animation.RunRecord`)."""

    def __init__(self, run, settings):
        self.run = run
        w, h = settings.size
        self.fig = Figure(figsize=(w / DPI, h / DPI), dpi=DPI, facecolor="white")
        self.canvas = FigureCanvasAgg(self.fig)
        self.ax = self.fig.add_axes((0.01, 0.01, 0.80, 0.91))
        self._by_time = {round(float(t), TIME_DECIMALS): g for t, g in run.traj.groupby("time")}
        self._games = {round(float(t), TIME_DECIMALS): list(zip(g["vehicle_a"], g["vehicle_b"]))
                       for t, g in run.games.groupby("time")}
        self._people = ({} if run.walkers is None else  # [m] where the people are, per time
                        {round(float(t), TIME_DECIMALS): g[["x", "y"]].to_numpy(float) for t, g in run.walkers.groupby("time")})
        self._dynamic: list = []
        self._static(self._half_view(settings))

    def _half_view(self, settings) -> float:
        """[m] half the side of the square view around the junction centre."""
        xy = self.run.traj[["x", "y"]].to_numpy(float) - np.asarray(self.run.centre)
        reach = float(np.nanmax(np.abs(xy))) if len(self.run.traj) else 0.0
        limit = settings.max_half_view if self.run.reach is None else self.run.reach  # [m]
        return max(20.0, min(reach + settings.margin, limit))

    def _static(self, half: float) -> None:
        ax, outline = self.ax, self.run.outline
        cx, cy = self.run.centre
        ax.set_xlim(cx - half, cx + half)
        ax.set_ylim(cy - half, cy + half)
        ax.set_aspect("equal")
        ax.set_facecolor("#e9efe4")
        ax.set_xticks([])
        ax.set_yticks([])
        draw_outline(ax, outline, ROAD, MARKING, PATH_LINE, path_width=0.5)
        frame = "paper frame" if self.run.centre == (0.0, 0.0) else "the net's frame"
        ax.text(0.01, 0.01, f"x, y: {frame} [m]", transform=ax.transAxes, fontsize=7, color="#555555")
        self.fig.suptitle(self.run.title, x=0.41, y=0.985, fontsize=11)
        cax = self.fig.add_axes((0.86, 0.36, 0.035, 0.50))
        bar = self.fig.colorbar(_scalar_mappable(), cax=cax)
        bar.set_label("aggressiveness $\\kappa$ (commanded)", fontsize=9)
        handles = [Patch(facecolor=_rgb(UNCONTROLLED), edgecolor="black", label="SUMO drives"),
                   Line2D([], [], color=_rgb(GAME), lw=2.5, label="game this step")]
        if self._people:
            handles.append(Line2D([], [], color="none", marker="o", markerfacecolor=PERSON, markeredgecolor="white",
                                  markersize=6, label="person at a crossing"))
        self.fig.legend(handles=handles, loc="lower right", bbox_to_anchor=(0.995, 0.12), fontsize=8, frameon=False)
        self.time_text = ax.text(0.02, 0.98, "", transform=ax.transAxes, fontsize=13, va="top", weight="bold",
                                 bbox=dict(facecolor="white", alpha=0.85, edgecolor="none"), zorder=10)

    def draw(self, t: float) -> np.ndarray:
        """The frame at trajectory time ``t`` [s] as an (height, width, 3) uint8 RGB array."""
        for artist in self._dynamic:
            artist.remove()
        self._dynamic = []
        key = round(float(t), TIME_DECIMALS)
        rows = self._by_time.get(key)
        centres: dict[str, np.ndarray] = {}
        if rows is not None:
            for r in rows.itertuples(index=False):
                centres[r.vehicle] = self._vehicle(r)
        for a, b in self._games.get(key, []):
            if a in centres and b in centres:
                (line,) = self.ax.plot(*zip(centres[a], centres[b]), color=_rgb(GAME), lw=2.5, zorder=4,
                                       solid_capstyle="round")
                self._dynamic.append(line)
        people = self._people.get(key)
        if people is not None and len(people):
            self._dynamic.append(self.ax.scatter(people[:, 0], people[:, 1], s=PERSON_SIZE, c=PERSON,
                                                 edgecolors="white", linewidths=0.6, zorder=7))
        self.time_text.set_text(f"t = {t:6.2f} s")
        self.canvas.draw()
        return np.asarray(self.canvas.buffer_rgba())[..., :3].copy()

    def _vehicle(self, r) -> np.ndarray:
        """Draw one vehicle's body and label; return its centre [m]."""
        run = self.run
        commanded = not math.isnan(float(getattr(r, "accel_cmd", 0.0)))  # NaN: SUMO drives it this step
        kappa = run.kappa.get(r.vehicle, math.nan)
        colour = kappa_color(kappa) if commanded and not math.isnan(kappa) else UNCONTROLLED
        corners = body_corners(r.x, r.y, r.heading, run.length, run.width)
        body = Polygon(corners, closed=True, facecolor=_rgb(colour), edgecolor="black", lw=0.7, zorder=5)
        self.ax.add_patch(body)
        centre = corners.mean(axis=0)
        text = f"{r.vehicle} $\\kappa$={kappa:.2f}\n{r.speed:.1f} m/s"
        label = self.ax.text(centre[0], centre[1] + run.length * 0.55, text, fontsize=7, ha="center", va="bottom",
                             zorder=6, clip_on=True,
                             bbox=dict(facecolor="white", alpha=0.75, edgecolor="none", pad=0.8))
        self._dynamic += [body, label]
        return centre


def _scalar_mappable():
    from matplotlib.cm import ScalarMappable

    return ScalarMappable(norm=Normalize(*KAPPA_RANGE), cmap=kappa_colormap())
