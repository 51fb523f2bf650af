"""The movements a controller manages: the movement paths of its junctions and how they relate.

A movement path runs from an approach lane through the junction-internal lane(s) of one
connection to one exit lane (:class:`~intersection_cosim.network.paths.MovementPath`). Paths from
the same approach lane that make the same movement onto the same road differ only in their exit
lane: they are *siblings*, and a vehicle on one may still switch to another while it approaches.
:class:`Movements` holds the paths with that relation and the role of every lane of them, so the
controller and the simulator adapter never take path or lane ids apart.

:func:`paper_movements` builds it for the generated intersection of the paper (arms, lane names
and lane use of :mod:`~intersection_cosim.network.spec`);
:func:`~intersection_cosim.network.junction_net.load_movements` for the junctions of any SUMO net.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path as FsPath
from typing import Mapping

from intersection_cosim.network.path_id import PathId
from intersection_cosim.network.paths import MovementPath, load_paths
from intersection_cosim.network.spec import LANE_USE

READY, PASSING, OUTSIDE = "ready", "passing", "outside"  # a vehicle's role by its lane


@dataclass(frozen=True)
class Movements:
    """Every managed movement path of a net (by path id) and how the paths relate."""

    net_file: str  # the SUMO net
    junctions: tuple[str, ...]  # the managed junctions' ids
    paths: Mapping[str, MovementPath]
    exits: Mapping[str, tuple[str, ...]]  # path id -> exit lanes of its movement, preferred first
    siblings: Mapping[tuple[str, str], str]  # (path id, exit lane) -> the sibling path's id
    roles: Mapping[str, str]  # SUMO lane id -> READY (before the stop line) or PASSING (in the junction)
    foes: frozenset[tuple[str, str]] = frozenset()  # path id pairs (both orders) SUMO's right of way calls foes
    control_range: float | None = None  # [m] approach length the paths were extended to (None: as the net has it)
    vclass: str = "passenger"  # the SUMO vehicle class whose movements these are

    def options(self, path_id: str) -> tuple[str, ...]:
        """The exit lanes a vehicle on ``path_id`` may take, preferred first."""
        return self.exits[path_id]

    def preferred(self, path_id: str) -> str:
        """The movement's default exit lane."""
        return self.exits[path_id][0]

    def sibling(self, path_id: str, exit_lane: str) -> str:
        """The id of the path from the same approach lane, same movement, to ``exit_lane``."""
        return self.siblings[(path_id, exit_lane)]

    def role(self, lane_id: str) -> str:
        """READY on a managed approach, PASSING inside a managed junction, else OUTSIDE."""
        return self.roles.get(lane_id, OUTSIDE)

    @property
    def key(self) -> tuple:
        """What identifies these movements (for caches)."""
        return (self.net_file, self.junctions, self.control_range, self.vclass)


@functools.lru_cache(maxsize=8)
def _paper_movements(net_file: str) -> Movements:
    paths = load_paths(net_file)
    exits, siblings, roles = {}, {}, {}
    for pid, path in paths.items():
        exits[pid] = LANE_USE[path.lane][path.movement]
        base = PathId.parse(pid)
        for exit_lane in exits[pid]:
            siblings[(pid, exit_lane)] = str(base.with_exit(exit_lane))
        for lane in path.lanes[:path.stop_index]:
            roles[lane] = READY
        for lane in path.junction_lanes:
            roles[lane] = PASSING
    return Movements(net_file, ("C",), paths, exits, siblings, roles)


def paper_movements(net_file: str | FsPath) -> Movements:
    """The movements of the generated intersection (its centre junction ``C``), cached per net."""
    return _paper_movements(str(net_file))
