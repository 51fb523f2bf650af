"""Movements of the junctions of any SUMO net, read with sumolib (never libsumo).

:func:`load_movements` turns every connection of a managed junction that a vehicle class may drive
into a :class:`~intersection_cosim.network.paths.MovementPath`: from lane -> the junction-internal
lane(s) SUMO built for the connection (an internal junction in the middle splits a connection into
more than one) -> to lane, id ``"<from lane>><to lane>"``. The approach is extended upstream
through *unique predecessors* (a lane with exactly one incoming lane whose only outgoing lane is
this one, or that only fans out into lanes of this one's edge; internal lanes of unmanaged
junctions count) until it is ``control_range`` metres long,
so short OSM edges still give the controller room to act. SUMO's own foe relation between the
junction's links is recorded as a second opinion on the geometric conflicts
(:func:`~intersection_cosim.network.conflicts.movement_conflicts`).

:func:`junction_table` lists a net's junctions with what they hold and whether they can be
managed, and why not.
"""

from __future__ import annotations

import difflib
import functools
from dataclasses import dataclass
from pathlib import Path as FsPath

import pandas as pd
import sumolib
from sumolib import geomhelper

from intersection_cosim.errors import InputError
from intersection_cosim.network.movements import PASSING, READY, Movements
from intersection_cosim.network.paths import MovementPath, centre_line
from intersection_cosim.network.xml_files import root_attributes

JUNCTIONS_FIELD = "network.junctions"
NET_FIELD = "network.net"
DIRECTIONS = {"s": "straight", "l": "left", "r": "right", "t": "turn", "L": "partleft", "R": "partright"}
# Lane 0 is the curb lane (rightmost in right-hand traffic, leftmost in a lefthand net). A turn
# across the oncoming traffic prefers the exit lane nearest the median (highest index), a
# curb-side turn the curb lane (index 0); by lefthand: the net's <net lefthand="true">.
FAR_SIDE = {False: ("left", "partleft", "turn"), True: ("right", "partright", "turn")}
NEAR_SIDE = {False: ("right", "partright"), True: ("left", "partleft")}
UNMANAGEABLE = {  # junction type -> why such a junction cannot be managed
    "internal": "is a junction-internal point, not a junction",
    "dead_end": "is a dead end (no connections to manage)",
    "rail_crossing": "is a rail crossing (trains have right of way)",
    "rail_signal": "is a rail signal, not a road junction",
    "district": "is a district (traffic assignment zone), not a junction",
}


@dataclass(frozen=True)
class _LaneGraph:
    """Which lane follows which, over every connection of the net (internal lanes included)."""

    succ: dict[str, frozenset[str]]
    pred: dict[str, frozenset[str]]


@functools.lru_cache(maxsize=4)
def _read(net_file: str):
    path = FsPath(net_file)
    if not path.is_file():
        raise InputError(net_file, NET_FIELD, net_file, "no such file")
    try:
        net = sumolib.net.readNet(net_file, withInternal=True)
    except Exception as exc:  # sumolib raises the XML parser's errors as they come
        raise InputError(net_file, NET_FIELD, net_file, f"not a readable SUMO net ({exc})") from None
    if not net.getEdges():  # e.g. a route or additional file: sumolib reads it as an empty net
        raise InputError(net_file, NET_FIELD, net_file, "is not a SUMO net (it has no edges)")
    return net, _lane_graph(net)


def _lane_graph(net) -> _LaneGraph:
    succ: dict[str, set[str]] = {}
    pred: dict[str, set[str]] = {}
    for edge in net.getEdges(withInternal=True):
        for lane in edge.getLanes():
            for conn in lane.getOutgoing():
                nxt = conn.getViaLaneID() or conn.getToLane().getID()
                succ.setdefault(lane.getID(), set()).add(nxt)
                pred.setdefault(nxt, set()).add(lane.getID())
    return _LaneGraph({k: frozenset(v) for k, v in succ.items()}, {k: frozenset(v) for k, v in pred.items()})


def _is_normal(lane) -> bool:
    return lane.getEdge().getFunction() == ""


def drivable_connections(node, vclass: str = "passenger") -> list:
    """The node's connections from a normal lane to a normal lane, both open to ``vclass``, with a
    known direction, in the net's order."""
    return [c for c in node.getConnections()
            if _is_normal(c.getFromLane()) and _is_normal(c.getToLane())
            and c.getFromLane().allows(vclass) and c.getToLane().allows(vclass)
            and c.getDirection() in DIRECTIONS]


def junction_problem(node, vclass: str = "passenger") -> str:
    """Why ``node`` cannot be managed for ``vclass`` ("" if it can)."""
    if node.getType() in UNMANAGEABLE:
        return UNMANAGEABLE[node.getType()]
    if not drivable_connections(node, vclass):
        return f"has no connection drivable by {vclass}"
    return ""


def _node(net, net_file: str, jid: str, vclass: str):
    if not net.hasNode(jid):
        ids = [n.getID() for n in net.getNodes()]
        near = difflib.get_close_matches(jid, ids, n=3, cutoff=0.5)
        hint = f"; nearest ids: {', '.join(near)}" if near else ""
        what = "is a junction-internal point (ids starting with ':' lie inside a junction)" \
            if jid.startswith(":") else "is not a junction of the net"
        raise InputError(net_file, JUNCTIONS_FIELD, jid, what + hint)
    node = net.getNode(jid)
    problem = junction_problem(node, vclass)
    if problem:
        raise InputError(net_file, JUNCTIONS_FIELD, jid, f"{problem} (type {node.getType()})")
    return node


def _internal_chain(net, conn) -> list:
    """The internal lanes of a connection in driving order (none if the net has no internal links)."""
    lanes = []
    via = conn.getViaLaneID()
    while via:
        internal = net.getLane(via)
        lanes.append(internal)
        nxt = internal.getOutgoing()
        via = nxt[0].getViaLaneID() if nxt else ""
    return lanes


def _lane_length(lane) -> float:
    """[m] length of a lane's shape (what :func:`centre_line` adds up)."""
    return geomhelper.polyLength([tuple(p[:2]) for p in lane.getShape()])


def _edge_after(graph: _LaneGraph, lane: str) -> str | None:
    """The normal edge a vehicle on ``lane`` reaches next (its own for a normal lane; through
    internal lanes with one successor each), None where the way branches."""
    seen = set()
    while lane.startswith(":") and lane not in seen:
        seen.add(lane)
        nxt = graph.succ.get(lane, frozenset())
        if len(nxt) != 1:
            return None
        (lane,) = nxt
    return None if lane.startswith(":") else lane.rsplit("_", 1)[0]


def _leads_only_to(graph: _LaneGraph, prev: str, cur: str) -> bool:
    """Whether every vehicle on ``prev`` drives on to the edge ``cur`` leads to: ``cur`` is its
    only successor, or it fans out into lanes of that one edge only (a lane split: one lane widening
    to several, an unmanaged node with no other way), so ``prev`` belongs to the approach as
    surely as a unique predecessor does."""
    succ = graph.succ.get(prev, frozenset())
    if succ == frozenset({cur}):
        return True
    target = _edge_after(graph, cur)
    return target is not None and all(_edge_after(graph, nxt) == target for nxt in succ)


def _upstream(net, graph: _LaneGraph, lane, control_range: float, vclass: str, blocked: frozenset) -> list:
    """Unique predecessors of ``lane``, furthest first, until the approach (them and ``lane``) is
    ``control_range`` [m] long; never a lane in ``blocked`` (managed junctions' lanes) or seen twice.
    A predecessor that fans out into other lanes of the same edge (:func:`_leads_only_to`) counts:
    without it the approach would end a few metres before a junction that follows a lane split,
    and vehicles bound for it would first be seen too close to stop."""
    chain: list = []
    length = _lane_length(lane)  # [m]
    cur = lane.getID()
    seen = {cur}
    while length < control_range:
        preds = graph.pred.get(cur, frozenset())
        if len(preds) != 1:
            break
        (prev,) = preds
        if not _leads_only_to(graph, prev, cur) or prev in seen or prev in blocked:
            break
        prev_lane = net.getLane(prev)
        if not prev_lane.allows(vclass):
            break
        chain.insert(0, prev_lane)
        seen.add(prev)
        length += _lane_length(prev_lane)
        cur = prev
    return chain


def _path(conn, upstream: list, internal: list, jid: str) -> MovementPath:
    from_lane, to_lane = conn.getFromLane(), conn.getToLane()
    lanes = [*upstream, from_lane, *internal, to_lane]
    stop_index = len(upstream) + 1
    line = centre_line(lanes)
    pid = f"{from_lane.getID()}>{to_lane.getID()}"
    return MovementPath(
        id=pid, approach=from_lane.getEdge().getID(), lane=from_lane.getID(),
        movement=DIRECTIONS[conn.getDirection()], exit_arm=conn.getTo().getID(),
        exit_lane=str(to_lane.getIndex()), lanes=tuple(ln.getID() for ln in lanes),
        lane_starts=line.lane_starts, s_stop=line.lane_starts[stop_index], s_exit=line.lane_starts[-1],
        length=line.length, s=line.s, xy=line.xy, heading=line.heading, curvature=line.curvature,
        stop_index=stop_index, junction=jid, speed_limits=tuple(float(ln.getSpeed()) for ln in lanes))


def _preference(movement: str, from_index: int, exit_index: int, lefthand: bool = False) -> tuple:
    """Sort key of an exit lane [lane index] for a movement: preferred first."""
    if movement in FAR_SIDE[lefthand]:
        return (-exit_index,)
    if movement in NEAR_SIDE[lefthand]:
        return (exit_index,)
    return (abs(exit_index - from_index), exit_index)


def _exits(paths: dict[str, MovementPath], from_index: dict[str, int], lefthand: bool = False):
    """``exits`` and ``siblings`` of :class:`Movements`: paths from one lane onto one road
    (``lefthand``: the net drives on the left)."""
    groups: dict[tuple[str, str], list[MovementPath]] = {}
    for path in paths.values():
        groups.setdefault((path.lane, path.exit_arm), []).append(path)
    exits, siblings = {}, {}
    for group in groups.values():
        by_exit = {p.exit_lane: p.id for p in group}
        move, here = group[0].movement, from_index[group[0].lane]
        order = tuple(sorted(by_exit, key=lambda e: _preference(move, here, int(e), lefthand)))
        for path in group:
            exits[path.id] = order
            for exit_lane in order:
                siblings[(path.id, exit_lane)] = by_exit[exit_lane]
    return exits, siblings


def _foes(node, conns: list, pids: list[str]) -> set[tuple[str, str]]:
    """Pairs of path ids (both orders) whose links SUMO's right-of-way logic marks as foes."""
    out = set()
    for i, ci in enumerate(conns):
        for j in range(i + 1, len(conns)):
            li, lj = ci.getJunctionIndex(), conns[j].getJunctionIndex()
            if li < 0 or lj < 0 or pids[i] == pids[j]:
                continue
            try:
                foes = node.areFoes(li, lj) or node.areFoes(lj, li)
            except (KeyError, IndexError):  # a node without right-of-way logic for these links
                foes = False
            if foes:
                out |= {(pids[i], pids[j]), (pids[j], pids[i])}
    return out


def _managed_lanes(net, nodes: list) -> frozenset:
    """Lanes no approach may extend through: the managed junctions' from and internal lanes."""
    lanes = set()
    for node in nodes:
        for conn in node.getConnections():
            if _is_normal(conn.getFromLane()):
                lanes.add(conn.getFromLane().getID())
                lanes.update(ln.getID() for ln in _internal_chain(net, conn))
    return frozenset(lanes)


def _junction_paths(net, graph, node, control_range: float, vclass: str, blocked: frozenset):
    """Paths, their from lanes' indices and SUMO's foe pairs of one managed junction."""
    conns = drivable_connections(node, vclass)
    upstream: dict[str, list] = {}
    paths: dict[str, MovementPath] = {}
    from_index: dict[str, int] = {}
    for conn in conns:
        lane = conn.getFromLane()
        if lane.getID() not in upstream:
            upstream[lane.getID()] = _upstream(net, graph, lane, control_range, vclass, blocked)
            from_index[lane.getID()] = lane.getIndex()
        path = _path(conn, upstream[lane.getID()], _internal_chain(net, conn), node.getID())
        paths.setdefault(path.id, path)
    foes = _foes(node, conns, [f"{c.getFromLane().getID()}>{c.getToLane().getID()}" for c in conns])
    return paths, from_index, foes


@functools.lru_cache(maxsize=8)
def _load_movements(net_file: str, junctions: tuple[str, ...], control_range: float, vclass: str) -> Movements:
    net, graph = _read(net_file)
    if not junctions:
        raise InputError(net_file, JUNCTIONS_FIELD, "", "name at least one junction to manage")
    nodes = [_node(net, net_file, jid, vclass) for jid in junctions]
    blocked = _managed_lanes(net, nodes)
    paths: dict[str, MovementPath] = {}
    from_index: dict[str, int] = {}
    foes: set[tuple[str, str]] = set()
    for node in nodes:
        p, f, fo = _junction_paths(net, graph, node, control_range, vclass, blocked)
        paths.update(p)
        from_index.update(f)
        foes |= fo
    exits, siblings = _exits(paths, from_index, root_attributes(net_file).get("lefthand") == "true")
    roles = {}
    for path in paths.values():
        roles.update({lane: READY for lane in path.lanes[:path.stop_index]})
        roles.update({lane: PASSING for lane in path.junction_lanes})
    return Movements(net_file, junctions, paths, exits, siblings, roles, foes=frozenset(foes),
                     control_range=control_range, vclass=vclass)


def load_movements(net_file: str | FsPath, junctions: tuple[str, ...], control_range: float = 100.0,
                   vclass: str = "passenger") -> Movements:
    """The movements of the junctions ``junctions`` of a SUMO net, for vehicles of ``vclass``, with
    approaches extended upstream to ``control_range`` [m] where the road does not branch (cached).

    Raises :class:`~intersection_cosim.errors.InputError` (field ``network.junctions``) for an id
    that is not a junction of the net (naming the nearest ids) or a junction that cannot be
    managed (:func:`junction_problem`).
    """
    unique = tuple(dict.fromkeys(str(j) for j in junctions))
    return _load_movements(str(net_file), unique, float(control_range), str(vclass))


def _node_row(node, vclass: str, include_all: bool) -> dict | None:
    def drivable(edges):
        return [e for e in edges if e.getFunction() == "" and any(ln.allows(vclass) for ln in e.getLanes())]

    inc, out = drivable(node.getIncoming()), drivable(node.getOutgoing())
    arms = len({e.getFromNode().getID() for e in inc} | {e.getToNode().getID() for e in out})
    if not include_all and arms < 3 and node.getType() != "traffic_light":
        return None
    problem = junction_problem(node, vclass)
    return {"id": node.getID(), "type": node.getType(), "arms": arms, "in": len(inc), "out": len(out),
            "lanes_in": sum(ln.allows(vclass) for e in inc for ln in e.getLanes()),
            "lanes_out": sum(ln.allows(vclass) for e in out for ln in e.getLanes()),
            "connections": len(drivable_connections(node, vclass)),
            "manageable": not problem, "reason": problem}


TABLE_COLUMNS = ("id", "type", "arms", "in", "out", "lanes_in", "lanes_out", "connections", "manageable", "reason")


def junction_table(net_file: str | FsPath, all_junctions: bool = False, vclass: str = "passenger") -> pd.DataFrame:
    """One row per junction of the net: ``arms`` (neighbouring junctions joined by a road open to
    ``vclass``), ``in`` / ``out`` (such incoming / outgoing edges), ``lanes_in`` / ``lanes_out``
    (their lanes open to ``vclass``), ``connections`` (drivable by ``vclass``), ``manageable`` and
    the ``reason`` if not. Without ``all_junctions`` only intersections: 3 or more arms, or a
    traffic light."""
    net, _ = _read(str(net_file))
    rows = [_node_row(n, vclass, all_junctions) for n in net.getNodes() if n.getType() != "internal"]
    return pd.DataFrame([r for r in rows if r is not None], columns=list(TABLE_COLUMNS))


def uturn_exits(net_file: str | FsPath, junctions: tuple[str, ...], vclass: str = "passenger") -> dict[str, str]:
    """Each edge into one of ``junctions`` that has a U-turn connection (SUMO's direction ``t``)
    open to ``vclass`` -> the edge it turns back onto; empty for a net built without turnarounds
    (the generated paper net). What the stress search's U-turn axis may draw."""
    net, _graph = _read(str(net_file))
    out: dict[str, str] = {}
    for jid in junctions:
        for conn in drivable_connections(_node(net, str(net_file), jid, vclass), vclass):
            if conn.getDirection() == "t":
                out.setdefault(conn.getFrom().getID(), conn.getTo().getID())
    return out
