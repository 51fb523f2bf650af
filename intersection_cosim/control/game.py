"""``nash`` and ``stackelberg``: the paper's decision process (Algorithm 1) in the closed loop.

Every control period, for the vehicles that are ready to enter or passing the conflict zone:

1. **Risk and trigger.** Each controlled vehicle is expanded into one row per exit lane it may
   still choose (Case 2's V3 has two). The ETM (:func:`~intersection_cosim.models.risk.event_trigger`,
   Eqs. 9 and 39) evaluates Gamma_cp for every pair of rows of different vehicles whose paths
   meet. A cross or confluence pair whose Gamma_cp exceeds Gamma_sf in any combination of exit
   lanes plays a game; with the ETM off (``--no-etm``) every such pair that has not yet passed its
   conflict point plays one, every step.
2. **Leaders.** A leader-follower relation (same approach lane, or a confluence after the merge)
   enters the follower's own cost as J_log (Eqs. 15-18) against the leader's predicted trajectory:
   its previous plan shifted by one period when it is controlled, constant speed otherwise. The
   leader does not care about its follower (its cost has no term for it), so this is not a game.
   On two paths that part (same approach lane, different exits) the leader counts only until its
   rear has left the shared stretch (``_Leader.until``).
3. **Games.** Each triggered pair plays the pairwise game of Algorithm 1 (Nash: iterated best
   response; Stackelberg: the vehicle with the smaller TCP leads), warm-started from the pair's
   previous plans shifted by the periods since they were solved (up to half the horizon), or,
   for a pair that has not played lately, from the plans its two players drive (what a cold
   start would first compute again). When a player may still choose its exit lane, the pair's
   continuous game is solved for every combination of exit lanes and a pure equilibrium of the
   resulting matrix game is taken (:func:`~intersection_cosim.games.lane_choice.lane_choice_game`);
   leaving the preferred exit lane costs J_lk (Eq. 23).
4. **Alone.** A vehicle in no game optimises its own cost with k_lat = 0 (its J_log and J_e only),
   choosing its exit lane the same way among its own options. It re-plans only when an input of
   that problem moved (``_reuse_solo_plan``: event-triggered, like the ETM), else keeps its last
   plan shifted, which answers the same problem seen one period later.
5. **Several games, one vehicle** (rule): the vehicle applies the plan of the game whose first
   acceleration is the lowest, and takes that game's exit lane. Why this is safe: every game's
   plan for the vehicle keeps the safety cost of *that* pair low given the partner's equilibrium
   plan. Taking the lowest acceleration keeps the vehicle at or behind the position each partner's
   plan assumes over the next period, so a partner that planned to pass first only gains margin,
   and a partner that planned to pass second sees the vehicle's actual, slower progress at the
   next control step (0.1 s later), when the pair's game is played again from the measured
   states. Braking harder than any single game asks is never needed: the lowest acceleration is
   one of the games' own plans, bounded by a_min.

**Anytime step.** Games are played most urgent first (smaller TCP), then solo vehicles nearest
their stop line; work that would not finish before the budget less ``anytime_reserve`` is
deferred and its vehicles keep their last plan, shifted (``Decisions.deferred``). The safety
filter (control/safety.py) then checks every acceleration, fresh or kept.

Decisions are written back as accelerations (held over the period; the adapter turns them into
exact speed commands) and exit lanes (enforced by the adapter when the vehicle enters the
junction). A vehicle that has left the conflict zone is handed back to SUMO's driver model.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from intersection_cosim.control.base import ControlContext, Decisions, World
from intersection_cosim.control.safety import braking_plan, krauss_safe_speed, occupancy, stopping_acceleration
from intersection_cosim.games.lane_choice import lane_change_cost, lane_choice_game
from intersection_cosim.games.nash import nash_equilibrium
from intersection_cosim.games.qp import reset_workspaces, solve_count
from intersection_cosim.games.problem import Interaction, Plan, Player, Problem, safe_plan, shift_plan
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.games.stackelberg import stackelberg_equilibrium
from intersection_cosim.models.prediction import all_pairs
from intersection_cosim.models.risk import event_trigger
from intersection_cosim.models.cost import time_to_conflict_point
from intersection_cosim.network.conflicts import (KIND_CONFLUENCE, KIND_CROSS, KIND_FOLLOWING,
                                                  load_conflict_table, point_zone)
from intersection_cosim.network.spec import LANE_INDEX, LANE_USE, IntersectionSpec

log = logging.getLogger(__name__)

SOLVERS = {"nash": nash_equilibrium, "stackelberg": stackelberg_equilibrium}


@dataclass
class _Rows:
    """The ETM's rows: one per (vehicle, exit lane it may take)."""

    vehicle: np.ndarray  # (R,) index into the World
    option: list[str]  # exit lane of the row
    path: list[str]  # path id of the row
    pidx: np.ndarray  # (R,) index of the row's path in the conflict table


FAR = 1.0e4  # [m] added to a leader's predicted position where it no longer constrains its follower


@dataclass
class _Leader:
    vehicle: int  # World index of the leader
    offset: float  # [m] leader's s in the follower's path = s_leader + offset
    gap: float  # [m] distance along the shared stretch (front to front)
    until: float = math.inf  # [m] leader's s (own path) past which it no longer constrains the
    #                          follower: the end of a diverging shared stretch plus a length


class _Lateral(NamedTuple):
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


@dataclass
class _Game:
    a: int  # World index of the first player (a < b)
    b: int
    combos: dict = field(default_factory=dict)  # (option a, option b) -> list of Interaction


@dataclass
class ConvergenceRecord:
    """One game's solve: the data of the paper's Fig. 3."""

    time: float  # [s]
    vehicle_a: str
    vehicle_b: str
    solver: str
    status: str
    iterations: int
    residuals: tuple[float, ...]  # [m/s^2] per iteration
    costs: tuple[float, ...]  # [-] final cost of each player


class GameController:
    """The game-theoretic decision layer; ``equilibrium`` is ``"nash"`` or ``"stackelberg"``."""

    controls_vehicles = True

    def __init__(self, equilibrium: str, settings: GameSettings | None = None,
                 junction_type: str = "priority"):
        if equilibrium not in SOLVERS:
            raise ValueError(equilibrium)
        self.equilibrium = equilibrium
        self.solver = SOLVERS[equilibrium]
        self.gs = settings or GameSettings()
        self.junction_type = junction_type
        self.plans: dict[str, Plan] = {}  # plan applied at the last step, per vehicle
        self.options: dict[str, str] = {}  # exit lane chosen at the last step
        # game or solo key -> (when its plans were solved [s], the plans)
        self.warm: dict[tuple, tuple[float, tuple[Plan, ...]]] = {}
        self.controlled: set[str] = set()
        self.convergence: list[ConvergenceRecord] = []
        self.filtered = 0  # accelerations the safety filter lowered
        self.cleared = 0  # accelerations the safety filter raised to clear a crossing (box rule)
        self._game_s = {False: 0.004, True: 0.002}  # [s] running mean wall time of one exit-lane
        #                                              combination of a game, cold / warm
        self._solo_s = 0.001  # [s] running mean wall time of one solo solve
        self._entered: dict[str, float] = {}  # [s] when each vehicle entered the junction
        self._choice_age: dict[str, int] = {}  # steps since a vehicle's exit lane was last decided
        self._held: set[str] = set()  # vehicles the filter held back at a crossing this step
        self._held_before: set[str] = set()  # ... at the step before
        self._solo_inputs: dict[str, tuple] = {}  # vehicle -> (steps since its solo solve, exit, leader prediction used)
        self._decided_at: float | None = None  # [s] time of the last decide call
        self._applied: dict[str, Plan] = {}  # plans applied before that call

    # ------------------------------------------------------------------ setup
    def setup(self, context: ControlContext) -> None:
        self.ctx = context
        self.model = context.model
        self.paths = context.paths
        if context.solver is not None:
            self.gs = context.solver
        self.table = load_conflict_table(context.net_file, context.model.vehicle_width,
                                         context.model.vehicle_length)
        self.etm = context.etm
        self.shift = max(1, int(round(context.control_period / self.gs.dt)))
        # a solo vehicle's SQP stops after solo_max_iter steps and goes on at the next period
        self._solo_gs = dataclasses.replace(self.gs, nash_max_iter=self.gs.solo_max_iter)
        reset_workspaces()
        self._warm_up()

    def _warm_up(self) -> None:
        """Solve one small game before the first step, so that OSQP's workspaces and the lazy
        imports are built outside the timed control loop (otherwise the first step can overrun
        its budget, and a fallback there would make the run depend on the machine's speed)."""
        problem = Problem((Player(0.0, 5.0, 0.5), Player(0.0, 5.0, 0.5)),
                          (Interaction.cross(0, 1, 15.0, 14.0),))
        self.solver(problem, self.gs, self.model)
        nash_equilibrium(Problem((Player(0.0, 5.0, 0.5),)), self.gs, self.model)

    # ------------------------------------------------------------------ one step
    def decide(self, world: World, deadline: float) -> Decisions:
        solved_before = solve_count()
        decisions = self._decide(world, deadline)
        decisions.qp_solves = solve_count() - solved_before
        return decisions

    def _decide(self, world: World, deadline: float) -> Decisions:
        self._decided_at, self._applied = world.time, dict(self.plans)  # for the fallback
        self._held_before, self._held = self._held, set()
        n = len(world)
        ids = world.ids
        active = [k for k in range(n) if world.role[k] != "outside"]
        active_set = set(active)
        decisions = Decisions()
        decisions.release = sorted(self.controlled - {ids[k] for k in active})
        self.controlled = {ids[k] for k in active}
        for vid in decisions.release:
            self.plans.pop(vid, None)
            self.options.pop(vid, None)
            self._solo_inputs.pop(vid, None)
            self._choice_age.pop(vid, None)
            self._entered.pop(vid, None)
        self._record_entries(world)
        if not active:
            return decisions

        rows = self._rows(world, active_set)
        present = {ids[k] for k in active}
        # Warm starts are keyed ("solo", vehicle, exit) or ("game", vehicle_a, vehicle_b, exit_a, exit_b).
        self.warm = {key: v for key, v in self.warm.items()
                     if all(x in present for x in (key[1:2] if key[0] == "solo" else key[1:3]))}
        leaders, lateral = self._relations(world, rows, active_set)
        self._effective = self._effective_options(world, rows, leaders, lateral)
        games = self._games(rows, lateral)

        # Anytime step: the most urgent work first; what would not fit before the deadline less
        # a reserve (for the safety filter) is deferred: its vehicles keep their last plan, shifted.
        start = time.perf_counter()
        cutoff = deadline - self.gs.anytime_reserve * max(deadline - start, 0.0)
        in_game: dict[int, list[tuple[float, Plan, str]]] = {}
        for game in sorted(games.values(), key=lambda g: self._urgency(world, g)):
            ka, kb = game.a, game.b
            warm = any(key[:3] == ("game", ids[ka], ids[kb]) for key in self.warm)
            combos = len(self._options(world, ka)) * len(self._options(world, kb))
            if time.perf_counter() + 2.0 * combos * self._game_s[warm] > cutoff:  # 2x: room for a slow one
                decisions.deferred += 1
                self._game_s[warm] *= 0.95  # so one slow solve cannot defer every later game
                for k in (ka, kb):
                    plan = self._kept_plan(world, k)
                    in_game.setdefault(k, []).append((float(plan.accelerations[0]), plan, self._held_option(world, k)))
                continue
            t0 = time.perf_counter()
            result, choice = self._play(world, game, leaders, cutoff)
            self._game_s[warm] = 0.8 * self._game_s[warm] + 0.2 * (time.perf_counter() - t0) / combos
            decisions.games += 1
            decisions.iterations += result.iterations
            decisions.pairs.append((ids[ka], ids[kb]))
            for k, plan, option in ((ka, result.plans[0], choice[0]), (kb, result.plans[1], choice[1])):
                in_game.setdefault(k, []).append((float(plan.accelerations[0]), plan, option))
            self.convergence.append(ConvergenceRecord(
                world.time, ids[ka], ids[kb], self.equilibrium, result.status, result.iterations,
                tuple(float(r) for r in result.residuals), tuple(float(c) for c in result.costs)))

        solo = sorted((k for k in active if k not in in_game),
                      key=lambda k: self.paths[world.path_ids[k]].s_stop - float(world.s[k]))
        for k in active:
            if k in in_game:
                _, plan, option = min(in_game[k], key=lambda e: e[0])  # the rule of the docstring
                self._solo_inputs.pop(ids[k], None)
                self._apply(world, k, plan, option, decisions)
        for k in solo:
            plan, option = self._alone(world, k, leaders, cutoff, decisions)
            self._apply(world, k, plan, option, decisions)
        if self.gs.safety_filter:
            self._safety_filter(world, rows, leaders, lateral, decisions)
        return decisions

    def _record_entries(self, world: World) -> None:
        for k in range(len(world)):
            if world.role[k] == "passing":
                self._entered.setdefault(world.ids[k], world.time)

    def _apply(self, world: World, k: int, plan: Plan, option: str, decisions: Decisions) -> None:
        vid = world.ids[k]
        self.plans[vid] = plan
        self.options[vid] = option
        decisions.accel[vid] = float(plan.accelerations[0])
        if len(world.exit_choices.get(vid, ())) > 1:
            decisions.exit_lane[vid] = option

    def _urgency(self, world: World, game: _Game) -> tuple[float, int, int]:
        """[s] the smaller time to its conflict point of the pair (TCP, Eqs. 21-22): games are
        played in this order, most urgent first (ties by vehicle index, deterministic)."""
        floor = self.model.tcp_speed_floor
        s_a, v_a, s_b, v_b = (float(x) for x in (world.s[game.a], world.v[game.a], world.s[game.b], world.v[game.b]))
        tcp = math.inf
        for inters in game.combos.values():
            for it in inters:
                if it.lateral:
                    tcp = min(tcp, time_to_conflict_point(it.s_cp_i - s_a, v_a, floor),
                              time_to_conflict_point(it.s_cp_j - s_b, v_b, floor))
        return (tcp, game.a, game.b)

    def _shift(self, plan: Plan) -> Plan:
        """``plan`` moved on by one control period (``self.shift`` solver steps)."""
        for _ in range(self.shift):
            plan = shift_plan(plan)
        return plan

    def _from_state(self, world: World, k: int, a) -> Plan:
        """The plan of accelerations ``a`` [m/s^2] started from vehicle k's measured state."""
        return Plan.from_accelerations(float(world.s[k]), float(world.v[k]), a, self.gs.dt)

    def _kept_plan(self, world: World, k: int) -> Plan:
        """Vehicle k's last applied plan shifted by one period and started from its measured
        state; comfortable braking if it has none."""
        plan = self.plans.get(world.ids[k])
        if plan is not None:
            return self._from_state(world, k, self._shift(plan).accelerations)
        return self._from_state(world, k, np.full(self.gs.steps, -self.gs.comfort_brake))

    def _held_option(self, world: World, k: int) -> str:
        """The exit lane vehicle k holds: its last choice, else its path's."""
        return self.options.get(world.ids[k], self.paths[world.path_ids[k]].exit_lane)

    def _safety_filter(self, world: World, rows: _Rows, leaders, lateral, decisions: Decisions) -> None:
        """Lower accelerations whose plans would collide (control/safety.py).

        Two passes: a vehicle braked in the first pass is checked again in the second with its
        braking plan (constant capped deceleration to a stop), so a vehicle made to stop is seen
        by every other crossing it now blocks in the same step.
        """
        gs, ms = self.gs, self.model
        period = self.ctx.control_period
        ids, k_of = world.ids, rows.vehicle
        chosen = [rows.option[r] == self.options.get(ids[k_of[r]], rows.option[r]) for r in range(len(k_of))]
        cap: dict[str, float] = {}
        for r, lead in leaders.items():
            vid = ids[k_of[r]]
            if vid not in decisions.accel or not chosen[r]:
                continue
            gap = lead.gap - ms.vehicle_length - gs.safety_margin  # [m] bumper to bumper, less margin
            v_safe = krauss_safe_speed(gap, float(world.v[lead.vehicle]), -gs.a_min, period)
            cap[vid] = min(cap.get(vid, math.inf), (v_safe - float(world.v[k_of[r]])) / period)
        leader_cap = dict(cap)  # [m/s^2] the caps behind a leader alone
        plans = dict(self.plans)
        clear: set[str] = set()  # vehicles in a crossing that another one waits for
        for _pass in range(2):
            for vid in clear:
                if vid in plans and float(plans[vid].accelerations[0]) < gs.clear_accel:
                    plans[vid] = braking_plan(plans[vid], gs.clear_accel)  # constant: it drives on
            for vid, limit in cap.items():
                if vid in plans and limit < float(plans[vid].accelerations[0]):
                    plans[vid] = braking_plan(plans[vid], max(limit, gs.a_min))
            self._guard_crossings(world, rows, lateral, chosen, plans, cap, period, clear)
        for vid in clear:
            # the box rule: a vehicle inside a crossing that another waits for clears it (its own
            # plan may wait for the other, as a game played before the wait can say), unless a
            # cap of its own holds it back
            if vid in decisions.accel and decisions.accel[vid] < gs.clear_accel:
                decisions.accel[vid] = min(gs.clear_accel, cap.get(vid, math.inf))
                self.cleared += 1
        for vid, limit in cap.items():
            if vid in decisions.accel and limit < decisions.accel[vid]:
                decisions.accel[vid] = max(limit, gs.a_min)
                self.filtered += 1
                if limit < leader_cap.get(vid, math.inf):  # held back at a crossing
                    self._held.add(vid)

    def _guard_crossings(self, world: World, rows: _Rows, lateral, chosen, plans, cap, period,
                         clear: set[str]) -> None:
        """Caps (into ``cap``) for every crossing the ``plans`` would share within
        ``safety_time_gap`` (control/safety.py).

        Who yields follows one priority order, so that waits cannot form a cycle (a deadlock of
        vehicles stopped in each other's zones): a vehicle inside the junction ranks by the time
        it entered it (first in, first out, like a queue), ahead of every vehicle not yet in;
        among those, the one that reaches the crossing first ranks higher (``yield_order``: at
        its current speed, the paper's leader rule, except for a pair that played its game, which
        keeps the game's order; or by the plans). The queue rule for vehicles inside holds even
        against a game's order: a game lets a vehicle into a crossing ahead of one that entered
        the junction before it, and once the pair's trigger is off (both slowed down) the queue
        order returns with both committed. With queues behind them that closed a cycle of waits
        (1800 veh/h, 20 ms budget: four vehicles stood in the junction for good). The lower-ranked one
        yields if it can still stay out of its zone (waiting at its stop line if it has not
        reached it: AIM's rule, enter only to clear); else the higher-ranked one yields if it
        can; else both are in (or committed) and the lower-ranked one holds back as hard as it
        may while the other clears the crossing. A higher-ranked vehicle already inside its zone
        that a lower-ranked one yields to is put in ``clear``: it must drive out.
        """
        gs = self.gs
        ids, k_of = world.ids, rows.vehicle
        for lat in lateral:
            ri, rj = lat.ri, lat.rj
            if not (chosen[ri] and chosen[rj]):
                continue
            ki, kj = int(k_of[ri]), int(k_of[rj])
            pi, pj = plans.get(ids[ki]), plans.get(ids[kj])
            if pi is None and world.role[ki] == "outside":
                pi = self._coasting_plan(world, ki)
            if pj is None and world.role[kj] == "outside":
                pj = self._coasting_plan(world, kj)
            if pi is None or pj is None:
                continue
            in_i, out_i = occupancy(pi, *lat.zone_i)
            in_j, out_j = occupancy(pj, *lat.zone_j)
            if in_i >= out_j + gs.safety_time_gap or in_j >= out_i + gs.safety_time_gap:
                continue  # the plans keep the crossing clear
            if gs.yield_order == "tcp" and not lat.play:
                # time to the zone at the current speed (Eqs. 21-22); a pair that played its
                # game this step keeps the equilibrium's order (its plans), so the filter never
                # overrules a game's decision, it only enforces it
                floor = self.model.tcp_speed_floor
                ti = time_to_conflict_point(lat.zone_i[0] - float(world.s[ki]), float(world.v[ki]), floor)
                tj = time_to_conflict_point(lat.zone_j[0] - float(world.s[kj]), float(world.v[kj]), floor)
            else:  # "plan" (or a game pair): when the plans reach the zone
                ti, tj = in_i, in_j
            lower_first = sorted(((self._rank(world, ki, ti), ki, lat.ri, lat.zone_i[0]),
                                  (self._rank(world, kj, tj), kj, lat.rj, lat.zone_j[0])), reverse=True)
            for n, (_rank, k, r, enter) in enumerate(lower_first):
                a = self._stay_out(world, k, float(self.table.s_stop[rows.pidx[r]]), enter)
                if a is not None:
                    cap[ids[k]] = min(cap.get(ids[k], math.inf), a)
                    if n == 0:
                        _, other, _, enter_other = lower_first[1]
                        if float(world.s[other]) >= enter_other and float(world.v[other]) < gs.clear_speed:
                            clear.add(ids[other])
                    break
            else:
                k = lower_first[0][1]
                cap[ids[k]] = min(cap.get(ids[k], math.inf), max(gs.a_min, -float(world.v[k]) / period))

    def _coasting_plan(self, world: World, k: int) -> Plan:
        """A vehicle SUMO drives again (it has left the junction), predicted at constant speed."""
        return self._from_state(world, k, np.zeros(self.gs.steps))

    def _rank(self, world: World, k: int, t_in: float) -> tuple:
        """Priority of vehicle k at a crossing it would reach in ``t_in`` [s]: smaller is first.
        A vehicle that has left the junction (SUMO drives it, its rear may still be in the
        crossing) comes first: it cannot yield."""
        if world.role[k] == "outside":
            return (-1, 0.0, world.ids[k])
        entered = self._entered.get(world.ids[k])
        return (0, entered, world.ids[k]) if entered is not None else (1, t_in, world.ids[k])

    def _stay_out(self, world: World, k: int, s_stop: float, enter: float) -> float | None:
        """[m/s^2] the acceleration that keeps vehicle k out of a zone starting at ``enter`` [m]:
        stop at its stop line (less the margin) if it has not reached it and can, else before
        the zone (less the margin, or at its edge when already within the margin); None if it
        cannot any more (inside, or too fast)."""
        gs = self.gs
        s_k, v_k = float(world.s[k]), float(world.v[k])
        if s_k >= enter:
            return None
        for target in (s_stop - gs.safety_margin, enter - gs.safety_margin, enter - 0.05):
            if target <= s_k:
                continue
            a = stopping_acceleration(s_k, v_k, target)
            if a is not None and a >= gs.a_min:
                return a
        return max(gs.a_min, -v_k / self.ctx.control_period) if v_k < 0.1 else None

    def fallback(self, world: World) -> Decisions:
        """The last applied plan shifted by one period (comfortable braking where there is none),
        through the safety filter.

        Called by the scheduler when ``decide`` overran its budget or failed: the plans that
        ``decide`` made in this step are discarded, the ones applied at the previous step are
        shifted. The safety filter still runs (it costs about a millisecond, the games are what
        overran): in long stretches of missed deadlines the shifted plans go stale, and without it
        they once drove two vehicles into each other under Stackelberg at 1200 veh/h.
        """
        if self._decided_at == world.time:
            self.plans = self._applied
        decisions = Decisions(fallback=True)
        self._record_entries(world)
        period = self.ctx.control_period
        active = set()
        for k in range(len(world)):
            vid = world.ids[k]
            if world.role[k] == "outside":
                continue
            active.add(k)
            plan = self._kept_plan(world, k)
            self.plans[vid] = plan
            decisions.accel[vid] = max(float(plan.accelerations[0]), -float(world.v[k]) / period)
            self.controlled.add(vid)
        if self.gs.safety_filter and active:
            rows = self._rows(world, active)
            leaders, lateral = self._relations(world, rows, active)
            self._safety_filter(world, rows, leaders, lateral, decisions)
        return decisions

    # ------------------------------------------------------------------ pieces
    def _rows(self, world: World, active: set[int]) -> _Rows:
        """The ETM's rows of this step; also indexes them as ``self._rows_of[(vehicle, exit)]``."""
        rows = self._build_rows(world, active)
        self._rows_of = {(int(k), o): r for r, (k, o) in enumerate(zip(rows.vehicle, rows.option))}
        return rows

    def _build_rows(self, world: World, active: set[int]) -> _Rows:
        """One row per exit lane a vehicle may still take; a vehicle farther than
        ``lane_choice_range`` from its stop line has one row, its current exit lane."""
        vehicle, option, path = [], [], []
        for k in range(len(world)):
            pid = world.path_ids[k]
            opts = world.exit_choices.get(world.ids[k], ()) if k in active else ()
            if len(opts) > 1:
                base = pid.rsplit("_", 1)[0]
                if self.paths[pid].s_stop - float(world.s[k]) > self.gs.lane_choice_range:
                    held = self._held_option(world, k)
                    opts = (held if held in opts else opts[0],)  # too far out to choose yet
                for o in opts:
                    vehicle.append(k)
                    option.append(o)
                    path.append(f"{base}_{o}")
            else:
                vehicle.append(k)
                option.append(self.paths[pid].exit_lane)
                path.append(pid)
        return _Rows(np.asarray(vehicle, dtype=np.intp), option, path, self.table.indices(path))

    def _relations(self, world: World, rows: _Rows, active: set[int]):
        """Leaders of every row and the lateral (cross / confluence) row pairs, from the ETM.

        A lateral pair stays in the list until one of the two has cleared the crossing (its front
        past ``zone_out`` of the conflict table, for confluence pairs the point plus a vehicle
        length and half a width), so the safety filter guards it that long; it carries J_lat and
        may play a game only while neither is more than ``conflict_clearance`` past the point.
        """
        ms = self.model
        table = self.table
        r = len(rows.vehicle)
        i, j = all_pairs(r)
        keep = rows.vehicle[i] != rows.vehicle[j]
        i, j = i[keep], j[keep]
        k_of = rows.vehicle
        pidx = rows.pidx
        risk = event_trigger(table, pidx, world.s[k_of], world.v[k_of], world.kappa[k_of], ms, pairs=(i, j))
        leaders: dict[int, _Leader] = {}  # row -> nearest leader
        lateral: list[_Lateral] = []
        s_i_now, s_j_now = world.s[k_of[risk.i]], world.s[k_of[risk.j]]
        d_i = risk.s_cp_i - s_i_now
        d_j = risk.s_cp_j - s_j_now
        p_i, p_j = pidx[risk.i], pidx[risk.j]
        zin_i, zout_i = table.zone_in[p_i, p_j], table.zone_out[p_i, p_j]
        zin_j, zout_j = table.zone_in[p_j, p_i], table.zone_out[p_j, p_i]
        clear = ms.conflict_clearance
        width, length = ms.vehicle_width, ms.vehicle_length
        for m in range(len(risk.i)):
            ri, rj = int(risk.i[m]), int(risk.j[m])
            if risk.leader_follower[m]:
                if min(d_i[m], d_j[m]) < -clear and risk.kind[m] != KIND_CONFLUENCE:
                    continue  # the leader has left the shared stretch
                lead, follow = (ri, rj) if d_i[m] < d_j[m] else (rj, ri)
                s_cp_f = risk.s_cp_i[m] if follow == ri else risk.s_cp_j[m]
                s_cp_l = risk.s_cp_j[m] if follow == ri else risk.s_cp_i[m]
                gap = abs(d_i[m] - d_j[m])
                if follow in leaders and leaders[follow].gap <= gap:
                    continue
                # two paths from one approach lane that part (s_cp = end of the shared stretch,
                # where the centre lines are a width apart): once the leader's rear is past it,
                # the follower may draw level on its own branch (Case 2's V3 beside V4)
                until = s_cp_l + clear if risk.kind[m] == KIND_FOLLOWING else math.inf
                leaders[follow] = _Leader(int(k_of[lead]), float(s_cp_f - s_cp_l), float(gap), float(until))
                continue
            if risk.kind[m] not in (KIND_CROSS, KIND_CONFLUENCE):
                continue
            both = k_of[ri] in active and k_of[rj] in active
            if not both and k_of[ri] not in active and k_of[rj] not in active:
                continue
            s_i, s_j = float(risk.s_cp_i[m]), float(risk.s_cp_j[m])
            if risk.kind[m] == KIND_CROSS:
                kind = "cross"
                zone_i, zone_j = (float(zin_i[m]), float(zout_i[m])), (float(zin_j[m]), float(zout_j[m]))
            else:
                kind = "confluence"
                zone_i, zone_j = point_zone(s_i, length, width), point_zone(s_j, length, width)
            if s_i_now[m] > zone_i[1] or s_j_now[m] > zone_j[1]:
                continue  # one of them has cleared the crossing
            # a vehicle that has left the junction (front past its exit, handed back to SUMO) may
            # still have its rear in the crossing: guarded, no game
            live = both and not (d_i[m] < -clear or d_j[m] < -clear)
            play = live and (bool(risk.trigger[m]) or not self.etm)
            lateral.append(_Lateral(ri, rj, kind, s_i, s_j, live, play, zone_i, zone_j))
        return leaders, lateral

    def _games(self, rows: _Rows, lateral) -> dict[tuple[int, int], _Game]:
        """Vehicle pairs that play a game, with the interactions of each exit-lane combination."""
        games: dict[tuple[int, int], _Game] = {}
        triggered = {tuple(sorted((int(rows.vehicle[lat.ri]), int(rows.vehicle[lat.rj]))))
                     for lat in lateral if lat.play}
        for lat in lateral:
            if not lat.live:
                continue
            ri, rj, kind, s_i, s_j = lat.ri, lat.rj, lat.kind, lat.s_i, lat.s_j
            ka, kb = int(rows.vehicle[ri]), int(rows.vehicle[rj])
            if ka > kb:
                ka, kb, ri, rj, s_i, s_j = kb, ka, rj, ri, s_j, s_i
            if (ka, kb) not in triggered:
                continue
            if rows.option[ri] not in self._effective[ka] or rows.option[rj] not in self._effective[kb]:
                continue
            game = games.setdefault((ka, kb), _Game(ka, kb))
            make = Interaction.cross if kind == "cross" else Interaction.confluence
            game.combos.setdefault((rows.option[ri], rows.option[rj]), []).append(make(0, 1, s_i, s_j))
        return games

    def _options(self, world: World, k: int) -> tuple[str, ...]:
        """Exit lanes worth deciding between for vehicle ``k`` this step."""
        return self._effective[k]

    def _effective_options(self, world: World, rows: _Rows, leaders, lateral) -> dict[int, tuple[str, ...]]:
        """Per vehicle, the exit lanes whose choice changes whom it interacts with.

        An exit lane matters only if it changes the vehicle's partners: whom it crosses or merges
        with, or whom it follows (Case 2's V3: behind V4 on the inner lane, or merging with V1 on
        the middle lane). Where every option gives the same partners (Case 1's left turns cross
        the same vehicles whichever exit lane they take), only the preferred one is solved: the
        previous step's choice, else the movement's default lane. This keeps the lane-choice
        matrix game for the decisions it is for, at one continuous solve otherwise.

        Where the choice matters it is decided every ``lane_choice_period`` control steps (the
        discrete decision at a slower rate than the continuous one, as in multi-rate MPC); in
        between the vehicle holds its last choice and only that combination is solved, warm.
        """
        partners: dict[int, set] = {r: set() for r in range(len(rows.vehicle))}
        for lat in lateral:
            if lat.live:
                partners[lat.ri].add(int(rows.vehicle[lat.rj]))
                partners[lat.rj].add(int(rows.vehicle[lat.ri]))
        sig: dict[int, dict[str, tuple]] = {}
        for r, k in enumerate(rows.vehicle):
            lead = leaders.get(r)
            sig.setdefault(int(k), {})[rows.option[r]] = (frozenset(partners[r]),
                                                           lead.vehicle if lead else None)
        out = {}
        for k, by_option in sig.items():
            opts = tuple(by_option)
            vid = world.ids[k]
            previous = self.options.get(vid)
            if len(opts) > 1 and len(set(by_option.values())) == 1:
                path = self.paths[world.path_ids[k]]
                opts = (previous if previous in by_option else LANE_USE[path.lane][path.movement][0],)
            elif len(opts) > 1:
                age = self._choice_age.get(vid)
                if age is not None and age + 1 < self.gs.lane_choice_period and previous in by_option:
                    opts = (previous,)  # hold the last choice between decisions
                    self._choice_age[vid] = age + 1
                else:
                    self._choice_age[vid] = 0
            out[k] = opts
        return out

    def _lane_costs(self, world: World, k: int) -> dict[str, float]:
        """J_lk of each exit lane: the lateral offset from the movement's preferred exit lane."""
        path = self.paths[world.path_ids[k]]
        preferred = LANE_USE[path.lane][path.movement][0]
        width = IntersectionSpec().lane_width  # [m]
        return {o: lane_change_cost(width * abs(LANE_INDEX[o] - LANE_INDEX[preferred]), self.model)
                for o in self._options(world, k)}

    def _leader_trajectory(self, world: World, leader: _Leader) -> tuple[np.ndarray, np.ndarray]:
        """Leader's predicted positions (in its own path) and speeds s_1..s_N, v_1..v_N."""
        k = leader.vehicle
        plan = self.plans.get(world.ids[k])
        plan = self._from_state(world, k, self._shift(plan).accelerations) if plan is not None \
            else self._coasting_plan(world, k)
        s, v = plan.positions[1:], plan.speeds[1:]
        parted = s > leader.until
        if parted.any():  # past the end of the shared stretch the leader is out of the way
            s = np.where(parted, s + FAR, s)
        return s, v

    def _player(self, world: World, k: int, option: str, leaders: dict[int, _Leader],
                rows_of: dict[tuple[int, str], int], partner: int | None = None) -> Player:
        row = rows_of[(k, option)]
        leader = leaders.get(row)
        exo = None
        if leader is not None and leader.vehicle != partner:
            s_l, v_l = self._leader_trajectory(world, leader)
            exo = (s_l + leader.offset, v_l)
        return Player(s0=float(world.s[k]), v0=float(world.v[k]), kappa=float(world.kappa[k]),
                      v_max=self._desired_speed(world, k), name=world.ids[k], leader=exo)

    def _desired_speed(self, world: World, k: int) -> float | None:
        """[m/s] vehicle k's own desired speed, None for the model's v_max."""
        if world.desired_speed is None or not math.isfinite(float(world.desired_speed[k])):
            return None
        return float(world.desired_speed[k])

    def _play(self, world: World, game: _Game, leaders, deadline: float):
        ka, kb = game.a, game.b
        rows_of = self._rows_of
        opts_a, opts_b = self._options(world, ka), self._options(world, kb)
        problems, warm = {}, {}
        for oa in opts_a:
            for ob in opts_b:
                inters = list(game.combos.get((oa, ob), []))
                for f, l, of, ol in ((ka, kb, oa, ob), (kb, ka, ob, oa)):
                    lead = leaders.get(rows_of[(f, of)])
                    if lead is not None and lead.vehicle == l:
                        inters.append(Interaction.following(0 if f == ka else 1, 0 if l == ka else 1, lead.offset))
                pa = self._player(world, ka, oa, leaders, rows_of, partner=kb)
                pb = self._player(world, kb, ob, leaders, rows_of, partner=ka)
                problems[(oa, ob)] = Problem((pa, pb), tuple(inters))
                start = self._warm_start(world, ("game", world.ids[ka], world.ids[kb], oa, ob))
                if start is None:  # a newly triggered pair: from the plans its players drive
                    start = tuple(self._driven_plan(world, k, o) for k, o in ((ka, oa), (kb, ob)))
                    start = None if all(p is None for p in start) else start
                if start is not None:
                    warm[(oa, ob)] = start
        kwargs = {"deadline": deadline}
        if len(problems) == 1:
            (combo, problem), = problems.items()
            result = self.solver(problem, self.gs, self.model, warm_start=warm.get(combo), **kwargs)
            choice, results = combo, {combo: result}
        else:
            lc = lane_choice_game(problems, [self._lane_costs(world, ka), self._lane_costs(world, kb)],
                                  solver=self.solver, settings=self.gs, model_settings=self.model,
                                  warm_starts=warm, **kwargs)
            result, choice, results = lc.result, lc.choice, lc.results
        for combo, res in results.items():  # every combination warm-starts its own next solve
            if res.status != "solver failure":
                self._store_warm(world, ("game", world.ids[ka], world.ids[kb], *combo), res.plans)
        if result.status == "solver failure":
            log.warning("t=%.2f s: %s game %s-%s: solver failure (%s); braking comfortably",
                        world.time, self.equilibrium, world.ids[ka], world.ids[kb], result.message)
        return result, choice

    def _alone(self, world: World, k: int, leaders, cutoff: float = math.inf,
               decisions: Decisions | None = None) -> tuple[Plan, str]:
        """Best response of a vehicle in no game (k_lat = 0), with its exit-lane choice; past
        ``cutoff`` (perf_counter) a vehicle with a plan keeps it, shifted (counted as deferred)."""
        rows_of = self._rows_of
        vid = world.ids[k]
        opts = self._options(world, k)
        players = {o: self._player(world, k, o, leaders, rows_of) for o in opts}
        if len(opts) == 1 and self._reuse_solo_plan(world, k, opts[0], players[opts[0]]):
            return self.plans[vid], opts[0]
        if vid in self.plans and time.perf_counter() + 2.0 * self._solo_s > cutoff:
            if decisions is not None:
                decisions.deferred += 1
            self._solo_s *= 0.95
            self._solo_inputs.pop(vid, None)
            return self._kept_plan(world, k), self._held_option(world, k)
        t0 = time.perf_counter()
        problems, warm = {}, {}
        for o in opts:
            problems[(o,)] = Problem((players[o],), ())
            if (driven := self._driven_plan(world, k, o)) is not None:
                warm[(o,)] = (driven,)  # the plan it is driving (maybe a game's)
            elif (start := self._warm_start(world, ("solo", vid, o))) is not None:
                warm[(o,)] = start
        solo_gs = self._solo_gs
        if len(problems) == 1:
            (combo, problem), = problems.items()
            result = nash_equilibrium(problem, solo_gs, self.model, warm_start=warm.get(combo))
            choice, results = combo, {combo: result}
        else:
            lc = lane_choice_game(problems, [self._lane_costs(world, k)], solver=nash_equilibrium,
                                  settings=solo_gs, model_settings=self.model, warm_starts=warm)
            result, choice, results = lc.result, lc.choice, lc.results
        for combo, res in results.items():
            if res.status != "solver failure":
                self._store_warm(world, ("solo", vid, combo[0]), res.plans)
        self._solo_s = 0.8 * self._solo_s + 0.2 * (time.perf_counter() - t0)
        plan = result.plans[0]
        if result.status == "solver failure":
            log.warning("t=%.2f s: best response of %s failed (%s); braking comfortably",
                        world.time, vid, result.message)
            plan = safe_plan(problems[choice].players[0], self.gs)
            self._solo_inputs.pop(vid, None)
        elif (result.status != "converged" and vid not in self._held_before
              and not (result.residuals and result.residuals[-1] < self.gs.nash_tol)):
            # real-time iteration: the capped SQP continues from this plan at the next step.
            # A capped step that moved the plan less than nash_tol (the convergence test of the
            # equilibrium iteration, which a one-step solve cannot apply itself) counts as
            # converged, and so does the plan of a vehicle the filter is holding back (its plan
            # is only the intent the filter checks; _reuse_solo_plan)
            self._solo_inputs.pop(vid, None)
        else:
            self._solo_inputs[vid] = (0, choice[0], problems[choice].players[0].leader)
        return plan, choice[0]

    def _reuse_solo_plan(self, world: World, k: int, option: str, player: Player) -> bool:
        """Reuse a solo vehicle's last plan, shifted, instead of solving again (event-triggered
        re-planning, in the spirit of the paper's ETM).

        A vehicle in no game minimises its own cost (J_e, comfort, and J_log against its leader's
        predicted trajectory). If its measured state is where its last plan put it and the
        leader's prediction is the one it answered at its last solve (shifted: the same
        trajectory seen later; within ``solo_leader_tol``; or it moved only where J_log is zero
        along the plan, see ``_leader_inactive``), the problem is that solve's problem moved on
        in time, and the shifted optimal plan is optimal again for all but its appended
        last steps. So it is solved again only when an input changed, after
        ``free_resolve_steps`` steps at the latest (1 = always), or when the shifted plan would
        leave the speed limits. A free vehicle (no leader) is the special case with nothing to
        compare. A vehicle the safety filter held back at a crossing at the last step is off its
        plan by the filter's doing, not because its problem changed, so its plan is kept
        (re-anchored at the measured state: its intent, which the filter goes on checking) until
        it is due, converged or not; a vehicle waiting at its stop line for a crossing otherwise
        solved again every period. (One held back behind its leader goes on solving: its plan
        answers J_log, which the filter's cap only bounds.)
        The safety filter checks reused plans like fresh ones.
        """
        vid = world.ids[k]
        last = self._solo_inputs.get(vid)
        plan = self.plans.get(vid)
        if last is None or plan is None:
            return False
        age, last_option, last_leader = last
        if (age + 1 >= self.gs.free_resolve_steps or last_option != option
                or self.options.get(vid) != option or (last_leader is None) != (player.leader is None)):
            return False
        plan = self._shift(plan)
        v = float(world.v[k])
        v_cap = player.v_max if player.v_max is not None else self.model.v_max  # [m/s]
        off_plan = abs(plan.speeds[0] - v) > 0.05 and vid not in self._held_before
        if off_plan or plan.speeds.max() > v_cap + 1e-6:
            return False
        if player.leader is not None:
            lag = (age + 1) * self.shift  # [steps] since the solve
            s_then, v_then = last_leader
            s_now, v_now = player.leader
            m = len(s_now) - lag
            tol = self.gs.solo_leader_tol
            if m <= 0:
                return False
            moved = (np.abs(s_now[:m] - s_then[lag:]).max() > tol
                     or np.abs(v_now[:m] - v_then[lag:]).max() > tol)
            # a moved prediction matters only where it enters the cost: J_log is zero along a
            # plan that is never faster than the leader and never overlaps it, under the old
            # prediction (so the plan did not answer it) and the new one (so it need not)
            if moved and not (self._leader_inactive(plan, s_then[lag:], v_then[lag:])
                              and self._leader_inactive(plan, s_now, v_now)):
                return False
        self.plans[vid] = self._from_state(world, k, plan.accelerations)
        self._solo_inputs[vid] = (age + 1, option, last_leader)
        return True

    def _leader_inactive(self, plan: Plan, s_lead: np.ndarray, v_lead: np.ndarray) -> bool:
        """True when J_log (Eqs. 15-18) is zero along ``plan`` against a leader predicted at
        ``s_lead`` (follower frame, front) [m] and ``v_lead`` [m/s] over the plan's first steps:
        the follower is never faster than the leader (TTC_log infinite) and never overlaps it."""
        n = len(s_lead)
        v, s = plan.speeds[1:n + 1], plan.positions[1:n + 1]
        return bool(np.all(v <= v_lead) and np.all(s_lead - self.model.vehicle_length - s >= 0.0))

    def _shifted(self, plans: tuple[Plan, ...], periods: int = 1) -> tuple[Plan, ...]:
        out = []
        for p in plans:
            for _ in range(periods):
                p = self._shift(p)
            out.append(p)
        return tuple(out)

    def _store_warm(self, world: World, key: tuple, plans: tuple[Plan, ...]) -> None:
        self.warm[key] = (world.time, plans)

    def _warm_start(self, world: World, key: tuple) -> tuple[Plan, ...] | None:
        """The plans stored under ``key``, shifted by the control periods since they were
        solved (a pair's game may pause while its trigger is off), or None when there are none
        or they are older than half the horizon (little of them would be left to reuse)."""
        entry = self.warm.get(key)
        if entry is None:
            return None
        solved_at, plans = entry
        periods = max(1, int(round((world.time - solved_at) / self.ctx.control_period)))
        if periods * self.shift > self.gs.steps // 2:
            return None
        return self._shifted(plans, periods)

    def _driven_plan(self, world: World, k: int, option: str) -> Plan | None:
        """The plan vehicle k drives (applied at the last step), shifted by one period, if it
        is for exit lane ``option``: the warm start of its own solo solve, and of a game its
        vehicles have not played yet (a cold start would first solve each player's decoupled
        optimum, which the solo plan it drives already is, up to its real-time iteration)."""
        vid = world.ids[k]
        plan = self.plans.get(vid)
        if plan is None or self.options.get(vid) != option:
            return None
        return self._shift(plan)

    def diagnostics(self) -> Diagnostics:
        """The games' convergence records and the safety filter's counts (control.base.Diagnostics)."""
        from intersection_cosim.control.base import Diagnostics  # module-level after the control-layer rewrite

        return Diagnostics(tuple(self.convergence), self.filtered, self.cleared)
