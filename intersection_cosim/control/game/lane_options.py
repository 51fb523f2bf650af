"""Exit-lane options of a step and what leaving the preferred exit lane costs (J_lk, paper Eq. 23).

An exit lane matters only if it changes the vehicle's partners: whom it crosses or merges with,
or whom it follows (Case 2's V3: behind V4 on the inner lane, or merging with V1 on the middle
lane). Where every option gives the same partners (Case 1's left turns cross the same vehicles
whichever exit lane they take), only the preferred one is solved: the previous step's choice,
else the movement's default lane. Where the choice matters it is decided every
``lane_choice_period`` control steps (the discrete decision at a slower rate than the continuous
one, as in multi-rate MPC); in between the vehicle holds its last choice.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Mapping

import numpy as np
import sumolib

from intersection_cosim.control.base import World
from intersection_cosim.control.game.relations import Relations
from intersection_cosim.games.lane_choice import lane_change_cost
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.movements import Movements


@dataclass(frozen=True)
class LaneOptions:
    """The exit lanes worth deciding between this step, per vehicle, and the lane-choice clock."""

    options: Mapping[int, tuple[str, ...]]  # World index -> exit lanes to solve for
    choice_age: Mapping[str, int]  # vehicle id -> control steps since its exit lane was decided


def lane_options(world: World, relations: Relations, movements: Movements,
                 previous: Mapping[str, str], choice_age: Mapping[str, int],
                 lane_choice_period: int) -> LaneOptions:
    """Per vehicle, the exit lanes whose choice changes whom it interacts with (module docstring).

    ``previous``: vehicle id -> exit lane chosen at the last step; ``choice_age``: the clock of
    the last step, returned advanced (a vehicle whose choice does not matter keeps its age).
    """
    ages = dict(choice_age)
    out = {}
    for k, by_option in _partners(relations).items():
        opts = tuple(by_option)
        vid = world.ids[k]
        last = previous.get(vid)
        if len(opts) > 1 and len(set(by_option.values())) == 1:
            opts = (last if last in by_option else movements.preferred(world.path_ids[k]),)
        elif len(opts) > 1:
            age = ages.get(vid)
            if age is not None and age + 1 < lane_choice_period and last in by_option:
                opts = (last,)  # hold the last choice between decisions
                ages[vid] = age + 1
            else:
                ages[vid] = 0
        out[k] = opts
    return LaneOptions(out, ages)


def _partners(relations: Relations) -> dict[int, dict[str, tuple | None]]:
    """World index -> exit lane -> (lateral partners, leader) of that row; None for the one row
    of a vehicle without a choice (nothing compares it). Only pairs with a row of a choosing
    vehicle are walked in Python: the step's cost grows with those, not with all live pairs."""
    rows, pairs = relations.rows, relations.pairs
    vehicle = np.asarray(rows.vehicle)
    choosing = np.bincount(vehicle, minlength=int(vehicle.max()) + 1)[vehicle] > 1 if len(vehicle) else \
        np.zeros(0, bool)  # per row: its vehicle has more than one row
    partners: dict[int, set] = {r: set() for r in np.flatnonzero(choosing).tolist()}
    live = pairs.live
    ri, rj = pairs.ri[live], pairs.rj[live]
    m = choosing[ri] | choosing[rj]
    ri, rj = ri[m], rj[m]
    for a, b, ka, kb in zip(ri.tolist(), rj.tolist(), vehicle[ri].tolist(), vehicle[rj].tolist()):
        if a in partners:
            partners[a].add(kb)
        if b in partners:
            partners[b].add(ka)
    sig: dict[int, dict[str, tuple | None]] = {}
    for r, k in enumerate(vehicle.tolist()):
        if r not in partners:
            sig.setdefault(k, {})[rows.option[r]] = None
            continue
        lead = relations.leaders.get(r)
        sig.setdefault(k, {})[rows.option[r]] = (frozenset(partners[r]), lead.vehicle if lead else None)
    return sig


@functools.lru_cache(maxsize=2)
def _read_net(net_file: str):
    """The sumolib net of ``net_file`` (no internal lanes), read once for every junction's controller."""
    return sumolib.net.readNet(net_file)


class LaneChangeCosts:
    """J_lk (Eq. 23) of each exit lane of a path: its lateral offset [m] from the movement's
    preferred exit lane, measured on the net's exit edge (the widths of the lanes between the
    two centre lines, read with sumolib)."""

    def __init__(self, movements: Movements, model: ModelSettings):
        net = _read_net(str(movements.net_file))
        self._lane = {}  # exit lane id -> (edge id, lane index)
        self._widths = {}  # exit edge id -> [m] width of each of its lanes, by index
        for path in movements.paths.values():
            lane = net.getLane(path.lanes[-1])
            edge = lane.getEdge()
            self._lane[lane.getID()] = (edge.getID(), lane.getIndex())
            self._widths[edge.getID()] = [ln.getWidth() for ln in edge.getLanes()]
        self._movements = movements
        self._model = model

    def offset(self, path_id: str, option: str) -> float:
        """[m] lateral distance between the centre lines of the preferred exit lane of
        ``path_id``'s movement and of exit lane ``option``."""
        m = self._movements
        edge, ia = self._lane[m.paths[m.sibling(path_id, m.preferred(path_id))].lanes[-1]]
        _, ib = self._lane[m.paths[m.sibling(path_id, option)].lanes[-1]]
        lo, hi = sorted((ia, ib))
        if lo == hi:
            return 0.0
        widths = self._widths[edge][lo:hi + 1]
        return (widths[0] + widths[-1]) / 2.0 + sum(widths[1:-1])

    def costs(self, path_id: str, options: tuple[str, ...]) -> dict[str, float]:
        """J_lk of each of ``options``."""
        return {o: lane_change_cost(self.offset(path_id, o), self._model) for o in options}
