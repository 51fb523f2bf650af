"""The relations of one control step: who may take which exit lane, who follows whom, which pairs
of vehicles cross or merge and which of those play a game (the ETM, paper Eqs. 9 and 39).

:func:`step_relations` builds them once per step from the World and the conflict table, as one
frozen :class:`Relations` value that the rest of the step (lane options, games, solo planning,
the safety filter) reads and never changes.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import Mapping, NamedTuple

import numpy as np

from intersection_cosim.control.base import World
from intersection_cosim.models.prediction import all_pairs
from intersection_cosim.models.risk import event_trigger
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.conflicts import KIND_CONFLUENCE, KIND_CROSS, KIND_FOLLOWING, ConflictTable
from intersection_cosim.network.conflict_zones import point_zone
from intersection_cosim.network.movements import READY, Movements


@dataclass(frozen=True)
class Rows:
    """The ETM's rows: one per (vehicle, exit lane it may take)."""

    vehicle: np.ndarray  # (R,) index into the World
    option: tuple[str, ...]  # exit lane of the row
    path: tuple[str, ...]  # path id of the row
    pidx: np.ndarray  # (R,) index of the row's path in the conflict table
    speed_cap: np.ndarray | None = None  # (R,) [m/s] the lane speed limit in force (inf: none;
    #                                      None: ModelSettings.lane_speed_limits off)

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
    merge: bool = False  # a confluence: the leader came from another lane and may still be
    #                      turning in, its body off the follower's path (SafetyFilter._leader_caps)


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
class LateralPairs:
    """The step's lateral pairs as columns, one entry per pair in the ETM's order (what the
    step's consumers select from with numpy; :meth:`at` gives one as a :class:`Lateral`)."""

    ri: np.ndarray  # (L,) row of the first vehicle
    rj: np.ndarray  # (L,) row of the second
    cross: np.ndarray  # (L,) bool: a cross pair (else a confluence pair)
    s_i: np.ndarray  # (L,) [m] conflict point on row ri's path
    s_j: np.ndarray  # (L,) [m] ... on row rj's path
    live: np.ndarray  # (L,) bool, as Lateral.live
    play: np.ndarray  # (L,) bool, as Lateral.play
    zone_i: np.ndarray  # (L, 2) [m] as Lateral.zone_i
    zone_j: np.ndarray  # (L, 2) [m] as Lateral.zone_j
    human: np.ndarray | None = None  # (L,) bool: a controlled vehicle and a human driver, neither
    #                                  past the point by conflict_clearance, triggered (or the ETM off):
    #                                  the human's predicted trajectory enters the other's J_lat
    human_j: np.ndarray | None = None  # (L,) bool: the human is row rj's vehicle (else ri's)

    def __len__(self) -> int:
        return len(self.ri)

    def at(self, m: int) -> Lateral:
        """Pair ``m`` as a :class:`Lateral` (Python scalars)."""
        return Lateral(int(self.ri[m]), int(self.rj[m]), "cross" if self.cross[m] else "confluence",
                       float(self.s_i[m]), float(self.s_j[m]), bool(self.live[m]), bool(self.play[m]),
                       (float(self.zone_i[m, 0]), float(self.zone_i[m, 1])),
                       (float(self.zone_j[m, 0]), float(self.zone_j[m, 1])))


_NONE_F = np.zeros(0)
_NONE_B = np.zeros(0, bool)
NO_PAIRS = LateralPairs(np.zeros(0, np.intp), np.zeros(0, np.intp), _NONE_B, _NONE_F, _NONE_F, _NONE_B, _NONE_B,
                        np.zeros((0, 2)), np.zeros((0, 2)), _NONE_B, _NONE_B)  # the step has no lateral pair
for _a in (_NONE_F, _NONE_B, *NO_PAIRS.__dict__.values()):
    _a.setflags(write=False)


@dataclass(frozen=True)
class Relations:
    """Everything of one step that depends on the vehicles' positions relative to each other."""

    rows: Rows
    leaders: Mapping[int, Leader]  # row -> its nearest leader
    pairs: LateralPairs  # the lateral pairs as columns
    row_of: Mapping[tuple[int, str], int]  # (World index, exit lane) -> row

    @functools.cached_property
    def human_crossings(self) -> Mapping[int, tuple[tuple[int, float, float], ...]]:
        """Row -> its crossings with human drivers that enter its J_lat as fixed trajectories:
        (the human's World index, the point on the row's path [m], on the human's path [m]) for
        each lateral pair marked ``human`` (built on first use)."""
        p, vehicle = self.pairs, self.rows.vehicle
        out: dict[int, list] = {}
        for m in np.flatnonzero(p.human) if p.human is not None else ():
            ri, rj, s_i, s_j = int(p.ri[m]), int(p.rj[m]), float(p.s_i[m]), float(p.s_j[m])
            own, other = (ri, rj) if p.human_j[m] else (rj, ri)
            s_own, s_other = (s_i, s_j) if p.human_j[m] else (s_j, s_i)
            out.setdefault(own, []).append((int(vehicle[other]), s_own, s_other))
        return {r: tuple(v) for r, v in out.items()}

    @functools.cached_property
    def lateral(self) -> tuple[Lateral, ...]:
        """The lateral pairs, one :class:`Lateral` each (built on first use)."""
        p = self.pairs
        cols = [x.tolist() for x in (p.ri, p.rj, p.cross, p.s_i, p.s_j, p.live, p.play)]
        zones = [list(map(tuple, z.tolist())) for z in (p.zone_i, p.zone_j)]
        return tuple(Lateral(a, b, "cross" if c else "confluence", si, sj, lv, pl, zi, zj)
                     for a, b, c, si, sj, lv, pl, zi, zj in zip(*cols, *zones))

    def pair_vehicles(self) -> tuple[np.ndarray, np.ndarray]:
        """(L,), (L,): World indices (lower, higher) of each lateral pair's two vehicles."""
        vehicle = self.rows.vehicle
        a, b = vehicle[self.pairs.ri], vehicle[self.pairs.rj]
        return np.minimum(a, b), np.maximum(a, b)

    def triggered_pairs(self) -> frozenset[tuple[int, int]]:
        """(a, b) with a < b, World indices of the vehicle pairs that play a game this step."""
        lo, hi = self.pair_vehicles()
        play = self.pairs.play
        return frozenset(zip(lo[play].tolist(), hi[play].tolist()))

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


def lane_speed_caps(world: World, rows: Rows, movements: Movements, model: ModelSettings) -> np.ndarray:
    """(R,) [m/s] per row the lane speed limit in force on its path where its vehicle is
    (MovementPath.speed_limit_ahead), inf where none is below the vehicle's desired speed."""
    caps = np.full(len(rows), np.inf)
    for r, (k, pid) in enumerate(zip(rows.vehicle.tolist(), rows.path)):
        own = world.desired_speed_of(k)
        want = model.v_max if own is None else own  # [m/s]
        cap = movements.paths[pid].speed_limit_ahead(float(world.s[k]), want, model.lane_speed_decel)
        if cap < want:
            caps[r] = cap
    return caps


@dataclass(frozen=True)
class TriggerHold:
    """The ETM's hysteresis (PolicySettings.trigger_hold_gap): the vehicle-id pairs (sorted) that
    played their game at the last step keep playing while their times to the conflict point
    (TCP, Eqs. 21-22) differ by less than ``gap`` [s]."""

    pairs: frozenset[tuple[str, str]]
    gap: float  # [s]


def step_relations(world: World, active: set[int], movements: Movements, table: ConflictTable,
                   model: ModelSettings, etm: bool, held: Mapping[str, str],
                   lane_choice_range: float, events: frozenset[tuple[str, str]] = frozenset(),
                   hold: TriggerHold | None = None) -> Relations:
    """The step's rows, leaders and lateral pairs (ETM on or off). ``events``: vehicle-id pairs
    (sorted) that play their game whatever Gamma_cp says (the safety filter had to hold one of
    them back for the other: control/game/controller.py); ``hold``: the ETM's hysteresis (:class:`TriggerHold`)."""
    rows = build_rows(world, active, movements, table, held, lane_choice_range)
    if model.lane_speed_limits:
        rows = dataclasses.replace(rows, speed_cap=lane_speed_caps(world, rows, movements, model))
    leaders, lateral = _pair_relations(world, rows, active, table, model, etm, events, hold)
    row_of = {(int(k), o): r for r, (k, o) in enumerate(zip(rows.vehicle, rows.option))}
    return Relations(rows, leaders, lateral, row_of)


def _pair_relations(world: World, rows: Rows, active: set[int], table: ConflictTable, model: ModelSettings,
                    etm: bool, events: frozenset[tuple[str, str]] = frozenset(),
                    hold: TriggerHold | None = None) -> tuple[dict[int, Leader], LateralPairs]:
    """Leaders of every row and the lateral (cross / confluence) row pairs, from the ETM.

    A lateral pair stays in the list until one of the two has cleared the crossing (its front
    past ``zone_out`` of the conflict table, for confluence pairs the point plus a vehicle
    length and half a width), so the safety filter guards it that long; it carries J_lat and
    may play a game only while neither is more than ``conflict_clearance`` past the point.
    Vectorised over the ETM's pairs: the cost of a step grows with the pairs that matter, not
    with a Python loop over every pair.
    """
    i, j = all_pairs(len(rows))
    keep = rows.vehicle[i] != rows.vehicle[j]
    if not keep.any():  # one vehicle (most junctions of a city, most steps): no pair to relate
        return {}, NO_PAIRS
    k_of, pidx = rows.vehicle, rows.pidx
    risk = event_trigger(table, pidx, world.s[k_of], world.v[k_of], world.kappa[k_of], model,
                         pairs=(i[keep], j[keep]))
    s_now = (world.s[k_of[risk.i]], world.s[k_of[risk.j]])
    d = (risk.s_cp_i - s_now[0], risk.s_cp_j - s_now[1])
    bodies = (world.lengths(model.vehicle_length), world.widths(model.vehicle_width))  # [m] per World index
    leaders = _leaders(risk, d, k_of, model.conflict_clearance, bodies[0], world.guest)
    forced = _event_pairs(risk, k_of, world.ids, events)
    if hold is not None and hold.pairs:
        kept = _event_pairs(risk, k_of, world.ids, hold.pairs) & (np.abs(risk.tcp_i - risk.tcp_j) < hold.gap)
        forced = kept if forced is None else forced | kept
    lateral = _laterals(risk, d, s_now, k_of, active, table, pidx, model, etm, bodies, world.observed(), forced,
                        approaching_guests(world))
    return leaders, lateral


def _event_pairs(risk, k_of: np.ndarray, ids, events: frozenset[tuple[str, str]]) -> np.ndarray | None:
    """(len(risk.i),) bool: the ETM's pairs named in ``events`` (sorted vehicle-id pairs); None
    when there are none."""
    if not events:
        return None
    return named_pairs(ids, events, k_of[risk.i], k_of[risk.j])


def named_pairs(ids, names, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(len(a),) bool: whether the vehicle pair (a[m], b[m]) (World indices) is one of ``names``
    (vehicle-id pairs, in either order). Each pair is one integer, lower index * n + higher,
    matched with numpy instead of a Python loop over the pairs (thousands in a jam)."""
    index = {vid: k for k, vid in enumerate(ids)}
    n = len(ids)
    named = [(index[x], index[y]) for x, y in names if x in index and y in index]  # vehicles still there
    keys = np.fromiter((min(p) * n + max(p) for p in named), np.int64, len(named))
    a, b = np.asarray(a, np.int64), np.asarray(b, np.int64)
    return np.isin(np.minimum(a, b) * n + np.maximum(a, b), keys)


def _leaders(risk, d, k_of: np.ndarray, clear: float, length: np.ndarray,
             guest: np.ndarray | None = None) -> dict[int, Leader]:
    """Each follower row's nearest leader among the ETM's leader-follower pairs (the first such
    pair in the ETM's order on equal gaps), keyed in the order the followers first appear.

    A following pair whose leader has left the shared stretch (more than ``clear`` [m], or the
    longer vehicle's ``length`` [m] per World index, past its end) gives no leader, and neither
    does one of two guests (``guest``: bool per World index): each guest's position on the path
    is measured along its own route to the path's start, so two guests coming from different
    lanes of the junction before are put on one lane they have not reached, in an order their
    merge there (their owner's to guard) has not decided."""
    d_i, d_j = d
    clear_m = np.maximum(clear, np.maximum(length[k_of[risk.i]], length[k_of[risk.j]]))  # [m] per pair
    gone = (np.minimum(d_i, d_j) < -clear_m) & (risk.kind != KIND_CONFLUENCE)
    if guest is not None:
        gone |= guest[k_of[risk.i]] & guest[k_of[risk.j]] & (risk.kind == KIND_FOLLOWING)
    m = np.flatnonzero(risk.leader_follower & ~gone)
    if len(m) == 0:
        return {}
    i_leads = d_i[m] < d_j[m]
    follow = np.where(i_leads, risk.j[m], risk.i[m])
    lead = np.where(i_leads, risk.i[m], risk.j[m])
    s_cp_f = np.where(i_leads, risk.s_cp_j[m], risk.s_cp_i[m])  # [m] the point on the follower's path
    s_cp_l = np.where(i_leads, risk.s_cp_i[m], risk.s_cp_j[m])  # [m] ... on the leader's path
    gap = np.abs(d_i[m] - d_j[m])  # [m]
    # two paths from one approach lane that part (s_cp = end of the shared stretch, where the
    # centre lines are a width apart): once the leader's rear is past it, the follower may draw
    # level on its own branch (Case 2's V3 beside V4)
    until = np.where(risk.kind[m] == KIND_FOLLOWING, s_cp_l + clear_m[m], math.inf)  # [m]
    by_gap = np.lexsort((np.arange(len(m)), gap, follow))  # per follower: smallest gap, then first
    sorted_follow = follow[by_gap]
    firsts = by_gap[np.concatenate(([True], sorted_follow[1:] != sorted_follow[:-1]))]  # by follower
    _, first_seen = np.unique(follow, return_index=True)  # by follower too
    firsts = firsts[np.argsort(first_seen)]
    offset = (s_cp_f - s_cp_l)[firsts]
    merge = risk.kind[m] == KIND_CONFLUENCE
    return {int(f): Leader(int(v), float(o), float(g), float(u), bool(c)) for f, v, o, g, u, c in zip(
        follow[firsts], k_of[lead[firsts]], offset, gap[firsts], until[firsts], merge[firsts])}


def _zones(table: ConflictTable, p: tuple[np.ndarray, np.ndarray], s_cp: tuple[np.ndarray, np.ndarray],
           cross: np.ndarray, k: tuple[np.ndarray, np.ndarray], bodies: tuple[np.ndarray, np.ndarray]):
    """[m] ((in, out) on i's path, (in, out) on j's path) per lateral pair: for cross pairs the
    conflict table's body-overlap zone of the two vehicles' own bodies (``bodies``: per World
    index, length and width [m]; the table's arrays where both have the table's body), for
    confluence pairs the point plus a length (the wider body's half width either side)."""
    (p_i, p_j), (s_i, s_j), (k_i, k_j) = p, s_cp, k
    length, width = bodies
    wide = np.maximum(width[k_i], width[k_j])  # [m]
    conf_i, conf_j = point_zone(s_i, length[k_i], wide), point_zone(s_j, length[k_j], wide)
    zone_i = [np.where(cross, table.zone_in[p_i, p_j], conf_i[0]), np.where(cross, table.zone_out[p_i, p_j], conf_i[1])]
    zone_j = [np.where(cross, table.zone_in[p_j, p_i], conf_j[0]), np.where(cross, table.zone_out[p_j, p_i], conf_j[1])]
    own = (length[k_i] == table.body[0]) & (width[k_i] == table.body[1]) & \
        (length[k_j] == table.body[0]) & (width[k_j] == table.body[1])
    for m in np.flatnonzero(cross & ~own):  # a pair of other size classes: their own bodies' zones
        bi = (float(length[k_i[m]]), float(width[k_i[m]]))
        bj = (float(length[k_j[m]]), float(width[k_j[m]]))
        zone_i[0][m], zone_i[1][m] = table.zone(int(p_i[m]), int(p_j[m]), bi, bj)
        zone_j[0][m], zone_j[1][m] = table.zone(int(p_j[m]), int(p_i[m]), bj, bi)
    return tuple(zone_i), tuple(zone_j)


def approaching_guests(world: World) -> np.ndarray:
    """(n,) bool: the guests coming towards this junction (World.guest, role ready): vehicles other
    junctions command that this one must keep apart, from each other too, by capping them."""
    if world.guest is None:
        return np.zeros(len(world.ids), bool)
    return world.guest & (np.asarray(world.role, dtype=object) == READY)


def _laterals(risk, d, s_now, k_of: np.ndarray, active: set[int], table: ConflictTable,
              pidx: np.ndarray, model: ModelSettings, etm: bool,
              bodies: tuple[np.ndarray, np.ndarray], human: np.ndarray | None,
              events: np.ndarray | None = None, coming: np.ndarray | None = None) -> LateralPairs:
    """The ETM's cross and confluence pairs as lateral pairs: those with a controlled vehicle, or
    of two guests coming towards the junction (``coming``: bool per World vehicle, see
    :func:`approaching_guests`; two vehicles other junctions command over short links would
    otherwise meet here unguarded), whose two vehicles have not cleared the crossing (in the
    ETM's order). ``human``: bool per World vehicle, a human driver or a guest (None: none);
    ``events``: bool per ETM pair, fired whatever Gamma_cp says (None: none)."""
    is_active = np.zeros(int(k_of.max()) + 1 if len(k_of) else 0, bool)  # by World index
    is_active[[k for k in active if k < len(is_active)]] = True
    row_active = is_active[k_of]
    a_i, a_j = row_active[risk.i], row_active[risk.j]
    lateral_kind = ((risk.kind == KIND_CROSS) | (risk.kind == KIND_CONFLUENCE)) & ~risk.leader_follower
    guests = np.zeros(len(risk.i), bool) if coming is None else coming[k_of[risk.i]] & coming[k_of[risk.j]]
    m = np.flatnonzero(lateral_kind & (a_i | a_j | guests))
    ri, rj = risk.i[m], risk.j[m]
    s_i, s_j = risk.s_cp_i[m], risk.s_cp_j[m]  # [m]
    cross = risk.kind[m] == KIND_CROSS
    p_i, p_j = pidx[ri], pidx[rj]
    zone_i, zone_j = _zones(table, (p_i, p_j), (s_i, s_j), cross, (k_of[ri], k_of[rj]), bodies)
    # one of them has cleared the crossing: dropped. A vehicle that has left the junction (front
    # past its exit, handed back to SUMO) may still have its rear in the crossing: guarded, no game
    kept = ~((s_now[0][m] > zone_i[1]) | (s_now[1][m] > zone_j[1]))
    clear = model.conflict_clearance
    open_ = ~((d[0][m] < -clear) | (d[1][m] < -clear))
    live = a_i[m] & a_j[m] & open_
    fired = risk.trigger[m] | (not etm)
    if events is not None:
        fired = fired | events[m]
    play = live & fired
    h_i, h_j = (np.zeros(len(m), bool),) * 2 if human is None else (human[k_of[ri]], human[k_of[rj]])
    with_human = open_ & fired & ((a_i[m] & h_j) | (a_j[m] & h_i))
    return LateralPairs(ri[kept], rj[kept], cross[kept], s_i[kept], s_j[kept], live[kept], play[kept],
                        np.stack(zone_i, axis=1)[kept], np.stack(zone_j, axis=1)[kept], with_human[kept],
                        h_j[kept])
