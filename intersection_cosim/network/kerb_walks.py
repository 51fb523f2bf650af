"""Walks over the crossings of junctions, kerb to kerb: what a pedestrian demand over them walks.

SUMO joins a junction's crossings by walking areas: a corner's walking area touches the sidewalks
of the roads meeting there; a median island's touches none, only the two crossings it splits.
A kerb-to-kerb crossing is one crossing between two corners, or a chain of crossings over islands
(Braunschweig's junction 38 has eight crossings over four islands: four kerb-to-kerb crossings).
:func:`kerb_walks` gives one :class:`KerbWalk` per kerb-to-kerb crossing: from a sidewalk edge of
one corner to one of the other, starting and ending ``approach`` metres from the junction, so
SUMO's router (the shortest way) takes the walker over that crossing soon after it departs.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import sumolib

from intersection_cosim.network.crossings import junction_crossings

PEDESTRIAN = "pedestrian"  # SUMO's vehicle class of walkers
MAX_ISLANDS = 4  # [-] islands a chain of crossings may pass before it is given up


@dataclass(frozen=True)
class KerbWalk:
    """A walk over one kerb-to-kerb crossing of ``junction``: from edge ``start`` at ``depart_pos``
    [m] to edge ``end`` at ``arrival_pos`` [m], over ``crossings`` (edge ids, in order)."""

    junction: str
    start: str
    depart_pos: float  # [m] along ``start``
    end: str
    arrival_pos: float  # [m] along ``end``
    crossings: tuple[str, ...]


def _area_edge(lane_id: str) -> str:
    return lane_id.rsplit("_", 1)[0]


def _sidewalks(net, area: str) -> list:
    """The normal edges open to pedestrians that touch walking area ``area`` (none: an island)."""
    wa = net.getEdge(area)
    return sorted({e for e in (*wa.getIncoming(), *wa.getOutgoing())
                   if e.getFunction() == "" and e.allows(PEDESTRIAN)}, key=lambda e: e.getID())


def _to_kerb(net, by_area: dict, area: str, came: str) -> tuple[str, tuple[str, ...]] | None:
    """(corner walking area, crossings passed) from ``area``, reached over crossing ``came``:
    ``area`` itself if it is a corner, else on over the island's other crossing."""
    chain: tuple[str, ...] = ()
    for _ in range(MAX_ISLANDS + 1):
        if _sidewalks(net, area):
            return area, chain
        others = [(c, ends) for c, ends in by_area.get(area, []) if c != came]
        if not others:
            return None
        came, ends = others[0]
        chain += (came,)
        area = ends[1] if ends[0] == area else ends[0]
    return None


def _pos_near(edge, junction: str, approach: float) -> float:
    """[m] the position along ``edge`` ``approach`` metres from its end at ``junction``."""
    length = edge.getLength()
    return round(max(0.0, length - approach) if edge.getToNode().getID() == junction else min(length, approach), 2)


@functools.lru_cache(maxsize=8)
def kerb_walks(net_file: str, junctions: tuple[str, ...], approach: float = 10.0) -> tuple[KerbWalk, ...]:
    """One walk per kerb-to-kerb crossing of ``junctions`` (none in a net without crossings), in
    the net's crossing order; ``approach`` [m]: how far from the junction the walks start and end."""
    crossings = junction_crossings(net_file, junctions)
    if not crossings:
        return ()
    net = sumolib.net.readNet(net_file, withInternal=True, withPedestrianConnections=True)
    by_area: dict[str, list] = {}
    for c in crossings.values():
        ends = tuple(_area_edge(a) for a in c.walking_areas)
        if len(ends) == 2:
            for a in ends:
                by_area.setdefault(a, []).append((c.edge, ends))
    walks, seen = [], set()
    for c in crossings.values():
        ends = tuple(_area_edge(a) for a in c.walking_areas)
        sides = [_to_kerb(net, by_area, a, c.edge) for a in ends] if len(ends) == 2 else [None]
        if any(s is None for s in sides) or sides[0][0] == sides[1][0] or frozenset(s[0] for s in sides) in seen:
            continue
        seen.add(frozenset(s[0] for s in sides))
        a_edges, b_edges = (_sidewalks(net, s[0]) for s in sides)
        start = next((e for e in a_edges if e not in b_edges), None)
        end = next((e for e in b_edges if e not in a_edges), None)
        if start is None or end is None:
            continue
        chain = tuple(reversed(sides[0][1])) + (c.edge,) + sides[1][1]
        walks.append(KerbWalk(c.junction, start.getID(), _pos_near(start, c.junction, approach), end.getID(),
                              _pos_near(end, c.junction, approach), chain))
    return tuple(walks)
