"""Kinematics the safety rules share: when a plan occupies a stretch of its path, the braking
that stops a vehicle at a point, the plan of a vehicle braked or driven on, and where a vehicle
standing inside crossing zones can get out of them. Pure functions of plans and numbers."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from intersection_cosim.games.problem import Plan

CREEP_CLEARANCE = 0.1  # [m] a vehicle leaving a crossing zone to stand between crossings stops this far past it


def occupancy(plan: Plan, enter: float, leave: float) -> tuple[float, float]:
    """[s] (enter, leave): when the planned front reaches arc length ``enter`` and when it passes
    ``leave`` [m] (a crossing's zone of the conflict table); ``inf`` where that is beyond the
    plan's horizon, 0 where it is already there."""
    pos = plan.positions  # non-decreasing: plans keep v >= 0
    k_in, k_out = pos.searchsorted((enter, leave))  # first samples at or past each point
    return _first_reach(pos, int(k_in), enter, plan.dt), _first_reach(pos, int(k_out), leave, plan.dt)


def _first_reach(pos: np.ndarray, k: int, target: float, dt: float) -> float:
    """[s] when ``pos`` (sampled every ``dt``) reaches ``target``, ``pos[k]`` its first sample at
    or past it, linearly interpolated."""
    if k == 0:
        return 0.0
    if k >= len(pos):
        return math.inf
    p0, p1 = float(pos[k - 1]), float(pos[k])
    return dt * (k - 1 + (target - p0) / max(p1 - p0, 1e-9))


def occupancy_times(positions: np.ndarray, lengths: np.ndarray, dt: np.ndarray, row: np.ndarray,
                    target: np.ndarray) -> np.ndarray:
    """[s] when the planned front of plan ``row[m]`` reaches arc length ``target[m]`` [m], as
    :func:`occupancy` computes it, for many (plan, target) at once: ``positions`` (P, L) [m] the
    plans' positions (each non-decreasing, padded with inf past its ``lengths`` (P,) samples),
    ``dt`` (P,) [s] their steps. Bit for bit the values of :func:`occupancy`."""
    return reach_times(positions, lengths, dt, row, target)[0]


def reach_times(positions: np.ndarray, lengths: np.ndarray, dt: np.ndarray, row: np.ndarray,
                target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`occupancy_times` [s] for plans that need not be non-decreasing, and (M,) bool:
    where the value is bit for bit :func:`occupancy`'s. That holds where the samples before
    the first one at or past the target all lie below it (then a binary search finds that
    sample, whatever the order of the rest): always for a non-decreasing plan, and for a
    plan that stands still to the last bit (its positions wobble by 1e-15) unless the
    target lies inside the wobble."""
    return _reach_times(positions, lengths, dt, np.asarray(row, np.intp), np.asarray(target, float))


@njit(cache=True)
def _reach_times(positions, lengths, dt, row, target):  # pragma: no cover - compiled
    """:func:`reach_times`, compiled: one pass over each row instead of some 15 numpy calls."""
    m, width = row.shape[0], positions.shape[1]
    times, exact = np.empty(m), np.empty(m, np.bool_)
    for i in range(m):
        r, x = row[i], target[i]
        k, first = 0, -1  # samples below the target; the first sample not below it
        for j in range(width):
            if positions[r, j] < x:
                k += 1
            elif first < 0:
                first = j
        exact[i] = first == k or k == width
        if k == 0:
            times[i] = 0.0
        elif k >= lengths[r]:
            times[i] = math.inf
        else:
            kk = min(k, width - 1)
            p0, p1 = positions[r, kk - 1], positions[r, kk]
            times[i] = dt[r] * (kk - 1 + (x - p0) / max(p1 - p0, 1e-9))
    return times, exact


class PlanEnds(NamedTuple):
    """Where plans end: per plan (or per pair side) its last planned state."""

    s: np.ndarray  # [m] last planned front position
    v: np.ndarray  # [m/s] last planned speed
    t: np.ndarray  # [s] the horizon

    def reach(self, target: np.ndarray, speed: np.ndarray) -> np.ndarray:
        """[s] when the front, going on at ``speed`` [m/s] past the plan's end, reaches ``target`` [m]."""
        return self.t + (target - self.s) / speed


def past_horizon(times: tuple, zone_i: np.ndarray, zone_j: np.ndarray, end_i: PlanEnds, end_j: PlanEnds,
                 block_i: np.ndarray, block_j: np.ndarray, speed: float) -> tuple:
    """(in_i, out_i, in_j, out_j) [s], :func:`occupancy` of pairs' zones ``zone_i``, ``zone_j`` (n, 2)
    [m], taken on past the horizon where a plan ends inside the block of its zone (``block_i``,
    ``block_j`` [m]; inf: never) before the zone itself: a vehicle about to enter a block is then
    checked against all of the block's crossings, not only those its horizon reaches. Its front is
    taken to go on at its final speed, at least ``speed`` [m/s], to the zone; in such a pair a
    plan that ends moving (at ``speed`` or more) is taken to go on at its final speed to leave its
    zone, and a plan that ends slower may stand there (leave ``inf``)."""
    in_i, out_i, in_j, out_j = (np.asarray(x, float) for x in times)
    new_i = np.isinf(in_i) & (end_i.s >= block_i)
    new_j = np.isinf(in_j) & (end_j.s >= block_j)
    taken = new_i | new_j
    if not taken.any():
        return in_i, out_i, in_j, out_j
    with np.errstate(divide="ignore", invalid="ignore"):
        in_i = np.where(new_i, end_i.reach(zone_i[:, 0], np.maximum(end_i.v, speed)), in_i)
        in_j = np.where(new_j, end_j.reach(zone_j[:, 0], np.maximum(end_j.v, speed)), in_j)
        go_i = taken & np.isinf(out_i) & np.isfinite(in_i) & (end_i.v >= speed)
        go_j = taken & np.isinf(out_j) & np.isfinite(in_j) & (end_j.v >= speed)
        out_i = np.where(go_i, end_i.reach(zone_i[:, 1], end_i.v), out_i)
        out_j = np.where(go_j, end_j.reach(zone_j[:, 1], end_j.v), out_j)
    return in_i, out_i, in_j, out_j


def plan_ends(plans) -> PlanEnds:
    """:class:`PlanEnds` of a sequence of :class:`~intersection_cosim.games.problem.Plan`."""
    return PlanEnds(np.array([float(p.positions[-1]) for p in plans]), np.array([float(p.speeds[-1]) for p in plans]),
                    np.array([p.dt * (len(p.positions) - 1) for p in plans]))


def stopping_acceleration(s: float, v: float, stop_at: float) -> float | None:
    """[m/s^2] constant acceleration that stops from speed ``v`` [m/s] at arc length ``stop_at``
    [m], or None if the vehicle is already there."""
    d = stop_at - s
    if d <= 0.0:
        return None
    return -v * v / (2.0 * d)


def zone_exit(pairs, row: int, s: float, enter: float, gap: float) -> float | None:
    """[m] the nearest arc length at or ahead of ``s`` (row ``row``'s front) outside every crossing
    zone of that row in ``pairs`` (:class:`~intersection_cosim.control.relations.LateralPairs`)
    that ends short of ``enter`` (the zone it must stay out of; one reaching past it cannot be left
    before it), when ``s`` lies inside such a zone and that point is at least ``gap`` [m] short of
    ``enter``; else None."""
    mine_i, mine_j = pairs.ri == row, pairs.rj == row
    if not (mine_i.any() or mine_j.any()):
        return None
    zones = np.concatenate((pairs.zone_i[mine_i], pairs.zone_j[mine_j]))  # [m] (in, out) each
    zones = zones[zones[:, 1] + CREEP_CLEARANCE <= enter - gap]
    zones = zones[np.argsort(zones[:, 0], kind="stable")]
    out = s
    for z_in, z_out in zones.tolist():
        if z_in <= out < z_out:
            out = z_out + CREEP_CLEARANCE
    if out == s or out > enter - gap:
        return None
    return out


def block_starts(rows: np.ndarray, z_in: np.ndarray, z_out: np.ndarray, join: float) -> np.ndarray:
    """[m] per zone (path row ``rows[n]``, front arc lengths ``z_in[n]`` to ``z_out[n]``), the start
    of its block: the row's zones that overlap or lie less than ``join`` [m] apart chain into one
    block, since a vehicle standing between two of them would stand inside one. A zone with a
    non-finite end is a block of its own."""
    starts = np.array(z_in, float, copy=True)
    ok = np.isfinite(z_in) & np.isfinite(z_out)
    if ok.sum() < 2:
        return starts
    idx = np.flatnonzero(ok)
    idx = idx[np.lexsort((z_in[idx], rows[idx]))]
    r, a, b = rows[idx].astype(float), z_in[idx], z_out[idx]
    shift = (np.abs(b).max() + np.abs(a).max() + 1.0) * 2.0 * r  # [m] keeps the running end within a row
    reach = np.maximum.accumulate(b + shift) - shift  # [m] farthest end so far in the row
    new = np.ones(len(idx), bool)
    new[1:] = (r[1:] != r[:-1]) | (a[1:] - reach[:-1] >= join)
    starts[idx] = a[new][np.cumsum(new) - 1]
    return starts


def creep_acceleration(s: float, v: float, target: float, accel: float, period: float) -> float:
    """[m/s^2] at most ``accel`` [m/s^2], the acceleration over one ``period`` [s] that drives a
    slow vehicle at ``s`` [m] and ``v`` [m/s] on to ``target`` [m] and lets it stop there
    braking at ``accel`` (the speed it may have at a distance d is sqrt(2 accel d))."""
    d = max(target - s, 0.0)
    return min(accel, (math.sqrt(2.0 * accel * d) - v) / period)


def braking_plan(plan: Plan, accel: float) -> Plan:
    """``plan`` from its start state with constant acceleration ``accel`` [m/s^2] (< 0) until it
    stops, then standing: what a vehicle the filter brakes will do if nothing changes."""
    v0 = float(plan.speeds[0])
    n, dt = plan.steps, plan.dt
    if accel >= 0.0:
        a = np.full(n, float(accel))
    else:
        t_stop = v0 / -accel  # [s]
        k = np.arange(n) * dt
        a = accel * np.clip((t_stop - k) / dt, 0.0, 1.0)  # the last step ends exactly at v = 0
    return Plan.from_accelerations(float(plan.positions[0]), v0, a, dt)
