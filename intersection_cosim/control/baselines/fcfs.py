"""``fcfs``: first-come-first-served reservation of the conflict points (Dresner and Stone's AIM).

A baseline without games: an intersection manager grants each vehicle time slots at the conflict
points on its path, in the order in which the vehicles could reach the conflict zone.

Units: arc lengths s [m] along the vehicle's movement path (network/paths.py), speeds [m/s],
accelerations [m/s^2], times [s] of simulation time.

**Profiles.** A vehicle's plan is an *arrival* at its path's stop line ``s_stop`` at time ``T_a``
with speed ``v_a``; from there it accelerates at ``comfort_accel`` up to ``v_max`` (ModelSettings)
through the junction. A vehicle already past the stop line "arrives" where it is, now, at its speed.
Its *earliest* arrival ``T_e`` (speed ``v_e``) is that of accelerating at ``comfort_accel`` to
``v_max`` from its current state; a later arrival ``T_a > T_e`` is flown at "constant-ish" speed:
constant acceleration covering the distance d to the line in ``T_a - t``, so
``v_a = min(2 d / (T_a - t) - v, v_e)``; where that would be negative the vehicle brakes to a stop
just before the line and starts from rest at ``T_a`` (``v_a = 0``).

**Occupancy.** At a cross or confluence point at arc length ``s_cp`` (ConflictTable) a vehicle
occupies the point from its front reaching ``s_cp - W/2`` until its front reaches
``s_cp + W/2 + L`` (the rear has left; W width, L length, ModelSettings). Two vehicles from the
same approach lane (a *following* pair) share a "stop-line point": from the front reaching
``s_stop`` until it reaches ``s_stop + L + follow_gap``. Two occupancies at the same point
*collide* if they come closer than ``buffer`` [s].

**Rule, every control period.**

1. Vehicles that are committed keep their grant: those inside the junction (or past the stop
   line), those that can no longer stop before the stop line at ``max_brake``, and vehicles
   already released (on the exit lane, SUMO-driven) until their rear has cleared every point.
   A committed vehicle's reserved interval at each point is the union of its granted slot and
   its prediction from the current state, so a vehicle that runs late keeps the point.
2. The others (approaching) are re-planned in the order of their earliest arrival ``T_e`` (ties
   by id; on one approach lane never before the vehicle ahead). Each tries the arrival times
   ``T_e, T_e + slot_step, ...`` (up to ``max_delay``) and takes the first whose occupancies of
   all its points collide with no grant made before it (committed vehicles and vehicles earlier
   in the order). That delays it until after the granted slots (the latest start it needs across
   its points, to within ``slot_step``).
3. Commands: a vehicle granted its earliest arrival, or past the stop line, accelerates at
   ``comfort_accel`` to ``v_max``; a delayed one applies the constant acceleration of its slot
   (or brakes to stop before the line, ``stopping_acceleration``), clipped to
   ``[-max_brake, comfort_accel]``. Every command is capped by Krauss' safe speed
   (:func:`~intersection_cosim.control.baselines.fcfs_guard.leader_caps`) behind the vehicle's
   leader: the nearest vehicle ahead on a shared stretch (same approach lane, or the same exit
   lane after a merge point).
4. Vehicles that have left the conflict zone (role ``outside``) are released to SUMO.
5. Don't block the box (``exit_room``, as the game controller): an approaching vehicle that is
   not committed and whose exit lane will lack room for it when it reaches its stop line
   (:func:`~intersection_cosim.control.exit_room.exit_room_caps`) gets no reservation this period
   and brakes to stop ``follow_gap`` before its line; the points it would have reserved stay free
   for the others.
6. Safety filter (``safety_filter``): the game controllers' named safety rules (control/safety/,
   through :mod:`~intersection_cosim.control.baselines.fcfs_guard`) check every command against
   the humans, the guests, vehicles standing in the box and each AV's grant flown; they only
   lower accelerations (or let a vehicle standing in a crossing drive out of it).

**Mixed traffic.** A human driver (and a guest another junction commands) is never commanded: its
points are reserved first, every period, from its current state: from its earliest entry
(accelerating at ``comfort_accel``) until it could have left accelerating only at
``human_slow_accel``, so the AVs are granted slots around the humans' predicted occupancy and
yield to them; the leader caps count humans as leaders too. A human standing short of its stop
line (below ``standing_speed``) reserves nothing: SUMO holds it for a foe, maybe an AV waiting
for that reservation (a cycle); once it moves it reserves again, and rule 6 guards the AVs.

The controller also fixes each vehicle's exit lane to its path's (``Decisions.exit_lane``) so that
the points it reserved are the ones it drives through.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from intersection_cosim.control.base import ControlContext, Decisions, Diagnostics, World
from intersection_cosim.control.safety.exit_room import exit_room_caps
from intersection_cosim.control.baselines.reservations import (FcfsSettings, Grant, Reservations,
                                                                not_before_vehicle_ahead, time_to_cover)
from intersection_cosim.control.baselines.fcfs_guard import FcfsGuard, leader_caps
from intersection_cosim.control.safety.kinematics import stopping_acceleration
from intersection_cosim.network.conflicts import (
    KIND_CONFLUENCE,
    KIND_CROSS,
    KIND_FOLLOWING,
    movement_conflict_table,
)


class _Arrivals(NamedTuple):
    """Every vehicle's earliest arrival at its stop line, one step (arrays over the world's vehicles)."""

    s_stop: np.ndarray  # [m] its path's stop line
    d: np.ndarray  # [m] distance to the stop line (<= 0: past it)
    past: np.ndarray  # bool: past the stop line, or not approaching (role other than "ready")
    v: np.ndarray  # [m/s] speed, clipped at 0
    t_e: np.ndarray  # [s] earliest arrival (now, past the line); never before the vehicle ahead
    v_e: np.ndarray  # [m/s] speed at the earliest arrival
    cannot_stop: np.ndarray  # bool: can no longer stop before the line at max_brake


class FcfsController:
    """First-come-first-served reservation controller (see the module docstring)."""

    controls_vehicles = True
    yields_to_pedestrians = False  # its reservations know no persons
    junction_type = "priority"

    def __init__(self, settings: FcfsSettings | None = None):
        self.fs = settings if isinstance(settings, FcfsSettings) else FcfsSettings()
        self.grants: dict[str, Grant] = {}
        self.committed: set[str] = set()
        self.controlled: set[str] = set()
        self.history: dict[str, dict] = {}  # vehicle -> its slots when it committed (for checks)

    def setup(self, context: ControlContext) -> None:
        self.ctx = context
        if isinstance(context.settings, FcfsSettings):
            self.fs = context.settings
        self.paths = context.paths
        self.model = context.model
        self.table = movement_conflict_table(context.movements, context.model.vehicle_width,
                                             context.model.vehicle_length)
        self._approach_lane = {pid: p.approach_lane for pid, p in self.paths.items()}
        self._point_key: dict = {}
        self.guard = FcfsGuard(context, self.fs) if self.fs.safety_filter else None

    def diagnostics(self) -> Diagnostics:
        """Reservations are granted, not solved; the safety filter's counts (none without it)."""
        if getattr(self, "guard", None) is None:
            return Diagnostics()
        f = self.guard.filter
        return Diagnostics(None, f.filtered, f.cleared, f.pedestrian_holds)

    def _key(self, *parts) -> int:
        return self._point_key.setdefault(parts, len(self._point_key))

    # ------------------------------------------------------------------ points
    def _points(self, pid: str, others: set[str]):
        """The points of path ``pid`` shared with any path in ``others``: keys and the arc-length
        window [s_in, s_out] [m] over which the front bumper occupies each."""
        fs, ms = self.fs, self.model
        half, length = ms.vehicle_width / 2, ms.vehicle_length
        p = self.table.index[pid]
        path = self.paths[pid]
        keys, s_in, s_out = [], [], []
        for q_id in others:
            q = self.table.index[q_id]
            kind = self.table.kind[p, q]
            if kind in (KIND_CROSS, KIND_CONFLUENCE):
                s_cp = float(self.table.s_a[p, q])
                keys.append(self._key("cp", *sorted((pid, q_id))))
                s_in.append(s_cp - half)
                s_out.append(s_cp + half + length)
        if any(self.table.kind[p, self.table.index[q_id]] == KIND_FOLLOWING for q_id in others):
            keys.append(self._key("line", path.approach_lane))
            s_in.append(path.s_stop)
            s_out.append(path.s_stop + length + fs.follow_gap)
        return np.asarray(keys, np.int64), np.asarray(s_in), np.asarray(s_out)

    def _occupancy(self, t_a, v_a, s_ref: float, s_in, s_out):
        """(enter, leave) [s] at the points for arrivals (t_a, v_a) at s_ref; broadcast (K,1)x(P,)."""
        fs, vmax = self.fs, self.model.v_max
        enter = t_a + time_to_cover(s_in - s_ref, v_a, fs.comfort_accel, vmax)
        leave = t_a + time_to_cover(s_out - s_ref, v_a, fs.comfort_accel, vmax)
        return enter, leave

    # ------------------------------------------------------------------ one step
    def decide(self, world: World, deadline: float) -> Decisions:
        observed = world.observed()
        active = [k for k in range(len(world)) if world.role[k] != "outside" and (observed is None or not observed[k])]
        release = self._forget_departed(world, active)
        arrivals = self._arrivals(world)
        paths_present = set(world.path_ids)
        order, busy = self._keep_committed(world, arrivals, paths_present, observed)  # rule 1
        held = self._exit_holds(world, order)  # rule 5
        order = [k for k in order if world.ids[k] not in held]
        self._grant_in_order(world, arrivals, order, paths_present, busy)  # rule 2
        accel = self._commands(world, arrivals, active, held)  # rule 3
        leader_caps(world, self.table, active, accel, self.model.vehicle_length, self.fs.follow_gap,
                    self.fs.max_brake, self.ctx.control_period)
        decisions = self._decisions(world, active, release, accel, arrivals.v)
        self._guard(world, arrivals, active, held, decisions)  # rule 6
        return decisions

    def _forget_departed(self, world: World, active: list[int]) -> list[str]:
        """Drop the grants of vehicles no longer in the world; return the ids to release to SUMO
        (controlled last step, ``outside`` or gone now), sorted (rule 4)."""
        ids = world.ids
        release = sorted(self.controlled - {ids[k] for k in active})
        self.controlled = {ids[k] for k in active}
        present = set(ids)
        self.grants = {v: g for v, g in self.grants.items() if v in present}
        self.committed &= present
        return release

    def _arrivals(self, world: World) -> _Arrivals:
        """Every vehicle's earliest arrival at its stop line and whether it can still stop."""
        fs, vmax, t = self.fs, self.model.v_max, world.time
        s_stop = np.array([self.paths[p].s_stop for p in world.path_ids])
        d = s_stop - world.s
        past = (d <= 0) | np.array([r != "ready" for r in world.role], dtype=bool)
        v = np.clip(world.v, 0.0, None)
        t_e = np.where(past, t, t + time_to_cover(d, v, fs.comfort_accel, vmax))
        v_e = np.where(past, v, np.minimum(vmax, np.sqrt(v * v + 2 * fs.comfort_accel * np.maximum(d, 0))))
        cannot_stop = v * v / (2 * fs.max_brake) >= d - fs.follow_gap
        return _Arrivals(s_stop, d, past, v, not_before_vehicle_ahead(world, past, t_e), v_e, cannot_stop)

    def _keep_committed(self, world: World, arr: _Arrivals, paths_present: set[str],
                        observed: np.ndarray | None = None) -> tuple[list[int], Reservations]:
        """Rule 1: reserve the humans' predicted points and re-reserve the committed vehicles'
        (granted slot widened by the prediction from now). Returns the indices of the other
        vehicles (to be planned, in world order) and the reservations made."""
        busy = Reservations()
        order = []
        for k in range(len(world)):
            vid = world.ids[k]
            if observed is not None and observed[k]:
                if not arr.past[k] and arr.v[k] < self.fs.standing_speed:
                    continue  # stands short of its line: SUMO holds it (docstring, Mixed traffic)
                keys, s_in, s_out = self._points(world.path_ids[k], paths_present)
                keep = world.s[k] <= s_out
                busy.add(keys[keep], *self._human_occupancy(world, k, arr, s_in[keep], s_out[keep]))
                continue
            grant = self.grants.get(vid)
            if not (arr.past[k] or vid in self.committed or (arr.cannot_stop[k] and grant is not None)):
                order.append(k)
                continue
            keys, s_in, s_out = self._points(world.path_ids[k], paths_present)
            if grant is None:  # first seen already committed: its grant is its prediction
                grant = Grant(float(arr.t_e[k]), float(arr.v_e[k]), True)
                self.grants[vid] = grant
            enter, leave = self._committed_occupancy(world, k, arr, grant, keys, s_in, s_out)
            if vid not in self.committed:
                self._commit(vid, grant, keys, enter, leave)
            keep = world.s[k] <= s_out  # rear not yet past the point
            grant.slots.update({int(kk): (float(e), float(l_)) for kk, e, l_ in
                                zip(keys[keep], enter[keep], leave[keep])})
            busy.add(keys[keep], enter[keep], leave[keep])
        return order, busy

    def _human_occupancy(self, world: World, k: int, arr: _Arrivals, s_in: np.ndarray, s_out: np.ndarray):
        """(enter, leave) [s] of human ``k`` at its points: entering as early as it could
        (``comfort_accel``), leaving as late as a gentle start (``human_slow_accel``) would."""
        fs, vmax, s = self.fs, self.model.v_max, float(world.s[k])
        enter = world.time + time_to_cover(s_in - s, arr.v[k], fs.comfort_accel, vmax)
        leave = world.time + time_to_cover(s_out - s, arr.v[k], fs.human_slow_accel, vmax)
        return enter, leave

    def _committed_occupancy(self, world: World, k: int, arr: _Arrivals, grant: Grant,
                             keys: np.ndarray, s_in: np.ndarray, s_out: np.ndarray):
        """(enter, leave) [s] of committed vehicle ``k`` at its points: its prediction from now
        (past the line) or from its granted arrival, late-arrival widened, united with its slots."""
        if arr.past[k]:
            enter, leave = self._occupancy(world.time, arr.v[k], float(world.s[k]), s_in, s_out)
        else:  # still approaching: it flies its granted arrival
            s_stop = float(arr.s_stop[k])
            enter, leave = self._occupancy(grant.t_arrive, grant.v_arrive, s_stop, s_in, s_out)
            _, late = self._occupancy(arr.t_e[k], arr.v_e[k], s_stop, s_in, s_out)
            leave = np.maximum(leave, late)
        for m, key in enumerate(keys):
            if int(key) in grant.slots:
                ge, gl = grant.slots[int(key)]
                enter[m], leave[m] = min(enter[m], ge), max(leave[m], gl)
        return enter, leave

    def _commit(self, vid: str, grant: Grant, keys: np.ndarray, enter: np.ndarray, leave: np.ndarray) -> None:
        """Mark ``vid`` committed and record its slots at that moment in ``history``."""
        self.committed.add(vid)
        self.history[vid] = {int(kk): (float(e), float(l_)) for kk, e, l_ in zip(keys, enter, leave)}
        self.history[vid].update(grant.slots)

    def _grant_in_order(self, world: World, arr: _Arrivals, order: list[int], paths_present: set[str],
                        busy: Reservations) -> None:
        """Rule 2: grant the vehicles ``order`` (indices), by earliest arrival then id, each the
        first arrival whose slots collide with no reservation in ``busy`` (which each grant joins)."""
        fs = self.fs
        n_cand = int(math.ceil(fs.max_delay / fs.slot_step)) + 1
        for k in sorted(order, key=lambda k: (arr.t_e[k], world.ids[k])):
            keys, s_in, s_out = self._points(world.path_ids[k], paths_present)
            cand_t, cand_v = self._candidate_arrivals(world.time, arr, k, n_cand)
            enter, leave = self._occupancy(cand_t[:, None], cand_v[:, None], float(arr.s_stop[k]), s_in, s_out)
            j = busy.first_free(enter, leave, keys, fs.buffer)
            if j < 0:
                j = n_cand - 1
            self.grants[world.ids[k]] = Grant(
                float(cand_t[j]), float(cand_v[j]), j == 0,
                {int(kk): (float(e), float(l_)) for kk, e, l_ in zip(keys, enter[j], leave[j])})
            busy.add(keys, enter[j], leave[j])

    def _candidate_arrivals(self, t: float, arr: _Arrivals, k: int, n_cand: int):
        """(times [s], speeds [m/s]) of the ``n_cand`` arrivals tried for vehicle ``k``: its earliest,
        then every ``slot_step`` later at the constant-acceleration speed (0: stop and start)."""
        cand_t = arr.t_e[k] + self.fs.slot_step * np.arange(n_cand)
        dt = np.maximum(cand_t - t, 1e-6)
        v_lin = 2.0 * max(arr.d[k], 0.0) / dt - arr.v[k]
        cand_v = np.where(v_lin >= 0, np.minimum(v_lin, arr.v_e[k]), 0.0)
        cand_v[0] = arr.v_e[k]
        return cand_t, cand_v

    def _exit_holds(self, world: World, order: list[int]) -> dict[str, float]:
        """Rule 5: [m/s^2] the stopping acceleration of each uncommitted vehicle of ``order``
        (indices) whose exit lane lacks room; their grants are dropped."""
        fs = self.fs
        if not fs.exit_room:
            return {}
        caps = exit_room_caps(world, self.ctx.movements, {}, self.model.vehicle_length, fs.exit_min_gap,
                              fs.follow_gap, fs.comfort_accel, -fs.max_brake, self.ctx.control_period,
                              fs.standing_speed)
        uncommitted = {world.ids[k] for k in order}
        held = {vid: a for vid, a in caps.items() if vid in uncommitted}
        for vid in held:
            self.grants.pop(vid, None)
        return held

    def _commands(self, world: World, arr: _Arrivals, active: list[int], held: dict[str, float]) -> np.ndarray:
        """Rule 3: [m/s^2] each active vehicle's acceleration towards its grant, or its hold
        (rule 5), before the leader caps."""
        accel = np.zeros(len(world))
        for k in active:
            vid = world.ids[k]
            accel[k] = held[vid] if vid in held else self._grant_accel(world, arr, k, self.grants[vid])
        return accel

    def _grant_accel(self, world: World, arr: _Arrivals, k: int, grant: Grant) -> float:
        """[m/s^2] vehicle ``k``'s acceleration to fly ``grant``, clipped to [-max_brake, comfort_accel]."""
        fs, period, t = self.fs, self.ctx.control_period, world.time
        d, v = arr.d, arr.v
        if arr.past[k] or grant.earliest or grant.t_arrive <= t + 1e-9:
            a = fs.comfort_accel
        elif grant.v_arrive > 0:
            dt = grant.t_arrive - t
            a = 2.0 * (d[k] - v[k] * dt) / (dt * dt)
        else:
            a = stopping_acceleration(float(world.s[k]), float(v[k]), float(arr.s_stop[k]) - fs.follow_gap)
            a = -v[k] / period if a is None else a
        a = min(a, (self.model.v_max - v[k]) / period)
        return min(max(a, -fs.max_brake), fs.comfort_accel)

    def _decisions(self, world: World, active: list[int], release: list[str], accel: np.ndarray,
                   v: np.ndarray) -> Decisions:
        """The step's Decisions: ``accel`` (no harder braking than to stop within the period) and
        the path's exit lane for each active vehicle, and the vehicles to ``release``."""
        period = self.ctx.control_period
        decisions = Decisions(release=release)
        for k in active:
            vid = world.ids[k]
            decisions.accel[vid] = float(max(accel[k], -v[k] / period))
            if len(world.exit_choices.get(vid, ())) > 1:
                decisions.exit_lane[vid] = self.paths[world.path_ids[k]].exit_lane
        return decisions

    def _guard(self, world: World, arr: _Arrivals, active: list[int], held: dict[str, float],
               decisions: Decisions) -> None:
        """Rule 6: the safety filter's rules (fcfs_guard.py) on the step's accelerations, each AV's
        plan its grant flown (a held one stops before its line); the caps on guests go to their owners."""
        if self.guard is None:
            return
        self.guard.release(decisions.release)
        if not active:
            return
        plans, options = {}, {}
        for k in active:
            vid = world.ids[k]
            grant = None if vid in held else self.grants.get(vid)
            plans[vid] = self.guard.plan(float(world.s[k]), float(arr.v[k]), decisions.accel[vid],
                                         float(arr.s_stop[k]), grant, bool(arr.past[k]), world.time)
            options[vid] = self.paths[world.path_ids[k]].exit_lane
        result = self.guard.apply(world, decisions.accel, plans, options)
        decisions.accel.update(result.accel)
        decisions.caps.update(result.guest_caps)

    def fallback(self, world: World) -> Decisions:
        """Comfortable braking for approaching vehicles that can still stop, the committed ones
        keep going; through the safety filter (rule 6) as every step."""
        decisions = Decisions(fallback=True)
        period = self.ctx.control_period
        observed = world.observed()
        active, stopping = [], {}
        for k in range(len(world)):
            if world.role[k] == "outside" or (observed is not None and observed[k]):
                continue
            vid = world.ids[k]
            a = self.fs.comfort_accel if vid in self.committed else -self.fs.comfort_accel
            if vid not in self.committed:
                stopping[vid] = a
            decisions.accel[vid] = max(a, -float(world.v[k]) / period)
            self.controlled.add(vid)
            active.append(k)
        self._guard(world, self._arrivals(world), active, stopping, decisions)
        return decisions
