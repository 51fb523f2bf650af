"""Which approach lanes SUMO's waiting position on a path looks at (its internal junction).

netconvert splits the internal lane of a connection that must wait inside the junction (a left
turn waiting for the opposing stream) at an internal junction; ``MovementPath.s_wait`` is where.
The net lists, for each internal junction, the lanes whose vehicles it waits for:
``incLanes`` (the approach lanes of the foe streams, plus the path's own first internal lane)
and ``intLanes`` (foe internal lanes). A vehicle standing there is released by SUMO once no
vehicle approaches on those approach lanes and none is on those internal lanes; a vehicle
approaching on any other lane is not looked at, and must keep able to yield to it.

Pure: reads the net file (plain or gzipped).
"""

from __future__ import annotations

import functools
from typing import Mapping

from intersection_cosim.network.movements import Movements
from intersection_cosim.network.xml_files import xml_root


@functools.lru_cache(maxsize=16)
def _internal_junctions(net_file: str) -> dict[str, tuple[str, ...]]:
    """Internal junction id -> its ``incLanes`` that are approach lanes (not internal ones)."""
    out = {}
    for el in xml_root(net_file).iter("junction"):
        if el.get("type") == "internal":
            out[el.get("id")] = tuple(ln for ln in el.get("incLanes", "").split() if not ln.startswith(":"))
    return out


def waiting_watches(movements: Movements) -> Mapping[str, frozenset[str]]:
    """Path id -> the approach lanes its waiting position waits for, for every path that has one
    (``MovementPath.s_wait`` finite: its second internal lane starts at an internal junction of
    the same id)."""
    junctions = _internal_junctions(str(movements.net_file))
    out = {}
    for pid, path in movements.paths.items():
        lanes = path.junction_lanes
        if len(lanes) >= 2 and lanes[1] in junctions:
            out[pid] = frozenset(junctions[lanes[1]])
    return out
