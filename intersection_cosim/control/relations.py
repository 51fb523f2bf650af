"""The relations of one control step: who may take which exit lane, who follows whom, which pairs
of vehicles cross or merge and which of those play a game (the ETM, paper Eqs. 9 and 39).

:func:`step_relations` builds them once per step from the World and the conflict table, as one
frozen :class:`Relations` value that the rest of the step (lane options, games, solo planning,
the safety filter) reads and never changes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, NamedTuple

import numpy as np

from intersection_cosim.control.base import World
from intersection_cosim.models.prediction import all_pairs
from intersection_cosim.models.risk import event_trigger
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.conflicts import (KIND_CONFLUENCE, KIND_CROSS, KIND_FOLLOWING, ConflictTable,
                                                  point_zone)
from intersection_cosim.network.movements import Movements


@dataclass(frozen=True)
class Rows:
    """The ETM's rows: one per (vehicle, exit lane it may take)."""

    vehicle: np.ndarray  # (R,) index into the World
    option: tuple[str, ...]  # exit lane of the row
    path: tuple[str, ...]  # path id of the row
    pidx: np.ndarray  # (R,) index of the row's path in the conflict table

    def __len__(self) -> int:
        return len(self.option)


class Leader(NamedTuple):
    """The nearest vehicle ahead of a row on a shared stretch (same approach lane, or a
    confluence after the merge)."""

    vehicle: int  # World index of the leader
    offset: float  # [m] leader's s in the follower's path = s_leader + offset
    gap: float  # [m] distance along the shared stretch (front to front)
    until: float = math.inf  # [m] leader's s (own path) past which it no longer constrains the
    #                          follower: the end of a diverging shared stretch plus a length


class Lateral(NamedTuple):
    """A cross or confluence pair of rows that has not cleared its crossing."""

    ri: int
    rj: int
    kind: str  # "cross" | "confluence"
    s_i: float  # [m] conflict point on row ri's path
    s_j: float  # [m] conflict point on row rj's path
    live: bool  # neither has passed the point by conflict_clearance: J_lat applies, games may run
    play: bool  # live and triggered (or the ETM is off): the pair plays a game this step
    zone_i: tuple[float, float]  # [m] front arc lengths on ri's path over which it occupies the crossing
    zone_j: tuple[float, float]  # [m] the same on rj's path


@dataclass(frozen=True)
class Relations:
    """Everything of one step that depends on the vehicles' positions relative to each other."""

    rows: Rows
    leaders: Mapping[int, Leader]  # row -> its nearest leader
    lateral: tuple[Lateral, ...]
    row_of: Mapping[tuple[int, str], int]  # (World index, exit lane) -> row

    def triggered_pairs(self) -> frozenset[tuple[int, int]]:
        """(a, b) with a < b, World indices of the vehicle pairs that play a game this step."""
        vehicle = self.rows.vehicle
        return frozenset(tuple(sorted((int(vehicle[lat.ri]), int(vehicle[lat.rj]))))
                         for lat in self.lateral if lat.play)

    def leader_of(self, k: int, option: str) -> Leader | None:
        return self.leaders.get(self.row_of[(k, option)])


def build_rows(world: World, active: set[int], movements: Movements, table: ConflictTable,
               held: Mapping[str, str], lane_choice_range: float) -> Rows:
    """One row per exit lane a vehicle may still take; a vehicle farther than
    ``lane_choice_range`` [m] from its stop line has one row, the exit lane it holds (``held``:
    vehicle id -> exit lane chosen at the last step)."""
    paths = movements.paths
    vehicle, option, path = [], [], []
    for k in range(len(world)):
        pid = world.path_ids[k]
        opts = world.exit_choices.get(world.ids[k], ()) if k in active else ()
        if len(opts) > 1:
            if paths[pid].s_stop - float(world.s[k]) > lane_choice_range:
                kept = held.get(world.ids[k], paths[pid].exit_lane)
                opts = (kept if kept in opts else opts[0],)  # too far out to choose yet
            for o in opts:
                vehicle.append(k)
                option.append(o)
                path.append(movements.sibling(pid, o))
        else:
            vehicle.append(k)
            option.append(paths[pid].exit_lane)
            path.append(pid)
    return Rows(np.asarray(vehicle, dtype=np.intp), tuple(option), tuple(path), table.indices(path))


def step_relations(world: World, active: set[int], movements: Movements, table: ConflictTable,
                   model: ModelSettings, etm: bool, held: Mapping[str, str],
                   lane_choice_range: float) -> Relations:
    """The step's rows, leaders and lateral pairs (ETM on or off)."""
    rows = build_rows(world, active, movements, table, held, lane_choice_range)
    leaders, lateral = _pair_relations(world, rows, active, table, model, etm)
    row_of = {(int(k), o): r for r, (k, o) in enumerate(zip(rows.vehicle, rows.option))}
    return Relations(rows, leaders, tuple(lateral), row_of)


def _pair_relations(world: World, rows: Rows, active: set[int], table: ConflictTable, model: ModelSettings,
                    etm: bool) -> tuple[dict[int, Leader], list[Lateral]]:
    """Leaders of every row and the lateral (cross / confluence) row pairs, from the ETM.

    A lateral pair stays in the list until one of the two has cleared the crossing (its front
    past ``zone_out`` of the conflict table, for confluence pairs the point plus a vehicle
    length and half a width), so the safety filter guards it that long; it carries J_lat and
    may play a game only while neither is more than ``conflict_clearance`` past the point.
    """
    i, j = all_pairs(len(rows))
    keep = rows.vehicle[i] != rows.vehicle[j]
    k_of, pidx = rows.vehicle, rows.pidx
    risk = event_trigger(table, pidx, world.s[k_of], world.v[k_of], world.kappa[k_of], model,
                         pairs=(i[keep], j[keep]))
    s_now = (world.s[k_of[risk.i]], world.s[k_of[risk.j]])
    d = (risk.s_cp_i - s_now[0], risk.s_cp_j - s_now[1])
    leaders: dict[int, Leader] = {}
    lateral: list[Lateral] = []
    for m in range(len(risk.i)):
        if risk.leader_follower[m]:
            _add_leader(leaders, risk, m, d, k_of, model.conflict_clearance)
        elif risk.kind[m] in (KIND_CROSS, KIND_CONFLUENCE):
            lat = _lateral(risk, m, d, s_now, k_of, active, table, pidx, model, etm)
            if lat is not None:
                lateral.append(lat)
    return leaders, lateral


def _add_leader(leaders: dict[int, Leader], risk, m: int, d, k_of: np.ndarray, clear: float) -> None:
    """Record pair ``m`` (a leader-follower pair of the ETM) if it is the follower's nearest."""
    ri, rj = int(risk.i[m]), int(risk.j[m])
    d_i, d_j = d[0][m], d[1][m]
    if min(d_i, d_j) < -clear and risk.kind[m] != KIND_CONFLUENCE:
        return  # the leader has left the shared stretch
    lead, follow = (ri, rj) if d_i < d_j else (rj, ri)
    s_cp_f = risk.s_cp_i[m] if follow == ri else risk.s_cp_j[m]
    s_cp_l = risk.s_cp_j[m] if follow == ri else risk.s_cp_i[m]
    gap = abs(d_i - d_j)
    if follow in leaders and leaders[follow].gap <= gap:
        return
    # two paths from one approach lane that part (s_cp = end of the shared stretch, where the
    # centre lines are a width apart): once the leader's rear is past it, the follower may draw
    # level on its own branch (Case 2's V3 beside V4)
    until = s_cp_l + clear if risk.kind[m] == KIND_FOLLOWING else math.inf
    leaders[follow] = Leader(int(k_of[lead]), float(s_cp_f - s_cp_l), float(gap), float(until))


def _lateral(risk, m: int, d, s_now, k_of: np.ndarray, active: set[int], table: ConflictTable,
             pidx: np.ndarray, model: ModelSettings, etm: bool) -> Lateral | None:
    """Pair ``m`` as a lateral pair, or None when neither is controlled or one has cleared it."""
    ri, rj = int(risk.i[m]), int(risk.j[m])
    both = k_of[ri] in active and k_of[rj] in active
    if not both and k_of[ri] not in active and k_of[rj] not in active:
        return None
    s_i, s_j = float(risk.s_cp_i[m]), float(risk.s_cp_j[m])
    if risk.kind[m] == KIND_CROSS:
        kind = "cross"
        p_i, p_j = pidx[ri], pidx[rj]
        zone_i = (float(table.zone_in[p_i, p_j]), float(table.zone_out[p_i, p_j]))
        zone_j = (float(table.zone_in[p_j, p_i]), float(table.zone_out[p_j, p_i]))
    else:
        kind = "confluence"
        length, width = model.vehicle_length, model.vehicle_width
        zone_i, zone_j = point_zone(s_i, length, width), point_zone(s_j, length, width)
    if s_now[0][m] > zone_i[1] or s_now[1][m] > zone_j[1]:
        return None  # one of them has cleared the crossing
    # a vehicle that has left the junction (front past its exit, handed back to SUMO) may still
    # have its rear in the crossing: guarded, no game
    clear = model.conflict_clearance
    live = both and not (d[0][m] < -clear or d[1][m] < -clear)
    play = live and (bool(risk.trigger[m]) or not etm)
    return Lateral(ri, rj, kind, s_i, s_j, live, play, zone_i, zone_j)
