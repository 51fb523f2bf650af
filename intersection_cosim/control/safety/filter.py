"""A safety filter on the game controller's accelerations (not in the paper).

The paper's running cost makes collisions expensive, not impossible: J_lat and J_log are bounded
by 1 / eps, so two aggressive players (Case 1 D) can find an equilibrium in which both cross the
conflict point at nearly the same time, and an aggressive follower can plan into its leader. SUMO
itself never lets that happen to its own vehicles (its safe-speed and right-of-way checks, which
the controller switches off). This filter is the controller's equivalent, applied after the
games; it only ever *lowers* an acceleration, and only when the plans of this step would collide:

* **Crossings.** For each cross / confluence pair, each vehicle's planned occupancy of the
  crossing is the interval from its front reaching the zone's start to its front passing the
  zone's end. For cross pairs the zone is the conflict table's body-overlap stretch
  (``zone_in``, ``zone_out``: where the body overlaps the area the other's bodies sweep); for
  confluence pairs it is ``s_cp - W/2`` to ``s_cp + W/2 + L`` (after the merge the pair is a
  following pair). If the two intervals come closer than ``safety_time_gap``, one of the two
  yields, by one priority order so that waits cannot form a cycle (vehicles stopped in each
  other's zones, a deadlock): a vehicle inside the junction ranks by when it entered it (first
  in, first out), ahead of every vehicle not yet in; among those, the one that would reach the
  crossing first ranks higher (by default at its current speed: the smaller time to the
  crossing, the paper's rule for the Stackelberg leader, except that a pair that played its
  game keeps the game's order, by its plans; ``SafetySettings.yield_order = "plan"`` ranks every
  pair by this step's plans). The lower-ranked one yields if it can still stay out of
  its zone: it brakes to stop ``safety_margin`` before it (a = -v^2 / 2d, at most |a_min|), or at its stop
  line if it has not reached it (as in AIM, a vehicle enters only to clear: one stopped inside
  the junction before one crossing may block another). Else the higher-ranked one yields if it
  can; else both are in (or committed) and the lower-ranked one holds back as hard as it may
  while the other clears the crossing. A slow vehicle in the junction held out of one crossing
  while it stands inside another that it can leave short of the first drives on out of it and
  stands between the two (held where it stood it could close a cycle of waits). A pair is
  guarded until one of the two has left its zone. Vehicles braked in a first pass are checked
  again with their braking plan, so a vehicle made to stop is seen by the other crossings it
  now blocks.
* **Leaders.** A follower's acceleration is capped by the safe speed of Krauss' car-following
  model (SUMO's default): v_safe = -b tau + sqrt((b tau)^2 + (b / b_L) v_L^2 + 2 b (gap - margin)),
  with tau = the control period, so it can always stop behind a leader that brakes as hard as it
  can. Every braking limit the filter counts on (b here, b_L the leader's, and every "can it
  still stop" below) is |a_min|, or a vehicle's own vType decel where that is weaker (a bus
  braking at 3 m/s^2 is guarded as one). A follower whose cap needs more than that (its leader
  makes an emergency stop, control/pedestrians.py) may brake beyond it, up to its vType's
  emergencyDecel, only as hard as Krauss' safe speed for that braking needs (as SUMO's own
  drivers do); the vehicles behind it then count on that braking.
* **Humans.** A human driver (``World.human``) will not yield: its plan is the prediction of
  :func:`~intersection_cosim.models.prediction.human_accelerations` (its present acceleration
  clipped to [0, a_max], never braking). Before it enters the junction it ranks ahead of every AV
  not yet in (it will not yield to them; an AV that can still stay out of the crossing does, one
  that cannot holds back as hard as it may, unless that would stop it inside the crossing: then
  it drives out, as SUMO's human brakes for a vehicle in its way), behind every vehicle already
  in the junction (SUMO's own model makes a human wait for a vehicle in its crossing, and that AV
  drives out by the box rule); inside, it ranks by its entry like an AV. An AV yielding to a human stops
  ``human_margin`` before the crossing (SUMO holds a human for a vehicle whose front is in its
  lane-wide conflict area). The filter never caps a human. An AV not yet
  in the junction waits at its stop line while a human of its crossing stands in that crossing,
  brakes (``SafetySettings.human_brake``) to stop in it, or may be held in it at its waiting
  position (an internal junction of SUMO's net, where a left turn waits for the opposing stream;
  SUMO's human brakes for it only metres before it) unless the AV clears its zone before the
  human gets there (:meth:`SafetyFilter._hold_for_human`). A human standing at its waiting
  position is predicted to start at once against an AV approaching on a lane its internal
  junction does not watch (SUMO releases it whatever that AV does); against the streams it waits
  for it stays put (:meth:`SafetyFilter._may_release`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Mapping, NamedTuple

import numpy as np
from numba import njit

from intersection_cosim.control.base import Decisions, World
from intersection_cosim.control.game.plan_memory import human_forecast
from intersection_cosim.control.game.relations import Lateral, Relations, named_pairs
from intersection_cosim.control.safety.onboard import krauss_safe_speed
from intersection_cosim.games.problem import Plan
from intersection_cosim.control.safety.settings import SafetySettings
from intersection_cosim.games.settings import ProblemSettings
from intersection_cosim.models.cost import time_to_conflict_point
from intersection_cosim.models.settings import ModelSettings


WAIT_REACH = 1.0  # [m] how far before its waiting position a standing human counts as waiting there
CREEP_CLEARANCE = 0.1  # [m] a vehicle leaving a crossing zone to stand between crossings stops this far past it
# [s] a vehicle that inherits another's entry time (priority inheritance) ranks this much ahead of
# it: on a tie the ids decided, and a blocker could stay behind a third vehicle that the one it
# blocks ranks ahead of (docs/design.md, issue 18, eleventh part: a cycle through a merge)
INHERIT_AHEAD = 1e-6
VECTOR_MIN_PAIRS = 16  # [-] guarded pairs from which the filter's first look is vectorised (below it
#                        numpy's fixed cost exceeds the per-pair check's)


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


class _Crossing(NamedTuple):
    """One vehicle of a guarded lateral pair, as the filter ranks it."""

    rank: tuple
    k: int  # World index
    row: int
    enter: float  # [m] front arc length where its zone starts


class SafetyFilter:
    """The whole filter of the module docstring, with its entry queue and its counters.

    ``s_stop`` [m]: each conflict-table path's stop line; ``period`` [s]: the control period.
    """

    def __init__(self, settings: SafetySettings, problem: ProblemSettings, model: ModelSettings,
                 s_stop: np.ndarray, period: float, s_wait: np.ndarray | None = None,
                 waits: Mapping[str, tuple[float, frozenset[str]]] | None = None, gap_slack: float = 0.0):
        self.settings, self.problem, self.model, self.s_stop, self.period = settings, problem, model, s_stop, period
        # [m] taken off every gap to a leader beyond safety_margin: the error of two noisy positions
        # (three standard deviations of their difference under a V2X link's noise)
        self.gap_slack = gap_slack
        self.s_wait = np.full(len(s_stop), math.inf) if s_wait is None else s_wait  # [m] per path, inf: none
        # path id -> ([m] its waiting position, the approach lanes SUMO's internal junction there waits for)
        self.waits = dict(waits or {})
        self.entered: dict[str, float] = {}  # [s] when each vehicle entered the junction (the queue)
        self.filtered = 0  # accelerations the filter lowered
        self.cleared = 0  # accelerations the filter raised to clear a crossing (box rule)
        # sorted vehicle-id pairs of two AVs that may play a game and whose crossing the last
        # apply() had to guard (one held back): the controller may let them play (control/game.py)
        self.events: set[tuple[str, str]] = set()
        self._games: frozenset[tuple[str, str]] = frozenset()  # this apply()'s pairs in a game
        self.stall_held: frozenset[str] = frozenset()  # vehicles the last apply() held for a stalled box

    def record_entries(self, world: World) -> None:
        """Put vehicles that entered the junction ("passing") into the entry queue."""
        for k in range(len(world)):
            if world.role[k] == "passing":
                self.entered.setdefault(world.ids[k], world.time)

    def release(self, vehicle: str) -> None:
        self.entered.pop(vehicle, None)

    def apply(self, world: World, relations: Relations, plans: Mapping[str, Plan], options: Mapping[str, str],
              decisions: Decisions, holds: Mapping[str, float] | None = None,
              games: frozenset[tuple[str, str]] = frozenset(),
              floors: Mapping[str, float] | None = None) -> frozenset[str]:
        """Lower (or, by the box rule, raise) ``decisions.accel`` where this step's ``plans``
        would collide; ``options``: the exit lane each vehicle takes; ``holds`` [m/s^2]: caps
        of other rules (e.g. control/exit_room.py's), enforced and seen by the crossings like
        the filter's own; ``games``: sorted vehicle-id pairs that play their game this step
        (their plans are a game's: their crossing keeps only ``SafetySettings.game_gap_share``
        of the time gap; none in a fallback step, whose plans are the last ones shifted);
        ``floors`` [m/s^2]: per vehicle, a braking harder than its own that a hold may use this
        step (an emergency stop for a pedestrian, control/pedestrians.py). Returns the vehicles
        held back at a crossing or by ``holds`` (not only behind a leader).

        Two passes: a vehicle braked in the first pass is checked again in the second with its
        braking plan (constant capped deceleration to a stop), so a vehicle made to stop is seen
        by every other crossing it now blocks in the same step.
        """
        self.events, self._games = set(), games
        relations = self._widened(relations)
        rows = relations.rows
        brakes = self._brakes(world)
        for vid, floor in (floors or {}).items():
            brakes[vid] = min(floor, brakes.get(vid, self.problem.a_min))
        chosen = tuple(rows.option[r] == options.get(world.ids[rows.vehicle[r]], rows.option[r])
                       for r in range(len(rows)))
        cap, harder = self._leader_caps(world, relations, chosen, decisions, brakes)
        if harder:  # followers that must brake harder than their own braking; theirs count on it
            brakes.update(harder)
            cap, harder = self._leader_caps(world, relations, chosen, decisions, brakes)
            brakes.update(harder)
        leader_cap = dict(cap)  # [m/s^2] the caps behind a leader alone
        for vid, limit in (holds or {}).items():
            if vid in decisions.accel:
                cap[vid] = min(cap.get(vid, math.inf), limit)
        plans = dict(plans)
        clear: set[str] = set()  # vehicles in a crossing that another one waits for
        pairs, on = relations.pairs, np.array(chosen, bool)
        guarded = np.flatnonzero(on[pairs.ri] & on[pairs.rj]) if len(pairs) else np.zeros(0, np.intp)
        queue = self._inherited_entries(world, relations, guarded)  # [s] entry times to rank by
        if world.human is not None and bool(np.any(world.human)):
            for m in guarded:
                self._hold_for_human(world, relations, pairs.at(m), plans, cap)
        if self.settings.stalled_box_hold:
            self.stall_held, waited_for = self._hold_out_of_stalled_box(world, relations, guarded, cap)
            clear |= waited_for
        for _pass in range(2):
            for vid in clear:
                if vid in plans and float(plans[vid].accelerations[0]) < self.settings.clear_accel:
                    plans[vid] = braking_plan(plans[vid], self.settings.clear_accel)  # constant: it drives on
            for vid, limit in cap.items():
                if vid in plans and limit < float(plans[vid].accelerations[0]):
                    plans[vid] = braking_plan(plans[vid], max(limit, brakes.get(vid, self.problem.a_min)))
            close, occ = self._maybe_close(world, relations, guarded, plans)
            for n in np.flatnonzero(close):
                self._guard(world, relations, pairs.at(guarded[n]), plans, cap, clear,
                            None if occ is None else tuple(float(x[n]) for x in occ), queue)
        return self._enforce(decisions, cap, leader_cap, clear, brakes)

    def _widened(self, relations: Relations) -> Relations:
        """``relations`` with every crossing zone widened by ``gap_slack`` [m] at both ends: under a
        link's position noise a vehicle read just short of another's zone may be in it (fokr38 over a
        noisy link: one stopped at the edge of a crossing, read outside it, and the other drove into
        it)."""
        pairs = relations.pairs
        if self.gap_slack <= 0.0 or not len(pairs):
            return relations
        widen = np.array([-self.gap_slack, self.gap_slack])  # [m]
        return dataclasses.replace(relations, pairs=dataclasses.replace(
            pairs, zone_i=pairs.zone_i + widen, zone_j=pairs.zone_j + widen))

    def _brake(self, world: World, k: int) -> float:
        """[m/s^2] (< 0) the hardest braking the filter counts on for vehicle k: the model's
        ``a_min``, or its vType's decel where that is weaker."""
        return world.accel_limits(k, self.problem.a_min, self.problem.a_max)[0]

    def _brakes(self, world: World) -> dict[str, float]:
        """:meth:`_brake` per vehicle id; empty (``a_min`` for all) when the World carries no decel."""
        return {} if world.decel is None else {vid: self._brake(world, k) for k, vid in enumerate(world.ids)}

    def _maybe_close(self, world: World, relations: Relations, guarded: np.ndarray,
                     plans: Mapping[str, Plan]) -> tuple[np.ndarray, tuple | None]:
        """(len(guarded),) bool for the lateral pairs ``guarded`` (indices into
        ``relations.pairs``): False where :meth:`_guard` would find at once that the plans
        keep the crossing clear (it does nothing then), computed for all pairs together with
        :func:`occupancy_times`; True where it must look (also for a pair with a plan missing or
        a plan whose positions go backwards where it matters, which it checks itself). Second: the occupancy
        times (in_i, out_i, in_j, out_j) [s] per pair, for :meth:`_guard` (None below
        ``VECTOR_MIN_PAIRS`` pairs; an entry of a pair with an unusable plan is not used)."""
        if len(guarded) < VECTOR_MIN_PAIRS:  # the per-pair guard's own check is cheaper
            return np.ones(len(guarded), bool), None
        pairs, vehicle = relations.pairs, relations.rows.vehicle
        ki, kj = vehicle[pairs.ri[guarded]], vehicle[pairs.rj[guarded]]
        ks = np.unique(np.concatenate([ki, kj]))
        own = [self._plan_of(world, int(k), plans) for k in ks]
        width = 1 + max((len(p.positions) for p in own if p is not None), default=1)
        pos = np.full((len(ks), width), math.inf)  # [m] padded past each plan
        lengths, dt = np.zeros(len(ks), np.intp), np.ones(len(ks))
        usable = np.zeros(len(ks), bool)
        for n, p in enumerate(own):
            if p is not None:
                pos[n, :len(p.positions)], lengths[n], dt[n], usable[n] = p.positions, len(p.positions), p.dt, True
        a, b = np.searchsorted(ks, ki), np.searchsorted(ks, kj)
        zone_i, zone_j = pairs.zone_i[guarded], pairs.zone_j[guarded]  # [m]
        # the four edges of every pair in one call (its fixed cost is most of a call's)
        times, exact = reach_times(pos, lengths, dt, np.concatenate((a, a, b, b)),
                                   np.concatenate((zone_i[:, 0], zone_i[:, 1], zone_j[:, 0], zone_j[:, 1])))
        in_i, out_i, in_j, out_j = np.split(times, 4)
        e1, e2, e3, e4 = np.split(exact, 4)
        st = self.settings
        gap = st.safety_time_gap  # [s]
        if st.game_gap_share != 1.0 and self._games:
            in_game = named_pairs(world.ids, self._games, ki, kj)
            gap = np.where(in_game, st.time_gap(True), gap)
        apart = (in_i >= out_j + gap) | (in_j >= out_i + gap)
        if self.waits and world.human is not None and bool(np.any(world.human)):
            # a human waiting at its position may start (its forecast depends on the partner):
            # the per-pair guard looks
            waiting = np.array([world.is_human(int(k)) and self._waits_at_its_position(world, int(k)) for k in ks])
            apart &= ~(waiting[a] | waiting[b])
            in_i = np.where(waiting[a] | waiting[b], np.nan, in_i)
        # usable: both plans there, every time as occupancy() has it, at finite zone edges
        ok = usable[a] & usable[b] & e1 & e2 & e3 & e4 & np.isfinite(zone_i).all(axis=1) & np.isfinite(zone_j).all(axis=1)
        return ~(apart & ok), (np.where(ok, in_i, np.nan), out_i, in_j, out_j)

    def _leader_caps(self, world: World, relations: Relations, chosen, decisions: Decisions,
                     brakes: Mapping[str, float]) -> tuple[dict[str, float], dict[str, float]]:
        """[m/s^2] per follower, the acceleration that keeps it at Krauss' safe speed behind a leader
        braking as hard as it may this step (``brakes`` [m/s^2] of :meth:`apply`, an emergency stop's
        included; a follower that counted on the leader's own braking stopped 0.09 m behind one that
        stopped at 7.7 m/s^2 for a person). Second, per follower whose cap needs more than its
        braking in ``brakes``: the braking [m/s^2] (< 0) it may use instead, the least that keeps
        it at Krauss' safe speed for its emergency braking (its vType's emergencyDecel), at most
        that (as SUMO's drivers brake beyond their decel only when they must)."""
        st, rows = self.settings, relations.rows
        cap: dict[str, float] = {}
        harder: dict[str, float] = {}
        for r, lead in relations.leaders.items():
            k = int(rows.vehicle[r])
            vid = world.ids[k]
            if vid not in decisions.accel or not chosen[r]:
                continue
            length = world.length_of(lead.vehicle, self.model.vehicle_length)  # [m] the leader's body
            gap = lead.gap - length - st.safety_margin - self.gap_slack  # [m] bumper to bumper, less margin
            lead_brake = brakes.get(world.ids[lead.vehicle], self.problem.a_min)  # [m/s^2]
            v, v_lead = float(world.v[k]), float(world.v[lead.vehicle])  # [m/s]
            if lead.merge and gap < 0.0:
                # at a merge, level with a leader whose rear is not yet a margin ahead along the
                # paths: it may still be turning in, its rear corner off the path the gap is
                # measured along, so its speed earns no Krauss credit: stop until it is ahead
                # (demand_balanced_high, stackelberg, seed 2, 124.75 s: 0.3 m into a right turner)
                cap[vid] = min(cap.get(vid, math.inf), -v / self.period)
                continue
            limit = (krauss_safe_speed(gap, v_lead, -self._brake(world, k), self.period, -lead_brake) - v) / self.period
            cap[vid] = min(cap.get(vid, math.inf), limit)
            own = brakes.get(vid, self.problem.a_min)  # [m/s^2]
            if limit < own and (em := world.emergency_brake(k, own)) < own:
                need = (krauss_safe_speed(gap, v_lead, -em, self.period, -lead_brake) - v) / self.period
                harder[vid] = min(harder.get(vid, own), max(em, need))
        return cap, {vid: b for vid, b in harder.items() if b < brakes.get(vid, self.problem.a_min)}

    def _enforce(self, decisions: Decisions, cap: dict[str, float], leader_cap: dict[str, float],
                 clear: set[str], brakes: Mapping[str, float]) -> frozenset[str]:
        st = self.settings
        held = set()
        for vid in clear:
            # the box rule: a vehicle inside a crossing that another waits for clears it (its own
            # plan may wait for the other, as a game played before the wait can say), unless a
            # cap of its own holds it back
            if vid in decisions.accel and decisions.accel[vid] < st.clear_accel:
                decisions.accel[vid] = min(st.clear_accel, cap.get(vid, math.inf))
                self.cleared += 1
        for vid, limit in cap.items():
            if vid in decisions.accel and limit < decisions.accel[vid]:
                decisions.accel[vid] = max(limit, brakes.get(vid, self.problem.a_min))
                self.filtered += 1
                if limit < leader_cap.get(vid, math.inf):  # held back at a crossing
                    held.add(vid)
        return frozenset(held)

    def _guard(self, world: World, relations: Relations, lat: Lateral, plans: dict[str, Plan],
               cap: dict[str, float], clear: set[str], occ: tuple[float, ...] | None = None,
               queue: Mapping[str, float] | None = None) -> None:
        """Caps (into ``cap``) for one crossing that the ``plans`` would share within
        ``safety_time_gap``: the lower-ranked vehicle yields if it can still stay out of its zone
        (waiting at its stop line if it has not reached it: AIM's rule, enter only to clear);
        else the higher-ranked one yields if it can; else both are in (or committed) and the
        lower-ranked one holds back as hard as it may while the other clears the crossing. A
        higher-ranked vehicle already inside its zone that a lower-ranked one yields to is put
        in ``clear``: it must drive out."""
        st, ids = self.settings, world.ids
        ki, kj = int(relations.rows.vehicle[lat.ri]), int(relations.rows.vehicle[lat.rj])
        pi, pj = self._plan_of(world, ki, plans, kj), self._plan_of(world, kj, plans, ki)
        if pi is None or pj is None:
            return
        if occ is not None and not math.isnan(occ[0]):  # _maybe_close's values, bit for bit
            in_i, out_i, in_j, out_j = occ
        else:
            in_i, out_i = occupancy(pi, *lat.zone_i)
            in_j, out_j = occupancy(pj, *lat.zone_j)
        gap = st.time_gap(self._in_game(ids[ki], ids[kj]))  # [s]
        if in_i >= out_j + gap or in_j >= out_i + gap:
            return  # the plans keep the crossing clear
        if lat.live and not (world.is_human(ki) or world.is_human(kj)):
            self.events.add((min(ids[ki], ids[kj]), max(ids[ki], ids[kj])))
        ti, tj = self._arrival(world, lat, ki, kj, in_i, in_j)
        lower_first = sorted((_Crossing(self._rank(world, ki, ti, lat.zone_i[0], queue), ki, lat.ri, lat.zone_i[0]),
                              _Crossing(self._rank(world, kj, tj, lat.zone_j[0], queue), kj, lat.rj, lat.zone_j[0])),
                             key=lambda c: (c.rank, c.k, c.row, c.enter), reverse=True)
        for n, c in enumerate(lower_first):
            if world.is_human(c.k):  # a human is never made to yield by the filter (nothing commands it)
                if n == 0:  # it ranks below an AV already in the junction: SUMO makes it wait for
                    other = lower_first[1]  # the vehicle in the box, which drives out
                    if float(world.s[other.k]) >= other.enter and float(world.v[other.k]) < st.clear_speed:
                        clear.add(ids[other.k])
                    return
                continue
            margin = st.human_margin if world.is_human(lower_first[1 - n].k) else st.safety_margin  # [m]
            a = self._stay_out_noisy(world, c.k, float(self.s_stop[relations.rows.pidx[c.row]]), c.enter, margin,
                                     (relations.pairs, c.row))
            if a is not None:
                cap[ids[c.k]] = min(cap.get(ids[c.k], math.inf), a)
                other = lower_first[1]
                if n == 0 and float(world.s[other.k]) >= other.enter and float(world.v[other.k]) < st.clear_speed:
                    clear.add(ids[other.k])
                return
        k = lower_first[0].k
        if world.is_human(lower_first[1].k) and self._would_stop_in(world, k, lower_first[0].enter):
            clear.add(ids[k])  # holding back would leave it standing in the human's way: drive out
            return
        other = lower_first[1]
        if float(world.s[other.k]) < other.enter and self._stuck_inside(
                world, k, lat.zone_i if lower_first[0].row == lat.ri else lat.zone_j):
            clear.add(ids[k])  # in the crossing, the other still coming: braking would stand it in its path
            return
        cap[ids[k]] = min(cap.get(ids[k], math.inf), max(self._brake(world, k), -float(world.v[k]) / self.period))

    def _in_game(self, a: str, b: str) -> bool:
        """Whether vehicles ``a`` and ``b`` play their game this step."""
        return (min(a, b), max(a, b)) in self._games

    def _stuck_inside(self, world: World, k: int, zone: tuple[float, float]) -> bool:
        """Whether vehicle k's front is inside its crossing zone ``zone`` [m] (in, out) and, held
        back as hard as it may from now (:meth:`_brake` [m/s^2]), would stop before its end: it
        would stand in the path of the vehicle it yields to, if that one is still coming
        (demand_balanced_high, nash, seed 18, 237 s: held at -4 m/s^2 0.17 m short of the zone's
        end, it was hit by the other, committed at 8 m/s). Two already in their zones keep the
        rule: one waits, the other clears."""
        s, v = float(world.s[k]), float(world.v[k])  # [m], [m/s]
        stop = s + v * v / (2.0 * -self._brake(world, k))  # [m]
        return zone[0] <= s and stop < zone[1]

    def _would_stop_in(self, world: World, k: int, enter: float) -> bool:
        """Whether vehicle k, braking as hard as it may (:meth:`_brake` [m/s^2]) after one control
        period, comes to a stop at or past arc length ``enter`` [m]: in the crossing it was to stay out of."""
        s, v = float(world.s[k]), float(world.v[k])  # [m], [m/s]
        return s + v * self.period + v * v / (2.0 * -self._brake(world, k)) >= enter

    def _hold_for_human(self, world: World, relations: Relations, lat: Lateral, plans: Mapping[str, Plan],
                        cap: dict[str, float]) -> None:
        """Cap (into ``cap``) an AV not yet in the junction to wait at its stop line while the
        human of its crossing ``lat`` stands in that crossing, brakes to stop in it, or may be
        held in it at its waiting position (:meth:`_human_stop`): SUMO holds it there, e.g. a
        left turn at its internal stop point for the opposing stream, and once in, the AV would
        stop short of the human inside the box, in other vehicles' crossings, while SUMO holds
        the human for the AV in its lane (a cycle). Nothing when the AV can no longer stop there."""
        st, rows = self.settings, relations.rows
        ki, kj = int(rows.vehicle[lat.ri]), int(rows.vehicle[lat.rj])
        for h, k, zone_h, rh, row, zone_k in ((ki, kj, lat.zone_i, lat.ri, lat.rj, lat.zone_j),
                                             (kj, ki, lat.zone_j, lat.rj, lat.ri, lat.zone_i)):
            if not world.is_human(h) or world.is_human(k) or world.role[k] != "ready" or world.ids[k] in self.entered:
                continue
            s_k, v_k = float(world.s[k]), float(world.v[k])
            if s_k >= zone_k[0] or not self._human_stop(world, h, zone_h, float(self.s_wait[rows.pidx[rh]]),
                                                        plans.get(world.ids[k]), zone_k):
                continue
            brake = self._brake(world, k)  # [m/s^2]
            a = stopping_acceleration(s_k, v_k, float(self.s_stop[rows.pidx[row]]) - st.safety_margin)
            if a is None:  # at (or just past) its stop line: stay there
                a = max(brake, -v_k / self.period) if v_k < st.clear_speed else brake - 1.0
            if a >= brake:
                cap[world.ids[k]] = min(cap.get(world.ids[k], math.inf), a)

    def _hold_out_of_stalled_box(self, world: World, relations: Relations, guarded: np.ndarray,
                                 cap: dict[str, float]) -> tuple[frozenset[str], set[str]]:
        """Cap (into ``cap``) an AV not yet in the junction to wait at its stop line while an AV
        of one of its crossings (``guarded``, indices into ``relations.pairs``) is in the
        junction, stalls (below ``clear_speed``, now or within ``stalled_box_lookahead`` at its
        present deceleration) and has not left its zone of that crossing
        (``SafetySettings.stalled_box_hold``). An entrant into a stalled box may itself be held
        inside it, standing in one crossing before another: the third such entry closed a cycle
        of waits that no rule inside the box can undo. The hold starts where a stop at the stop
        line needs ``ProblemSettings.comfort_brake`` (a stall far ahead may clear before the
        vehicle gets there); nothing for one that can no longer stop at its stop line, nor for one
        whose front is already inside a crossing zone (a right turn at its stop line may be: the
        vehicle of that crossing waits for it, so holding it closed a cycle). Returns the
        vehicles whose cap it lowered, and the stalled vehicles someone now waits for: they drive
        on (the box rule), or their own plans, waiting for the held entrant (a game's order),
        would hold it for good."""
        if not len(guarded) or not self.entered:
            return frozenset(), set()
        pairs, rows, ids, st = relations.pairs, relations.rows, world.ids, self.settings
        inside = self._avs_entered(world)
        entrant = np.array([vid not in self.entered and not world.is_human(k) and world.role[k] == "ready"
                            for k, vid in enumerate(ids)], bool)
        v = np.asarray(world.v)  # [m/s]
        soon = v + np.minimum(np.asarray(world.a), 0.0) * st.stalled_box_lookahead  # [m/s]
        stalled = inside & (np.minimum(v, soon) < st.clear_speed)
        reach = v * v / (2.0 * self.problem.comfort_brake) + v * self.period + 2.0 * st.safety_margin  # [m]
        in_zone = np.zeros(len(ids), bool)  # its front inside one of its crossing zones
        for r, zone in ((pairs.ri[guarded], pairs.zone_i[guarded]), (pairs.rj[guarded], pairs.zone_j[guarded])):
            k = rows.vehicle[r]
            in_zone[k[(zone[:, 0] <= world.s[k]) & (world.s[k] < zone[:, 1])]] = True
        entrant &= ~in_zone
        held = set()
        for r_e, r_o, zone_o in ((pairs.ri, pairs.rj, pairs.zone_j), (pairs.rj, pairs.ri, pairs.zone_i)):
            ke, ko = rows.vehicle[r_e[guarded]], rows.vehicle[r_o[guarded]]
            s_stop = self.s_stop[rows.pidx[r_e[guarded]]]  # [m]
            near = s_stop - world.s[ke] <= reach[ke]
            m = entrant[ke] & stalled[ko] & (world.s[ko] < zone_o[guarded][:, 1]) & near  # past the line: _stay_out declines
            held.update(zip(ke[m].tolist(), s_stop[m].tolist(), ko[m].tolist()))
        lowered, waited_for = set(), set()
        for k, s_stop_k, o in sorted(held):
            a = self._stay_out(world, k, s_stop_k, s_stop_k, st.safety_margin)
            if a is not None:
                if a < cap.get(ids[k], math.inf):
                    lowered.add(ids[k])
                    cap[ids[k]] = a
                waited_for.add(ids[o])
        return frozenset(lowered), waited_for

    def _human_stop(self, world: World, h: int, zone_h: tuple[float, float], s_wait: float,
                    plan_k: Plan | None, zone_k: tuple[float, float]) -> bool:
        """Whether human h stands in its zone ``zone_h`` [m], brakes (``human_brake``) to stop in
        it, or may stop in it at its waiting position ``s_wait`` [m] (where SUMO's right of way
        holds a left turn for the opposing stream; its braking starts only metres before it,
        too late for an AV at its stop line to react): the last when the human has not passed
        that position and the AV's ``plan_k`` does not leave its zone ``zone_k`` ``safety_time_gap``
        before the human's forecast reaches its zone (the AV would still be in the way)."""
        st = self.settings
        s_h, v_h, a_h = float(world.s[h]), float(world.v[h]), float(world.a[h])  # [m], [m/s], [m/s^2]
        if v_h < st.clear_speed:
            stop_h = s_h  # where it stands
        elif a_h <= -st.human_brake:
            stop_h = s_h + v_h * v_h / (2.0 * -a_h)  # where it will stop
        elif s_h < s_wait and zone_h[0] <= s_wait < zone_h[1] and plan_k is not None:
            in_h, _ = occupancy(self._plan_of(world, h, {}), *zone_h)
            if math.isinf(in_h):  # beyond the horizon: at its present speed (its forecast is no slower)
                in_h = time_to_conflict_point(zone_h[0] - s_h, v_h, self.model.tcp_speed_floor)
            _, out_k = occupancy(plan_k, *zone_k)
            if math.isinf(out_k):  # beyond the horizon: on from the plan's end at its end speed
                out_k = plan_k.steps * plan_k.dt + time_to_conflict_point(
                    zone_k[1] - float(plan_k.positions[-1]), float(plan_k.speeds[-1]), self.model.tcp_speed_floor)
            return out_k + st.safety_time_gap > in_h
        else:
            return False
        return zone_h[0] <= stop_h < zone_h[1]

    def _plan_of(self, world: World, k: int, plans: Mapping[str, Plan], partner: int | None = None) -> Plan | None:
        """The plan the filter checks for vehicle k: this step's, or constant speed for one
        SUMO drives again (it has left the junction); None for one without a plan. A human
        is its forecast; against a ``partner`` that :meth:`_may_release` says SUMO does not wait
        for, a human standing at its waiting position starts at once at ``a_max``."""
        if world.is_human(k):
            a0 = self.problem.a_max if partner is not None and self._may_release(world, k, partner) else None
            return human_forecast(world, k, self.problem.a_max, self.model.v_max, self.problem.steps, self.problem.dt, a0)
        plan = plans.get(world.ids[k])
        if plan is None and world.role[k] == "outside":
            return Plan.from_accelerations(float(world.s[k]), float(world.v[k]), np.zeros(self.problem.steps), self.problem.dt)
        return plan

    def _waits_at_its_position(self, world: World, k: int) -> bool:
        """Whether vehicle k stands (below ``clear_speed``) at its path's waiting position (from
        ``WAIT_REACH`` [m] before it to half a metre past it)."""
        wait = self.waits.get(world.path_ids[k])
        s = float(world.s[k])
        return wait is not None and float(world.v[k]) < self.settings.clear_speed and wait[0] - WAIT_REACH <= s <= wait[0] + 0.5

    def _may_release(self, world: World, h: int, k: int) -> bool:
        """Whether SUMO may release human h from its waiting position while AV k approaches: h
        waits there (:meth:`_waits_at_its_position`) and k, not yet in the junction, is on a lane
        h's internal junction does not look at (network/waiting.py), so SUMO lets h go whatever
        k does, and k must keep able to yield. Against the streams it waits for, h stays put
        (predicting it to start made those AVs wait for it while SUMO held it for them: a lock)."""
        if world.is_human(k) or world.role[k] != "ready" or not self._waits_at_its_position(world, h):
            return False
        return world.lanes[k] not in self.waits[world.path_ids[h]][1]

    def _arrival(self, world: World, lat: Lateral, ki: int, kj: int, in_i: float, in_j: float) -> tuple[float, float]:
        """[s] the times that rank the pair: to the zone at the current speed (``yield_order =
        "tcp"``, Eqs. 21-22); by the plans for ``"plan"`` and for a pair that played its game this
        step, which keeps the equilibrium's order (the filter never overrules a game's
        decision, it only enforces it)."""
        if self.settings.yield_order == "tcp" and not lat.play:
            floor = self.model.tcp_speed_floor
            return (time_to_conflict_point(lat.zone_i[0] - float(world.s[ki]), float(world.v[ki]), floor),
                    time_to_conflict_point(lat.zone_j[0] - float(world.s[kj]), float(world.v[kj]), floor))
        return in_i, in_j

    def _rank(self, world: World, k: int, t_in: float, enter: float = math.inf,
              queue: Mapping[str, float] | None = None) -> tuple:
        """Priority of vehicle k at a crossing it would reach in ``t_in`` [s]: smaller is first.
        A vehicle that has left the junction (SUMO drives it, its rear may still be in the
        crossing) comes first: it cannot yield. One inside ranks by when it entered (first in,
        first out, like a queue: the queue holds even against a game's order, or waits could
        close a cycle), ahead of every vehicle not yet in. A human not yet in ranks ahead of every AV
        not yet in (it will not yield to them), behind those inside (SUMO makes it wait for them),
        unless it cannot stop before the crossing starting at ``enter`` [m] any more: then it ranks
        first, like a vehicle SUMO drives again. ``queue``: the entry times [s] to rank by
        (:meth:`_inherited_entries`); the recorded ones when None."""
        if world.role[k] == "outside" or (world.is_human(k) and self.human_committed(world, k, enter)):
            return (-1, 0.0, world.ids[k])
        entered = (self.entered if queue is None else queue).get(world.ids[k])
        if entered is not None:
            return (0, entered, world.ids[k])
        return (0.5, t_in, world.ids[k]) if world.is_human(k) else (1, t_in, world.ids[k])

    def _avs_entered(self, world: World) -> np.ndarray:
        """(len(world),) bool: the AVs in the entry queue (in the junction); humans never count."""
        return np.array([vid in self.entered and not world.is_human(k) for k, vid in enumerate(world.ids)], bool)

    def _inherited_entries(self, world: World, relations: Relations, guarded: np.ndarray) -> dict[str, float]:
        """[s] the entry time each vehicle in the junction ranks by (:meth:`_rank`): its own, or
        the earlier one of a vehicle in the junction that waits (below ``clear_speed``) short of
        their crossing while this one stands inside its zone of it, passed on along chains. So
        a vehicle that blocks one ranked ahead of others goes before those others and clears its
        way (priority inheritance; it ranks ``INHERIT_AHEAD`` ahead of the one it blocks, so a
        tie of ids cannot put it back behind them): the "cannot stay out" rule had let a vehicle standing in the
        first one's crossing wait for a third, and four vehicles held each other for good
        (docs/design.md, "The cycle of four, replayed"). Human drivers neither pass nor inherit."""
        queue = dict(self.entered)
        if not len(guarded) or not queue:
            return queue
        pairs, vehicle, ids = relations.pairs, relations.rows.vehicle, world.ids
        inside = self._avs_entered(world)
        ks = (vehicle[pairs.ri[guarded]], vehicle[pairs.rj[guarded]])
        zones = (pairs.zone_i[guarded], pairs.zone_j[guarded])
        links = []  # (the waiting vehicle, the one standing in its crossing)
        for w, b in ((0, 1), (1, 0)):
            s_w, s_b = world.s[ks[w]], world.s[ks[b]]
            m = (inside[ks[w]] & inside[ks[b]] & (world.v[ks[w]] < self.settings.clear_speed)
                 & (s_w < zones[w][:, 0]) & (zones[b][:, 0] <= s_b) & (s_b < zones[b][:, 1]))
            links += [(ids[x], ids[y]) for x, y in zip(ks[w][m].tolist(), ks[b][m].tolist())]
        for _ in range(len(links)):  # a chain is at most as long as the links
            changed = False
            for waiting, blocking in links:
                if queue[waiting] - INHERIT_AHEAD < queue[blocking]:  # just ahead of the one it blocks
                    queue[blocking], changed = queue[waiting] - INHERIT_AHEAD, True
            if not changed:
                break
        return queue

    def human_committed(self, world: World, k: int, enter: float) -> bool:
        """Whether human k can no longer stop before arc length ``enter`` [m]: its braking distance
        at the hardest braking the filter counts on (:meth:`_brake` [m/s^2]), after a control period at its present
        speed (it reacts no faster than the controller), reaches past it. A standing human
        (below ``clear_speed``) is not committed: it starts again only when SUMO lets it."""
        if float(world.v[k]) < self.settings.clear_speed:  # standing (at its stop line, held by SUMO's right of way)
            return False
        return self._would_stop_in(world, k, enter)

    def _stay_out_noisy(self, world: World, k: int, s_stop: float, enter: float, margin: float,
                        own: tuple | None = None) -> float | None:
        """:meth:`_stay_out` of the zone widened by ``gap_slack`` (``enter`` [m]); if the vehicle's
        reading is already inside that widened start but it can still stop short of the zone
        itself, it stops as soon as it can (hardest braking, a standing one stays): it is not
        committed, and under the link's noise the zone's own edge by its reading is no safe
        target. A vehicle standing short of its zone, read inside the widened one, was otherwise
        let drive into another standing in the crossing (fokr38 over a 1 m noisy link)."""
        a = self._stay_out(world, k, s_stop, enter, margin, own)
        if a is not None or self.gap_slack <= 0.0:
            return a
        s_k, v_k = float(world.s[k]), float(world.v[k])  # [m], [m/s]
        brake = self._brake(world, k)  # [m/s^2] < 0
        if s_k + v_k * v_k / (-2.0 * brake) >= enter + self.gap_slack:
            return None  # it cannot stop short of the zone: committed
        return max(brake, -v_k / self.period)

    def _stay_out(self, world: World, k: int, s_stop: float, enter: float, margin: float,
                  own: tuple | None = None) -> float | None:
        """[m/s^2] the acceleration that keeps vehicle k out of a zone starting at ``enter`` [m]:
        stop at its stop line (less ``safety_margin``) if it has not reached it and can, else
        before the zone (less ``margin`` [m], else less ``safety_margin``, or at its edge when
        already within them); None if it cannot any more (inside, or too fast). ``own``: (the
        step's LateralPairs, k's row): a slow vehicle (below ``clear_speed``) past its stop line
        standing inside another of its crossing zones that it can leave short of this one drives
        on out of it and stands between the two (:func:`zone_exit`, :func:`creep_acceleration`):
        held where it stood, it blocked that crossing's vehicle, which waited for it while
        holding up a third, who held this one back (a cycle of three in demand_balanced_high:
        docs/design.md, "A gridlock of three")."""
        st = self.settings
        s_k, v_k = float(world.s[k]), float(world.v[k])
        if s_k >= enter:
            return None
        if own is not None and v_k < st.clear_speed and s_k >= s_stop:  # in the junction: it entered to clear
            target = zone_exit(own[0], own[1], s_k, enter, CREEP_CLEARANCE)
            if target is not None:
                return creep_acceleration(s_k, v_k, target, st.clear_accel, self.period)
        for target in (s_stop - st.safety_margin, enter - margin, enter - st.safety_margin, enter - 0.05):
            if target <= s_k:
                continue
            a = stopping_acceleration(s_k, v_k, target)
            if a is not None and a >= self._brake(world, k):
                return a
        return max(self._brake(world, k), -v_k / self.period) if v_k < 0.1 else None
