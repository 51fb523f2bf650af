"""The net's drawable geometry, read with sumolib: lane, junction and zebra-crossing outlines, internal
lane centre lines.

Everything is in the net's frame, the frame of a run's trajectories (x east, y north, metres;
for the generated paper net the paper frame, its junction centre at the origin).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import sumolib


@dataclass(frozen=True)
class NetOutline:
    lanes: list[np.ndarray]  # [m] outline polygon (n x 2) of every normal lane
    junctions: list[np.ndarray]  # [m] outline polygon of every junction with an area
    internal: list[np.ndarray]  # [m] centre line (n x 2) of every junction-internal lane (the connections)
    crossings: list[np.ndarray] = field(default_factory=list)  # [m] outline of every zebra crossing


def lane_polygon(shape: np.ndarray, width: float) -> np.ndarray:
    """[m] the outline of a lane ``width`` [m] wide around its centre polyline ``shape`` (n x 2)."""
    d = np.gradient(shape, axis=0)
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    normal = np.column_stack([-d[:, 1], d[:, 0]]) * (width / 2)
    return np.vstack([shape + normal, (shape - normal)[::-1]])


def junction_centre(net_file: str | Path, junction: str) -> tuple[float, float]:
    """[m] the position of ``junction`` in the net's frame."""
    return junction_outlines(net_file, (junction,))[junction][0]


def junction_outlines(net_file: str | Path, junctions) -> dict[str, tuple[tuple[float, float], np.ndarray]]:
    """[m] per junction id: its position and its outline polygon (n x 2; (0, 2) if it has no
    area) in the net's frame, from one read of the net."""
    net = sumolib.net.readNet(str(net_file))
    out = {}
    for j in junctions:
        node = net.getNode(j)
        shape = node.getShape()
        polygon = np.asarray([p[:2] for p in shape], float).reshape(-1, 2) if len(shape) >= 3 else np.zeros((0, 2))
        x, y = node.getCoord()[:2]
        out[j] = ((float(x), float(y)), polygon)
    return out


def read_outline(net_file: str | Path) -> NetOutline:
    """The outline of ``net_file``'s lanes and junctions (sumolib, with internal lanes)."""
    net = sumolib.net.readNet(str(net_file), withInternal=True)
    lanes, internal, crossings = [], [], []
    for edge in net.getEdges(withInternal=True):
        for lane in edge.getLanes():
            shape = np.asarray([p[:2] for p in lane.getShape()], float)
            if edge.getFunction() == "internal":
                internal.append(shape)
            elif edge.getFunction() == "crossing":
                crossings.append(lane_polygon(shape, lane.getWidth()))
            elif edge.getFunction() != "walkingarea":  # (a walking area's shape is its outline, not a centre line)
                lanes.append(lane_polygon(shape, lane.getWidth()))
    junctions = [np.asarray([p[:2] for p in node.getShape()], float) for node in net.getNodes()
                 if len(node.getShape()) >= 3]
    return NetOutline(lanes=lanes, junctions=junctions, internal=internal, crossings=crossings)
