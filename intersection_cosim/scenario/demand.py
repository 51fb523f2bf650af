"""Demand on a net given by ``[network] file``: ``[[flow]]`` and ``[[vehicle]]`` tables by edge ids.

A route is either ``from`` / ``to`` edges (SUMO's shortest path for passenger cars, through
sumolib) or an explicit ``route`` list whose consecutive edges must be connected for passenger
cars. A vehicle is placed by ``edge`` / ``lane`` / ``pos`` or by ``position = [x, y]`` in the
net's frame (the nearest lane allowing passenger cars, within 1 m).
"""

from __future__ import annotations

import warnings
from typing import Any

import sumolib
from sumolib import geomhelper

from intersection_cosim.errors import InputError
from intersection_cosim.scenario.model import FlowSpec, KappaDistribution, VehicleSpec
from intersection_cosim.scenario.network import nearest
from intersection_cosim.scenario.values import number

VCLASS = "passenger"  # [-] the SUMO vehicle class routes and lanes must allow
GENERIC_FLOW_KEYS = ("id", "from", "to", "route", "rate", "kappa", "begin", "end", "speed", "lane", "pos",
                     "distance", "av_share", "vtype")
GENERIC_VEHICLE_KEYS = ("id", "edge", "lane", "pos", "position", "to", "route", "speed", "kappa", "depart",
                        "desired_speed", "driver", "vtype")
DEPART_LANES = ("best", "random", "free", "first", "allowed")  # SUMO departLane words
DEPART_SPEEDS = ("max", "desired", "speedLimit", "random")  # SUMO departSpeed words
PLACEMENT_TOLERANCE = 1.0  # [m] a position farther than this from every passenger lane is an error
PAPER_ONLY = ("approach", "movement", "exit_lane")  # keys of the paper forms only


def _edge(src: str, field: str, net: sumolib.net.Net, eid: Any) -> sumolib.net.edge.Edge:
    if not isinstance(eid, str) or not eid:
        raise InputError(src, field, eid, "must be an edge id (a string)")
    if not net.hasEdge(eid):
        known = [e.getID() for e in net.getEdges()]
        raise InputError(src, field, eid, f"is not an edge of the net ({nearest(eid, known)})")
    edge = net.getEdge(eid)
    if not edge.allows(VCLASS):
        raise InputError(src, field, eid, f"does not allow {VCLASS} cars")
    return edge


def _checked_route(src: str, field: str, net: sumolib.net.Net, value: Any) -> tuple[str, ...]:
    if not isinstance(value, list) or not value:
        raise InputError(src, field, value, 'must be a non-empty list of edge ids, like ["1si", "2o"]')
    edges = [_edge(src, f"{field}[{k}]", net, eid) for k, eid in enumerate(value)]
    for k, (a, b) in enumerate(zip(edges, edges[1:])):
        if b not in a.getAllowedOutgoing(VCLASS):
            raise InputError(src, f"{field}[{k + 1}]", b.getID(),
                             f"is not reached from {a.getID()!r} by {VCLASS} cars (no connection)")
    return tuple(e.getID() for e in edges)


def resolve_route(src: str, field: str, net: sumolib.net.Net, table: dict,
                  start: str | None = None) -> tuple[str, ...]:
    """The route of a flow or vehicle ``table``: its ``route``, or ``start``/``from`` -> ``to`` by SUMO's router.

    ``field`` is the table's name in messages (``flow[0]``); ``start`` is a vehicle's edge.
    """
    origin_key = "edge" if start is not None else "from"
    if "route" in table:
        for key in ("from", "to"):
            if key in table:
                raise InputError(src, f"{field}.{key}", table[key], "give either route or from/to, not both")
        route = _checked_route(src, f"{field}.route", net, table["route"])
        if start is not None and route[0] != start:
            raise InputError(src, f"{field}.route", table["route"], f"must start on the vehicle's edge {start!r}")
        return route
    if start is None and "from" not in table:
        raise InputError(src, f"{field}.from", None, "is required (or route)")
    if "to" not in table:
        raise InputError(src, f"{field}.to", None, "is required (or route)")
    a = _edge(src, f"{field}.{origin_key}", net, start if start is not None else table["from"])
    b = _edge(src, f"{field}.to", net, table["to"])
    path, _cost = net.getShortestPath(a, b, vClass=VCLASS)
    if path is None:
        raise InputError(src, f"{field}.to", table["to"], f"no route for {VCLASS} cars from {a.getID()!r}")
    return tuple(e.getID() for e in path)


def _reject_paper_keys(src: str, field: str, table: dict) -> None:
    for key in PAPER_ONLY:
        if key in table:
            raise InputError(src, f"{field}.{key}", table[key],
                             "is for the generated net only; on [network] file give from/to or route (edge ids)")


def _depart_lane(src: str, field: str, value: Any, edge: sumolib.net.edge.Edge) -> str:
    if isinstance(value, str) and value in DEPART_LANES:
        return value
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(src, field, value, f"must be a lane index or one of {', '.join(DEPART_LANES)}")
    _lane(src, field, value, edge)
    return str(value)


def _lane(src: str, field: str, index: Any, edge: sumolib.net.edge.Edge) -> sumolib.net.lane.Lane:
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < edge.getLaneNumber():
        raise InputError(src, field, index, f"must be a lane index of edge {edge.getID()!r} "
                         f"(0 to {edge.getLaneNumber() - 1})")
    lane = edge.getLane(index)
    if not lane.allows(VCLASS):
        raise InputError(src, field, index, f"lane {lane.getID()!r} does not allow {VCLASS} cars")
    return lane


def _depart_speed(src: str, field: str, value: Any) -> str:
    if isinstance(value, str) and value in DEPART_SPEEDS:
        return value
    if isinstance(value, str):
        raise InputError(src, field, value, f"must be a speed [m/s] or one of {', '.join(DEPART_SPEEDS)}")
    return f"{number(src, field, value, minimum=0.0):g}"


def _flow_depart_pos(src: str, field: str, table: dict, edge: sumolib.net.edge.Edge) -> float | None:
    if "pos" in table and "distance" in table:
        raise InputError(src, f"{field}.distance", table["distance"], "give either pos or distance, not both")
    length = edge.getLength()  # [m]
    if "pos" in table:
        return number(src, f"{field}.pos", table["pos"], minimum=0.0, maximum=length)
    if "distance" in table:  # [m] before the end of the first edge (its junction)
        return length - number(src, f"{field}.distance", table["distance"], minimum=0.0, maximum=length)
    return None


def generic_flow(src: str, i: int, table: dict, net: sumolib.net.Net,
                 kappa: KappaDistribution, window: tuple[float, float]) -> FlowSpec:
    """A ``[[flow]]`` table on a generic net; ``kappa`` and the ``(begin, end)`` window [s] are
    already validated (they are read as on the generated net)."""
    field = f"flow[{i}]"
    _reject_paper_keys(src, field, table)
    for key in table:
        if key not in GENERIC_FLOW_KEYS:
            raise InputError(src, f"{field}.{key}", table[key], f"unknown key (known: {', '.join(GENERIC_FLOW_KEYS)})")
    if "rate" not in table:
        raise InputError(src, f"{field}.rate", None, "is required")
    route = resolve_route(src, field, net, table)
    first = net.getEdge(route[0])
    fid = table.get("id", f"{route[0]}_{route[-1]}_{i}")
    if not isinstance(fid, str) or not fid or any(ch.isspace() for ch in fid):
        raise InputError(src, f"{field}.id", fid, "must be a non-empty string without spaces")
    return FlowSpec(id=fid, approach="", movement="", rate=number(src, f"{field}.rate", table["rate"], minimum=0.0),
                    kappa=kappa, begin=window[0], end=window[1], route=route,
                    depart_lane=_depart_lane(src, f"{field}.lane", table.get("lane", "best"), first),
                    depart_speed=_depart_speed(src, f"{field}.speed", table.get("speed", "max")),
                    depart_pos=_flow_depart_pos(src, field, table, first))


def _place_by_position(src: str, field: str, net: sumolib.net.Net, xy: Any) -> tuple[sumolib.net.lane.Lane, float]:
    if (not isinstance(xy, list) or len(xy) != 2
            or any(isinstance(c, bool) or not isinstance(c, (int, float)) for c in xy)):
        raise InputError(src, f"{field}.position", xy, "must be [x, y] in metres (the net's frame)")
    with warnings.catch_warnings():  # sumolib warns once when rtree is missing and searches all lanes
        warnings.simplefilter("ignore")
        near = net.getNeighboringLanes(float(xy[0]), float(xy[1]), PLACEMENT_TOLERANCE, includeJunctions=False)
    near = sorted(((d, ln.getID(), ln) for ln, d in near if ln.allows(VCLASS)), key=lambda t: t[:2])
    if not near:
        raise InputError(src, f"{field}.position", xy,
                         f"more than {PLACEMENT_TOLERANCE:g} m from every lane allowing {VCLASS} cars")
    lane = near[0][2]
    pos, _dist = lane.getClosestLanePosAndDist((float(xy[0]), float(xy[1])))
    return lane, float(min(max(pos, 0.0), lane.getLength()))


def _place(src: str, field: str, net: sumolib.net.Net, table: dict) -> tuple[sumolib.net.lane.Lane, float]:
    """The lane and the position along it [m] a generic vehicle starts at."""
    if "position" in table:
        for key in ("edge", "lane", "pos"):
            if key in table:
                raise InputError(src, f"{field}.{key}", table[key], "give either position or edge/lane/pos, not both")
        return _place_by_position(src, field, net, table["position"])
    for key in ("edge", "pos"):
        if key not in table:
            raise InputError(src, f"{field}.{key}", None, "is required when position is not given")
    edge = _edge(src, f"{field}.edge", net, table["edge"])
    lane = _lane(src, f"{field}.lane", table.get("lane", 0), edge)
    return lane, number(src, f"{field}.pos", table["pos"], minimum=0.0, maximum=lane.getLength())


def lane_point(lane: sumolib.net.lane.Lane, pos: float) -> tuple[float, float]:
    """The point [m] (net frame) ``pos`` [m] along ``lane``."""
    shape = lane.getShape()
    scale = geomhelper.polyLength(shape) / lane.getLength() if lane.getLength() > 0 else 1.0
    x, y = geomhelper.positionAtShapeOffset(shape, pos * scale)[:2]
    return float(x), float(y)


def check_vehicle_keys(src: str, field: str, table: dict) -> None:
    """A generic ``[[vehicle]]`` table has no paper-only and no unknown keys."""
    _reject_paper_keys(src, field, table)
    for key in table:
        if key not in GENERIC_VEHICLE_KEYS:
            raise InputError(src, f"{field}.{key}", table[key],
                             f"unknown key (known: {', '.join(GENERIC_VEHICLE_KEYS)})")


def generic_vehicle(src: str, field: str, vid: str, table: dict, net: sumolib.net.Net,
                    motion: tuple[float, float, float, float | None]) -> VehicleSpec:
    """A ``[[vehicle]]`` table on a generic net; ``motion`` = (speed [m/s], kappa [-], depart [s],
    desired_speed [m/s] or None), already validated as on the generated net (its keys by
    :func:`check_vehicle_keys`)."""
    lane, pos = _place(src, field, net, table)
    route = resolve_route(src, field, net, table, start=lane.getEdge().getID())
    x, y = lane_point(lane, pos)
    speed, kappa, depart, desired = motion
    return VehicleSpec(id=vid, approach="", lane=lane.getID(), movement="", path_id="", s0=pos, x=x, y=y,
                       speed=speed, kappa=kappa, depart=depart, desired_speed=desired, route=route,
                       depart_lane=lane.getIndex(), depart_pos=pos)


def check_generic_spacing(src: str, vehicles: list[VehicleSpec], min_gap: float) -> None:
    """Two generic vehicles placed at the same time closer than ``min_gap`` [m] on one lane: an error."""
    placed: dict[tuple[float, str], list[tuple[float, str]]] = {}
    for v in vehicles:
        for other_pos, other in placed.get((v.depart, v.lane), []):
            if abs(other_pos - v.s0) < min_gap:
                raise InputError(src, f"vehicle[{v.id}].pos", round(v.s0, 2),
                                 f"within {min_gap:g} m of {other} on lane {v.lane}")
        placed.setdefault((v.depart, v.lane), []).append((v.s0, v.id))
