"""Paths through the intersection and the conflict points between them, read from the SUMO net.

A *path* is one movement from one approach lane to one exit lane: approach lane -> the
junction-internal lane(s) SUMO built for that connection -> exit lane. Its centre line is
resampled at a fixed arc-length step so that heading, curvature and the implied front-wheel steer
(paper Eq. 1-4: delta_f = atan(l * curvature)) are plain numpy arrays.

Everything here is computed once per net (``load_paths``) and is pure data afterwards. It reads the
net with sumolib; it never imports libsumo.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path as FsPath

import numpy as np
import sumolib
from scipy.ndimage import gaussian_filter1d
from sumolib import geomhelper

from intersection_cosim.network.path_id import PathId
from intersection_cosim.network.spec import ARMS, LANE_INDEX, LANE_NAME, LANE_USE, exit_arm

RESAMPLE_STEP = 0.25  # [m] arc-length spacing of the resampled centre line
CURVATURE_SMOOTHING = 1.0  # [m] Gaussian width applied to the heading before differentiating


@dataclass(frozen=True)
class MovementPath:
    """One approach-lane -> exit-lane path. Lengths in metres, angles in radians."""

    id: str  # str(PathId), e.g. "south_inner_left_middle" (see network/path_id.py)
    approach: str
    lane: str
    movement: str
    exit_arm: str
    exit_lane: str
    lanes: tuple[str, ...]  # SUMO lane ids in driving order (approach..., internal..., exit)
    lane_starts: tuple[float, ...]  # [m] arc length at which each lane begins
    s_stop: float  # [m] arc length of the stop line (end of the approach lane, start of lanes[stop_index])
    s_exit: float  # [m] arc length where the path leaves the junction (start of the exit lane)
    length: float  # [m] total arc length
    s: np.ndarray = field(repr=False)  # [m] resampled arc lengths, shape (n,)
    xy: np.ndarray = field(repr=False)  # [m] centre-line points at s, shape (n, 2)
    heading: np.ndarray = field(repr=False)  # [rad] heading at s, counter-clockwise from east
    curvature: np.ndarray = field(repr=False)  # [1/m] signed curvature at s (left turn > 0)
    stop_index: int = 1  # index in ``lanes`` of the first junction-internal lane (lanes before it: the approach)
    junction: str = ""  # id of the managed junction the path crosses ("" for the generated net)
    speed_limits: tuple[float, ...] = ()  # [m/s] SUMO's speed limit of each of ``lanes`` (a turn's are lower)

    @property
    def approach_lane(self) -> str:
        """The lane that ends at the stop line."""
        return self.lanes[self.stop_index - 1]

    @property
    def junction_lanes(self) -> tuple[str, ...]:
        """The junction-internal lanes, in driving order."""
        return self.lanes[self.stop_index:-1]

    @property
    def s_wait(self) -> float:
        """[m] arc length of SUMO's waiting position inside the junction (an internal junction:
        netconvert splits the internal lane there, e.g. where a left turn waits for the opposing
        stream), the first one if there are several; ``inf`` for a path with none."""
        if len(self.junction_lanes) < 2:
            return float("inf")
        return float(self.lane_starts[self.stop_index + 1])

    @functools.cached_property
    def lane_limits(self) -> tuple[tuple[float, float, float], ...]:
        """(start [m], end [m], speed limit [m/s]) of each of ``lanes`` along the path (built on
        first use: the safety filter and the relations read it for every vehicle every step)."""
        ends = self.lane_starts[1:] + (self.length,)
        return tuple(zip(self.lane_starts, ends, self.speed_limits))

    def speed_limit_ahead(self, s: float, v_desired: float, decel: float) -> float:
        """[m/s] the lowest lane speed limit in force at arc length ``s`` [m] for a vehicle that
        wants ``v_desired`` [m/s]: a lane's limit L holds from (v_desired^2 - L^2) / (2 decel)
        before the lane begins (where braking at ``decel`` [m/s^2] from v_desired reaches L at its
        start, as a driver slows for a turn) to the lane's end; ``v_desired`` where none does."""
        cap = v_desired
        for start, end, limit in self.lane_limits:
            if limit < cap and start - (v_desired ** 2 - limit ** 2) / (2.0 * decel) <= s < end:
                cap = limit
        return cap

    def point_at(self, s: float | np.ndarray) -> np.ndarray:
        """[m] (x, y) at arc length ``s`` (clipped to the path)."""
        s = np.clip(s, 0.0, self.length)
        return np.stack([np.interp(s, self.s, self.xy[:, 0]), np.interp(s, self.s, self.xy[:, 1])], -1)

    def heading_at(self, s: float | np.ndarray) -> np.ndarray:
        """[rad] heading at arc length ``s`` (unwrapped along the path)."""
        return np.interp(s, self.s, self.heading)

    def curvature_at(self, s: float | np.ndarray) -> np.ndarray:
        """[1/m] signed curvature at arc length ``s``."""
        return np.interp(s, self.s, self.curvature)

    def steer_at(self, s: float | np.ndarray, wheelbase: float) -> np.ndarray:
        """[rad] front-wheel steer the path implies, delta_f = atan(l * curvature) (Eqs. 1-4)."""
        return np.arctan(wheelbase * self.curvature_at(s))

    def lane_at(self, s: float) -> tuple[str, float]:
        """The SUMO lane id at arc length ``s`` and the position [m] along that lane."""
        i = int(np.searchsorted(self.lane_starts, s, side="right")) - 1
        i = min(max(i, 0), len(self.lanes) - 1)
        return self.lanes[i], float(s - self.lane_starts[i])

    def project(self, x: float, y: float) -> tuple[float, float]:
        """Arc length [m] of the nearest point on the path to (x, y) and the distance [m] to it."""
        shape = [tuple(p) for p in self.xy]
        offset, dist = geomhelper.polygonOffsetAndDistanceToPoint((x, y), shape)
        return float(offset), float(dist)


def _resample(shape: list[tuple[float, float]], step: float) -> tuple[np.ndarray, np.ndarray]:
    pts = np.asarray(shape, dtype=float)
    keep = np.concatenate([[True], np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-6])
    pts = pts[keep]
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    n = max(int(np.ceil(cum[-1] / step)), 1) + 1
    s = np.linspace(0.0, cum[-1], n)
    xy = np.stack([np.interp(s, cum, pts[:, 0]), np.interp(s, cum, pts[:, 1])], axis=1)
    return s, xy


def _heading_curvature(s: np.ndarray, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Heading [rad] and curvature [1/m] of a resampled polyline.

    The net's polylines have corners at their vertices, so the heading is smoothed with a
    Gaussian of CURVATURE_SMOOTHING metres before it is differentiated.
    """
    d = np.gradient(xy, s, axis=0)
    heading = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    sigma = CURVATURE_SMOOTHING / (s[1] - s[0]) if len(s) > 1 else 0.0
    smooth = gaussian_filter1d(heading, sigma, mode="nearest") if sigma > 0 else heading
    curvature = np.gradient(smooth, s) if len(s) > 1 else np.zeros_like(s)
    return heading, curvature


@dataclass(frozen=True)
class CentreLine:
    """The resampled centre line of a chain of lanes (what a MovementPath's geometry is built from)."""

    s: np.ndarray  # [m] arc lengths, RESAMPLE_STEP apart, shape (n,)
    xy: np.ndarray  # [m] points at s, shape (n, 2)
    heading: np.ndarray  # [rad] heading at s, counter-clockwise from east (unwrapped)
    curvature: np.ndarray  # [1/m] signed curvature at s (left turn > 0)
    lane_starts: tuple[float, ...]  # [m] arc length at which each lane begins

    @property
    def length(self) -> float:
        """[m] total arc length."""
        return float(self.s[-1])


def centre_line(lanes) -> CentreLine:
    """Centre line of sumolib lanes in driving order: their shapes joined (each joint point once),
    resampled RESAMPLE_STEP apart, with heading and curvature (:func:`_heading_curvature`)."""
    shape: list[tuple[float, float]] = []
    starts = []
    total = 0.0
    for ln in lanes:
        starts.append(total)
        pts = [tuple(p[:2]) for p in ln.getShape()]
        shape.extend(pts if not shape else pts[1:])
        total += geomhelper.polyLength(pts)
    s, xy = _resample(shape, RESAMPLE_STEP)
    # Arc length of the resampled line differs from the lanes' sum only by the
    # de-duplicated joints; scale lane starts onto it.
    scale = s[-1] / total
    starts = [st * scale for st in starts]
    heading, curvature = _heading_curvature(s, xy)
    return CentreLine(s=s, xy=xy, heading=heading, curvature=curvature, lane_starts=tuple(starts))


def _path_lanes(net, approach_lane, exit_lane_id: str) -> list | None:
    for conn in approach_lane.getOutgoing():
        if conn.getToLane().getID() != exit_lane_id:
            continue
        lanes = [approach_lane]
        via = conn.getViaLaneID()
        while via:
            internal = net.getLane(via)
            lanes.append(internal)
            nxt = [c for c in internal.getOutgoing()]
            via = nxt[0].getViaLaneID() if nxt else ""
        lanes.append(conn.getToLane())
        return lanes
    return None


@functools.lru_cache(maxsize=8)
def load_paths(net_file: str | FsPath) -> dict[str, MovementPath]:
    """Every movement path of the net, keyed by path id."""
    net = sumolib.net.readNet(str(net_file), withInternal=True)
    paths: dict[str, MovementPath] = {}
    for approach in ARMS:
        for lane, moves in LANE_USE.items():
            approach_lane = net.getLane(f"{approach}_in_{LANE_INDEX[lane]}")
            for movement, exit_lanes in moves.items():
                arm = exit_arm(approach, movement)
                for exit_lane in exit_lanes:
                    lanes = _path_lanes(net, approach_lane, f"{arm}_out_{LANE_INDEX[exit_lane]}")
                    if lanes is None:
                        raise ValueError(f"{net_file}: no connection {approach} {lane} {movement} -> {exit_lane}")
                    line = centre_line(lanes)
                    pid = str(PathId(approach, lane, movement, exit_lane))
                    paths[pid] = MovementPath(
                        id=pid, approach=approach, lane=lane, movement=movement, exit_arm=arm,
                        exit_lane=exit_lane, lanes=tuple(ln.getID() for ln in lanes),
                        lane_starts=line.lane_starts, s_stop=line.lane_starts[1], s_exit=line.lane_starts[-1],
                        length=line.length, s=line.s, xy=line.xy, heading=line.heading,
                        curvature=line.curvature, speed_limits=tuple(float(ln.getSpeed()) for ln in lanes))
    return paths


def lane_name(sumo_lane_index: int) -> str:
    return LANE_NAME[sumo_lane_index]
