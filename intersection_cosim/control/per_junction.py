"""One controller per managed junction: split the World by junction, merge the Decisions.

:class:`PerJunction` composes controllers of one kind (made by the registry's factory), one per
managed junction of the run's movements. Each gets a ControlContext with its own junction's
movements (:func:`~intersection_cosim.network.by_junction.junction_movements`) and, every step,
the sub-World of the vehicles whose movement path crosses its junction (:meth:`PerJunction.split`):
a vehicle belongs to one junction at a time, the one whose path it is on. The simulator adapter
moves a vehicle onto the next junction's path when it comes within that junction's control
range, so a vehicle in two ranges at once belongs to the junction it reaches first; between the
ranges SUMO drives it. The step scheduler (``sim.network_scheduler``) times each junction's
controller against its own budget; :meth:`decide` runs them all under one deadline for callers
without a scheduler. With one managed junction the one controller sees the World unchanged.
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np

from intersection_cosim.control.base import ControlContext, Controller, Decisions, Diagnostics, Guest, World
from intersection_cosim.network.by_junction import junction_movements, path_junction


def sub_world(world: World, keep: list[int], guests: list[tuple[int, Guest]] = ()) -> World:
    """The World of the vehicles at indices ``keep`` (in their order) and, after them, the
    ``guests`` (the index of each guest's own row, the Guest): a guest row is its vehicle on the
    other junction's path, flagged ``World.guest``; ``world`` itself if all and no guest."""
    if len(keep) == len(world) and not guests and not world.guests:
        return world
    return _with_guests(world.subset([*keep, *(k for k, _ in guests)]), len(keep), guests)


def _with_guests(part: World, n: int, guests: list[tuple[int, Guest]]) -> World:
    """``part`` (its first ``n`` rows a junction's own vehicles, then one row per guest) with the
    guest rows moved onto the other junction's path and flagged (:func:`sub_world`)."""
    if not guests:
        return dataclasses.replace(part, guests=())
    path_ids, s, role = list(part.path_ids), part.s.copy(), list(part.role)
    exits = dict(part.exit_choices)
    for i, (_, g) in enumerate(guests, start=n):
        path_ids[i], s[i], role[i] = g.path, s[i] + g.offset, g.role
        exits[g.vehicle] = ()
    flag = np.zeros(len(path_ids), bool)
    flag[n:] = True
    return dataclasses.replace(part, path_ids=path_ids, s=s, role=role, exit_choices=exits, guest=flag, guests=())


def merge_decisions(parts: dict[str, Decisions], worlds: dict[str, World], alone: bool | None = None) -> Decisions:
    """The Decisions of every junction as one, each vehicle's ``owner`` the junction that decided
    it: a vehicle one junction releases because it is now on another junction's path (in that
    junction's sub-World) is not released. The Decisions of a run's one junction (``alone``;
    None: ``parts`` has one entry) are returned as they are (with their owner filled in);
    ``parts`` may leave out junctions that decided nothing (the network scheduler's skipped ones)."""
    for j, d in parts.items():
        d.owner.update({vid: j for vid in (*d.accel, *d.release)})
    if (len(parts) == 1 if alone is None else alone) and parts:
        return next(iter(parts.values()))
    merged = Decisions()
    owner = {vid: j for j, w in worlds.items() for vid in w.ids}
    notes = []
    for j, d in parts.items():
        merged.accel.update(d.accel)
        merged.exit_lane.update(d.exit_lane)
        merged.signals.update(d.signals)
        merged.release.extend(vid for vid in d.release if owner.get(vid, j) == j)
        merged.owner.update({vid: j for vid in d.accel})
        merged.owner.update({vid: j for vid in d.release if owner.get(vid, j) == j})
        merged.games += d.games
        merged.iterations += d.iterations
        merged.pairs.extend(d.pairs)
        merged.kept.extend(d.kept)
        merged.deferred += d.deferred
        merged.qp_solves += d.qp_solves
        merged.fallback = merged.fallback or d.fallback
        if d.note:
            notes.append(f"{j}: {d.note}")
    merged.release.sort()
    for d in parts.values():  # a guest's caps bound its owner's decision
        for vid, cap in d.caps.items():
            if vid in merged.accel and cap < merged.accel[vid]:
                merged.accel[vid] = cap
    merged.note = "; ".join(notes)
    return merged


def merge_diagnostics(parts: list[Diagnostics]) -> Diagnostics:
    """The run's Diagnostics over every junction's controller (games in junction order)."""
    def total(name: str) -> int | None:
        values = [getattr(d, name) for d in parts]
        return None if all(v is None for v in values) else sum(v or 0 for v in values)

    conv = [d.convergence for d in parts]
    convergence = None if all(c is None for c in conv) else tuple(r for c in conv for r in (c or ()))
    clu = [d.clusters for d in parts]
    clusters = None if all(c is None for c in clu) else tuple(r for c in clu for r in (c or ()))
    return Diagnostics(convergence, total("safety_interventions"), total("box_rule_clearances"),
                       total("pedestrian_holds"), clusters)


class PerJunction:
    """Controllers of one kind, one per managed junction (see the module docstring).

    ``factory`` makes a new controller; the first one made tells the junction type and whether
    the kind commands vehicles.
    """

    def __init__(self, factory: Callable[[], Controller]):
        self._factory = factory
        self._first: Controller | None = factory()
        self.junction_type = self._first.junction_type
        self.controls_vehicles = self._first.controls_vehicles
        self.yields_to_pedestrians = self._first.yields_to_pedestrians
        # (net file, junctions) -> an <additional> SUMO loads for the run (a signal programme), if the kind has one
        self.signal_additional = getattr(self._first, "signal_additional", None)
        self.parts: dict[str, Controller] = {}  # junction id -> its controller, after setup
        self._movements = None
        self._junction_of: dict[str, str] = {}  # path id -> the managed junction it crosses

    def setup(self, context: ControlContext) -> None:
        self._movements = context.movements
        self._junction_of = {pid: path_junction(context.movements, pid) for pid in context.movements.paths}
        self.parts = {}
        for j in context.movements.junctions:
            part = self._first if self._first is not None else self._factory()
            self._first = None
            part.setup(dataclasses.replace(context, movements=junction_movements(context.movements, j)))
            self.parts[j] = part

    def split(self, world: World) -> dict[str, World]:
        """The sub-World of each junction (every junction, maybe empty), by the vehicles' paths."""
        if len(self.parts) == 1:
            return {next(iter(self.parts)): world}
        occupied = self.split_occupied(world)
        empty = world.subset([]) if len(occupied) < len(self.parts) else None
        return {j: occupied[j] if j in occupied else dataclasses.replace(empty, guests=()) for j in self.parts}

    def split_occupied(self, world: World) -> dict[str, World]:
        """The sub-Worlds of the junctions with at least one vehicle (its own or a guest), in the
        junctions' order; with one managed junction, that junction's World whatever it holds.
        One pass over the vehicles for the whole network: a junction without any costs nothing."""
        if len(self.parts) == 1:
            return {next(iter(self.parts)): world}
        keep: dict[str, list[int]] = {}
        for k, pid in enumerate(world.path_ids):
            keep.setdefault(self._junction_of[pid], []).append(k)
        guests: dict[str, list[tuple[int, Guest]]] = {}
        if world.guests:
            index = {vid: k for k, vid in enumerate(world.ids)}
            for g in world.guests:
                if g.vehicle in index:
                    guests.setdefault(self._junction_of[g.path], []).append((index[g.vehicle], g))
        occupied = [j for j in self.parts if j in keep or j in guests]
        rows = [[*keep.get(j, []), *(k for k, _ in guests.get(j, []))] for j in occupied]
        return {j: _with_guests(part, len(keep.get(j, [])), guests.get(j, []))
                for j, part in zip(occupied, world.subsets(rows))}

    def decide(self, world: World, deadline: float) -> Decisions:
        worlds = self.split(world)
        return merge_decisions({j: self.parts[j].decide(w, deadline) for j, w in worlds.items()}, worlds)

    def fallback(self, world: World) -> Decisions:
        worlds = self.split(world)
        merged = merge_decisions({j: self.parts[j].fallback(w) for j, w in worlds.items()}, worlds)
        merged.fallback = True
        return merged

    def diagnostics(self) -> Diagnostics:
        return merge_diagnostics([p.diagnostics() for p in self.parts.values()])
