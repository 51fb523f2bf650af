"""crossing_order: A vehicle enters a crossing zone only if its planned occupancy of the zone stays
``time_gap`` apart from that of every vehicle ranking ahead of it there, or it can still stop
short of the zone; the rank is a total order (the entry queue inside the junction, then time to
the crossing), so waits cannot form a cycle, and a vehicle is never made to stop inside a zone in
the path of one that cannot yield. A vehicle's zones that overlap, or leave no room to stand
between them, are one block, and a vehicle that can still stop before a crossing's block stays out
of the crossing there: one that waits for a crossing then stands in none of its other crossings,
whose vehicles would have to wait for it whatever the ranks say (a cycle the ranks cannot see).
A vehicle not yet in the junction whose plan reaches into a block is checked against all of the
block's crossings, its plan taken on past the horizon at its final speed (at least
``clear_speed``), so it enters a block only if it need not wait inside it.

Trigger: a guarded crossing (a cross or confluence pair of the rows each vehicle takes, until one
has left its zone) whose two occupancy intervals, by this look's plans (braked and clearing
vehicles' plans replaced; taken on past the horizon as above), come closer than ``time_gap``
(``game_gap_share`` of it for a pair that plays its game this step: its margin is the game's).

Action: the lower-ranked vehicle stays out: it stops ``margin`` before its stop line if it has not
reached it (it enters the junction only to clear it), else before the zone's block if it still can
stop there, else before the zone (``human_margin`` before a human's), and one standing in the
junction inside another of its crossing zones that it can leave short of this one drives out of it
and stands between the two. If it cannot stay out the higher-ranked one does, if it can, and waits
for it (``box_clear`` drives it on if it stands in the zone). Both committed: the lower-ranked one
holds back as hard as it may, unless that would stop it in the crossing while the other is still
coming, or in a human's way: then it drives out. A human is never made to yield (nothing commands
it); it ranks ahead of every AV not yet in the junction, behind those inside. A guest (a vehicle
another managed junction commands, coming over a short link) ranks as an AV not yet in: its cap goes
to its owner. The pair becomes an event of the ETM for the next step (``[controller.policy]
filter_event``).

Setting: ``[controller.safety] time_gap``, ``game_gap_share``, ``margin``, ``human_margin``,
``yield_order``, ``clear_speed``, ``clear_accel``.

Test: tests/control/test_safety_filter.py::test_two_plans_at_a_crossing_together_one_brakes_to_stop_before_it
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from intersection_cosim.control.game.relations import Lateral, named_pairs
from intersection_cosim.control.safety.context import StepContext
from intersection_cosim.control.safety.kinematics import PlanEnds, occupancy, past_horizon, plan_ends, reach_times
from intersection_cosim.control.safety.rules.base import SAFETY, Rule
from intersection_cosim.control.safety.step import FilterStep, Wait

NAME = "crossing_order"
VECTOR_MIN_PAIRS = 16  # [-] guarded pairs from which the first look is vectorised (below it numpy's
#                        fixed cost exceeds the per-pair check's)


class _Crossing(NamedTuple):
    """One vehicle of a guarded pair, as the rule ranks it."""

    rank: tuple
    k: int  # World index
    row: int
    enter: float  # [m] front arc length where its zone starts
    block: float  # [m] ... where the block of its zones holding this one starts (<= enter)


def maybe_close(ctx: StepContext, plans) -> tuple[np.ndarray, tuple | None]:
    """(len(guarded),) bool: False where the plans keep a guarded pair's crossing clear (computed
    for all pairs at once), True where :func:`guard` must look; and the occupancy times (in_i,
    out_i, in_j, out_j) [s] per pair for it (None below ``VECTOR_MIN_PAIRS`` pairs; NaN in_i where
    a plan is unusable)."""
    guarded, world, st = ctx.guarded, ctx.world, ctx.settings
    if len(guarded) < VECTOR_MIN_PAIRS:
        return np.ones(len(guarded), bool), None
    pairs, vehicle = ctx.relations.pairs, ctx.relations.rows.vehicle
    ki, kj = vehicle[pairs.ri[guarded]], vehicle[pairs.rj[guarded]]
    ks = np.unique(np.concatenate([ki, kj]))
    own = [ctx.plan_of(int(k), plans) for k in ks]
    width = 1 + max((len(p.positions) for p in own if p is not None), default=1)
    pos = np.full((len(ks), width), math.inf)  # [m] padded past each plan
    lengths, dt = np.zeros(len(ks), np.intp), np.ones(len(ks))
    usable, v_end = np.zeros(len(ks), bool), np.zeros(len(ks))  # [m/s] each plan's final speed
    for n, p in enumerate(own):
        if p is not None:
            pos[n, :len(p.positions)], lengths[n], dt[n], usable[n] = p.positions, len(p.positions), p.dt, True
            v_end[n] = p.speeds[-1]
    a, b = np.searchsorted(ks, ki), np.searchsorted(ks, kj)
    zone_i, zone_j = pairs.zone_i[guarded], pairs.zone_j[guarded]  # [m]
    times, exact = reach_times(pos, lengths, dt, np.concatenate((a, a, b, b)),
                               np.concatenate((zone_i[:, 0], zone_i[:, 1], zone_j[:, 0], zone_j[:, 1])))
    in_i, out_i, in_j, out_j = np.split(times, 4)
    e1, e2, e3, e4 = np.split(exact, 4)
    n_end = np.maximum(lengths - 1, 0)
    ends = PlanEnds(pos[np.arange(len(ks)), n_end], v_end, dt * n_end)  # per plan in ks
    out = np.array([not ctx.in_junction(int(k)) for k in ks])  # not yet in the junction
    block_i, block_j = ctx.block_in  # [m]
    in_i, out_i, in_j, out_j = past_horizon(
        (in_i, out_i, in_j, out_j), zone_i, zone_j, PlanEnds(*(x[a] for x in ends)), PlanEnds(*(x[b] for x in ends)),
        np.where(out[a], block_i, math.inf), np.where(out[b], block_j, math.inf), st.clear_speed)
    gap = st.time_gap  # [s]
    if st.game_gap_share != 1.0 and ctx.games:
        gap = np.where(named_pairs(world.ids, ctx.games, ki, kj), st.gap_for(True), gap)
    apart = (in_i >= out_j + gap) | (in_j >= out_i + gap)
    if ctx.junction.waits and world.human is not None and bool(np.any(world.human)):
        # a human waiting at its position may start (its forecast depends on the partner): look
        waiting = np.array([world.is_human(int(k)) and ctx.waits_at_its_position(int(k)) for k in ks])
        apart &= ~(waiting[a] | waiting[b])
        in_i = np.where(waiting[a] | waiting[b], np.nan, in_i)
    ok = usable[a] & usable[b] & e1 & e2 & e3 & e4 & np.isfinite(zone_i).all(axis=1) & np.isfinite(zone_j).all(axis=1)
    return ~(apart & ok), (np.where(ok, in_i, np.nan), out_i, in_j, out_j)


def _ranked(ctx: StepContext, step: FilterStep, lat: Lateral, ki: int, kj: int, times: tuple,
            block: tuple[float, float]) -> list[_Crossing]:
    """The pair's two vehicles, lower-ranked first; ``block``: where each one's block starts [m]."""
    ti, tj = ctx.arrival(lat.play, (lat.zone_i, lat.zone_j), ki, kj, times[0], times[2])
    both = (_Crossing(ctx.rank(ki, ti, lat.zone_i[0], step.queue), ki, lat.ri, lat.zone_i[0], block[0]),
            _Crossing(ctx.rank(kj, tj, lat.zone_j[0], step.queue), kj, lat.rj, lat.zone_j[0], block[1]))
    return sorted(both, key=lambda c: (c.rank, c.k, c.row, c.enter), reverse=True)


def guard(ctx: StepContext, step: FilterStep, lat: Lateral, occ: tuple | None = None,
          block: tuple[float, float] | None = None) -> None:
    """The rule on one guarded crossing (module docstring); ``occ``: :func:`maybe_close`'s times;
    ``block``: where each vehicle's block of zones holding this crossing starts [m] (default: the
    zones' own starts)."""
    world, st, j, ids = ctx.world, ctx.settings, ctx.junction, ctx.world.ids
    ki, kj = int(ctx.relations.rows.vehicle[lat.ri]), int(ctx.relations.rows.vehicle[lat.rj])
    pi, pj = ctx.plan_of(ki, step.plans, kj), ctx.plan_of(kj, step.plans, ki)
    if pi is None or pj is None:
        return
    block = block or (lat.zone_i[0], lat.zone_j[0])
    if occ is None or math.isnan(occ[0]):
        reach = [np.array([math.inf if ctx.in_junction(k) else b]) for k, b in ((ki, block[0]), (kj, block[1]))]
        occ = tuple(float(x[0]) for x in past_horizon(
            [np.array([t]) for t in (*occupancy(pi, *lat.zone_i), *occupancy(pj, *lat.zone_j))],
            np.array([lat.zone_i]), np.array([lat.zone_j]),
            plan_ends([pi]), plan_ends([pj]), *reach, st.clear_speed))
    in_i, out_i, in_j, out_j = occ
    gap = st.gap_for(ctx.in_game(ids[ki], ids[kj]))  # [s]
    if in_i >= out_j + gap or in_j >= out_i + gap:
        return  # the plans keep the crossing clear
    if lat.live and not (world.is_human(ki) or world.is_human(kj)):
        step.events.add((min(ids[ki], ids[kj]), max(ids[ki], ids[kj])))
    lower_first = _ranked(ctx, step, lat, ki, kj, occ, block)
    for n, c in enumerate(lower_first):
        other = lower_first[1 - n]
        if world.is_human(c.k):  # never made to yield; ranked below an AV in the box, SUMO makes it wait
            if n == 0:
                step.waits.append(Wait(c.k, other.k, other.enter))
                return
            continue
        margin = st.human_margin if world.is_human(other.k) else st.margin  # [m]
        s_stop, own = float(j.s_stop[ctx.relations.rows.pidx[c.row]]), (ctx.relations.pairs, c.row)
        a = ctx.stop_short_of(c.k, s_stop, c.block, margin, own) if c.block < c.enter else None
        if a is None:  # in the block, or too close to stop before it: before the zone, as it can
            a = ctx.stay_out(c.k, s_stop, c.enter, margin, own)
        if a is not None:
            step.lower(ids[c.k], a, NAME)
            step.waits.append(Wait(c.k, other.k, other.enter))  # either way round: box_clear ends it
            return
    _committed(ctx, step, lat, lower_first)


def _committed(ctx: StepContext, step: FilterStep, lat: Lateral, lower_first: list[_Crossing]) -> None:
    """Neither can stay out: the lower-ranked one holds back as hard as it may, unless that stops
    it in a human's way, or inside its zone while the other is still coming: then it drives out."""
    world, ids = ctx.world, ctx.world.ids
    low, other = lower_first
    k = low.k
    if world.is_human(other.k) and ctx.would_stop_in(k, low.enter):
        step.drive_out(ids[k], NAME)
        return
    zone = lat.zone_i if low.row == lat.ri else lat.zone_j
    if float(world.s[other.k]) < other.enter and ctx.stuck_inside(k, zone):
        step.drive_out(ids[k], NAME)
        return
    step.lower(ids[k], max(ctx.brake(k), -float(world.v[k]) / ctx.junction.period), NAME)


def run(ctx: StepContext, step: FilterStep) -> None:
    close, occ = maybe_close(ctx, step.plans)
    look = np.flatnonzero(close)
    if not len(look):
        return
    pairs, (block_i, block_j) = ctx.relations.pairs, ctx.block_in
    for n in look:
        guard(ctx, step, pairs.at(int(ctx.guarded[n])), None if occ is None else tuple(float(x[n]) for x in occ),
              (float(block_i[n]), float(block_j[n])))


RULE = Rule(NAME, SAFETY, run, each_look=True)
