"""``nash`` and ``stackelberg``: the paper's decision process (Algorithm 1) in the closed loop.

Every control period, for the vehicles that are ready to enter or passing the conflict zone:

1. **Relations** (control/game/relations.py): each controlled vehicle is expanded into one row per
   exit lane it may still choose (Case 2's V3 has two); the ETM
   (:func:`~intersection_cosim.models.risk.event_trigger`, Eqs. 9 and 39) evaluates Gamma_cp for
   every pair of rows of different vehicles whose paths meet. A cross or confluence pair whose
   Gamma_cp exceeds Gamma_sf in any combination of exit lanes plays a game; with the ETM off
   (``--no-etm``) every such pair that has not yet passed its conflict point plays one, every
   step. A leader-follower relation enters the follower's own cost as J_log (Eqs. 15-18)
   against the leader's predicted trajectory (control/game/players.py).
2. **Exit-lane options** (control/game/lane_options.py): the exit lanes whose choice changes whom a
   vehicle interacts with.
3. **Games** (control/game/pair_games.py): each triggered pair plays its game, most urgent first.
4. **Alone** (control/game/solo.py): a vehicle in no game optimises its own cost with k_lat = 0,
   re-planning only when an input of its problem moved.
5. **Several games, one vehicle** (:func:`combine`): the vehicle applies the plan of the game
   whose first acceleration is the lowest, and takes that game's exit lane. Every game's plan
   for the vehicle keeps the safety cost of *that* pair low given the partner's equilibrium
   plan; taking the lowest acceleration keeps the vehicle at or behind the position each
   partner's plan assumes over the next period, so a partner that planned to pass first only
   gains margin, and one that planned to pass second sees the vehicle's actual, slower progress
   at the next control step, when the pair's game is played again from the measured states.
   The lowest acceleration is one of the games' own plans, bounded by a_min.
6. **Anytime step** (control/game/anytime.py): work that would not finish before the budget less
   what the safety filter needs (``anytime_reserve``, or twice its measured time) is deferred
   and its vehicles keep their last plan, shifted.
7. **Safety filter** (control/safety/) checks every acceleration, fresh or kept.

Decisions are written back as accelerations (held over the period; the adapter turns them into
exact speed commands) and exit lanes (enforced by the adapter when the vehicle enters the
junction). A vehicle that has left the conflict zone is handed back to SUMO's driver model.

**Human drivers** (``World.human``) are observed, never players: they get no decision, play no
game and are never commanded. A human leader enters its AV follower's J_log as a fixed (constant
speed) trajectory, and a human of a triggered crossing enters the AV's J_lat with its forecast
fixed (``Player.crossers``, control/game/players.py); the safety filter guards the crossing, predicting
the human by :func:`~intersection_cosim.models.prediction.human_accelerations`, and never lets
the AV claim it against the human (control/safety/).
"""

from __future__ import annotations

import dataclasses
import math
import numpy as np

from intersection_cosim.games import budget_clock
from intersection_cosim.control.game.anytime import AnytimeSchedule, step_cutoff
from intersection_cosim.control.base import ControlContext, Decisions, Diagnostics, World
from intersection_cosim.control.game.lane_options import LaneChangeCosts, lane_options
from intersection_cosim.control.game.events import in_force, playing
from intersection_cosim.control.game.game_reuse import GameReuse
from intersection_cosim.control.game.cluster_games import ClusterGames, cluster_pairs, split_clusters
from intersection_cosim.control.game.pair_games import GameSolver, PairGame, game_problems, pair_games, play, urgency
from intersection_cosim.control.game.plan_memory import GameKey, PlanMemory
from intersection_cosim.control.game.records import Choice, ConvergenceRecord
from intersection_cosim.control.game.relations import Relations, TriggerHold, approaching_guests, step_relations
from intersection_cosim.control.safety.context import GuardedJunction
from intersection_cosim.control.safety.filter import SafetyFilter
from intersection_cosim.control.safety.kinematics import occupancy_times
from intersection_cosim.control.game.solo import SoloPlanner
from intersection_cosim.games.nash import nash_equilibrium
from intersection_cosim.games.problem import Interaction, Plan, Player, Problem, shift_plan
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.games.solo_batch import SMALL_BATCH, solo_responses
from intersection_cosim.games.qp import reset_workspaces, solve_count
from intersection_cosim.control.game.settings import GameControllerSettings
from intersection_cosim.games.stackelberg import stackelberg_equilibrium
from intersection_cosim.network.conflicts import movement_conflict_table
from intersection_cosim.network.crossings import crossing_zones, movement_crossings
from intersection_cosim.network.waiting import waiting_watches

EQUILIBRIA = {"nash": nash_equilibrium, "stackelberg": stackelberg_equilibrium}


def combine(choices: list[Choice]) -> Choice:
    """The rule for a vehicle in several games (module docstring, 5): the lowest first
    acceleration (the first such game on ties)."""
    return min(choices, key=lambda c: c.first_accel)


class GameController:
    """The game-theoretic decision layer; ``equilibrium`` is ``"nash"`` or ``"stackelberg"``."""

    controls_vehicles = True
    yields_to_pedestrians = True  # control/safety/pedestrians.py

    def __init__(self, equilibrium: str, settings: GameControllerSettings | None = None,
                 junction_type: str = "priority", coupling: str | None = None):
        if equilibrium not in EQUILIBRIA:
            raise ValueError(equilibrium)
        self.equilibrium = equilibrium
        self.coupling = coupling  # overrides [controller.game] coupling (the *-coupled controllers)
        self.settings = settings or GameControllerSettings()
        self.junction_type = junction_type
        self.controlled: set[str] = set()
        self.convergence: list[ConvergenceRecord] = []
        self._choice_age: dict[str, int] = {}  # vehicle -> steps since its exit lane was decided
        self._held: frozenset[str] = frozenset()  # held back at a crossing by the filter this step
        self._held_before: frozenset[str] = frozenset()  # ... at the step before
        self._decided_at: float | None = None  # [s] time of the last decide call
        self._applied: dict[str, Plan] = {}  # plans applied before that call
        # sorted vehicle-id pairs the filter had to guard (PolicySettings.filter_event): they play
        self._events: set[tuple[str, str]] = set()
        # sorted vehicle-id pairs that played at the last step (PolicySettings.trigger_hold_gap)
        self._played: frozenset[tuple[str, str]] = frozenset()

    # ------------------------------------------------------------------ setup
    def setup(self, context: ControlContext) -> None:
        if context.settings is not None:
            self.settings = context.settings
        if self.coupling is not None:
            self.settings = dataclasses.replace(self.settings, game=dataclasses.replace(self.settings.game,
                                                                                        coupling=self.coupling))
        game = self.settings.game
        self.ctx, self.model, self.paths = context, context.model, context.paths
        self.table = movement_conflict_table(context.movements, context.model.vehicle_width,
                                             context.model.vehicle_length, context.touch_width)
        if context.bodies:  # the areas other bodies sweep, built before the first step needs them
            self.table.warm(context.bodies)
        longest = max([context.model.vehicle_length] + [length for length, _ in context.bodies])  # [m]
        zones = crossing_zones(context.movements, movement_crossings(context.movements), longest, context.touch_width)
        shift = max(1, int(round(context.control_period / game.dt)))
        self.memory = PlanMemory(shift, context.control_period, game.steps, game.dt, game.a_max, context.model.v_max)
        lane_costs = LaneChangeCosts(context.movements, context.model)
        self.solver = GameSolver(EQUILIBRIA[self.equilibrium], self.equilibrium, self.settings.games, self.model,
                                 lane_costs, context.movements, _capped(self.settings))
        self.clusters = (ClusterGames(self.equilibrium, self.solver, self.memory, self.settings.policy.cluster_check)
                         if game.coupling == "cluster" else None)
        self.solo = SoloPlanner(self.settings, self.model, self.memory, lane_costs, context.movements)
        self.reuse = GameReuse(self.settings.policy, self.memory, context.model.v_max)
        waits = {pid: (context.paths[pid].s_wait, lanes) for pid, lanes in waiting_watches(context.movements).items()}
        self.safety = SafetyFilter(GuardedJunction(
            self.settings.safety, game, self.model, context.movements, self.table.s_stop, self.table.s_wait, waits,
            context.control_period, gap_slack=3.0 * math.sqrt(2.0) * context.position_noise, crossing_zones=zones))
        self._stall_held: frozenset[str] = frozenset()  # held at their stop lines for a stalled box, last step
        self.schedule = AnytimeSchedule()
        reset_workspaces()
        self._warm_up()

    def _warm_up(self) -> None:
        """Solve one small game, a batch of solo problems and the filter's occupancy times before
        the first step, so that OSQP's workspaces, the lazy imports and the compiled kernels
        (numba loads each from its cache at its first call, some milliseconds) are ready outside
        the timed control loop (a first step over its budget would make the run depend on the
        machine's speed)."""
        problem = Problem((Player(0.0, 5.0, 0.5), Player(0.0, 5.0, 0.5)), (Interaction.cross(0, 1, 15.0, 14.0),))
        self.solver.equilibrium(problem, self.solver.settings, self.model)
        nash_equilibrium(Problem((Player(0.0, 5.0, 0.5),)), self.solver.settings, self.model)
        solo_responses([Problem((Player(0.0, 5.0, 0.5),))] * SMALL_BATCH, self.solver.settings, self.model)
        occupancy_times(np.array([[0.0, 1.0]]), np.array([2], np.intp), np.array([0.1]), np.zeros(1, np.intp),
                        np.array([0.5]))
        shift_plan(Plan.from_accelerations(0.0, 5.0, np.zeros(self.solver.settings.problem.steps),
                                           self.solver.settings.problem.dt))

    def diagnostics(self) -> Diagnostics:
        return Diagnostics(tuple(self.convergence), self.safety.filtered, self.safety.cleared,
                           self.safety.pedestrian_holds, self.clusters.rows() if self.clusters is not None else None)

    # ------------------------------------------------------------------ one step
    def decide(self, world: World, deadline: float) -> Decisions:
        solved_before = solve_count()
        decisions = self._decide(world, deadline)
        decisions.qp_solves = solve_count() - solved_before
        return decisions

    def _decide(self, world: World, deadline: float) -> Decisions:
        self._decided_at, self._applied = world.time, dict(self.memory.plans)  # for the fallback
        self.memory.new_step()
        self._held_before, self._held = self._held, frozenset()
        active = [k for k in range(len(world))
                  if world.role[k] != "outside" and not world.is_human(k) and not world.is_guest(k)]
        decisions = Decisions(release=self._release(world, active))
        self.safety.record_entries(world)
        if not active and approaching_guests(world).sum() < 2:  # two guests: the filter keeps them apart
            return decisions
        self.memory.prune_warm({world.ids[k] for k in active})
        relations = self._relations(world, set(active))
        self._played = self._hold_after(world, relations)
        lanes = lane_options(world, relations, self.ctx.movements, self.memory.options, self._choice_age,
                             self.settings.policy.lane_choice_period)
        self._choice_age = dict(lanes.choice_age)
        cutoff = step_cutoff(deadline, self.settings.policy.anytime_reserve, self.schedule.filter.seconds)
        in_game = self._play_games(world, relations, lanes.options, cutoff, decisions)
        for k in active:
            if k in in_game:
                choice = combine(in_game[k])
                self.solo.forget(world.ids[k])
                self._apply(world, k, choice.plan, choice.option, decisions)
        solo = sorted((k for k in active if k not in in_game),
                      key=lambda k: self.paths[world.path_ids[k]].s_stop - float(world.s[k]))
        outcomes = self.solo.plan_all(world, solo, lanes.options, relations, self._held_before, self.schedule.solo,
                                      cutoff)
        for k in solo:
            out = outcomes[k]
            decisions.deferred += out.deferred
            self._apply(world, k, out.plan, out.option, decisions)
        t0 = budget_clock.now()
        self._filter(world, relations, decisions)
        self.schedule.filter.measured(budget_clock.now() - t0)
        return decisions

    def _release(self, world: World, active: list[int]) -> list[str]:
        """Hand vehicles that left the conflict zone back to SUMO and forget them."""
        now = {world.ids[k] for k in active}
        release = sorted(self.controlled - now)
        self.controlled = now
        if self._events and release:
            gone = set(release)
            self._events = {e for e in self._events if not (e[0] in gone or e[1] in gone)}
        for vid in release:
            self.memory.forget(vid)
            self.solo.forget(vid)
            self.reuse.forget(vid)
            self._choice_age.pop(vid, None)
            self.safety.release(vid)
        return release

    def _relations(self, world: World, active: set[int]) -> Relations:
        gap = self.settings.policy.trigger_hold_gap
        hold = TriggerHold(self._played, gap) if gap > 0 and self._played else None
        return step_relations(world, active, self.ctx.movements, self.table, self.model, self.ctx.etm, self.memory.options,
                              self.settings.policy.lane_choice_range, frozenset(self._events), hold)

    def _hold_after(self, world: World, relations: Relations) -> frozenset[tuple[str, str]]:
        """The pairs that play this step and may keep playing at the next (the ETM's hysteresis,
        PolicySettings.trigger_hold_gap), as sorted vehicle-id pairs; none when it is off."""
        if not self.settings.policy.trigger_hold_gap > 0:
            return frozenset()
        return frozenset(self._in_force(world, playing(world, relations)))

    def _play_games(self, world: World, relations: Relations, options, cutoff: float,
                    decisions: Decisions) -> dict[int, list[Choice]]:
        """Every triggered pair's game, most urgent first; a game that would not finish before
        ``cutoff`` is deferred (its vehicles keep their last plans, shifted)."""
        in_game: dict[int, list[Choice]] = {}
        games = pair_games(relations, options)
        if self.clusters is not None:
            games = self._play_clusters(world, games, relations, options, cutoff, decisions, in_game)
        for game in sorted(games.values(), key=lambda g: urgency(world, g, self.model.tcp_speed_floor)):
            ka, kb = game.a, game.b
            problems, warm = game_problems(world, game, options, relations, self.memory)
            if (kept := self.reuse.kept(world, ka, kb, problems, self._held_before)) is not None:
                self._keep_game(world, game, *kept, in_game, decisions)
                continue
            estimate, n_warm = self.schedule.game, sum(combo in warm for combo in problems)
            n_cold = len(problems) - n_warm
            if not estimate.fits(n_warm, n_cold, cutoff):
                decisions.deferred += 1
                estimate.deferred(n_warm, n_cold)
                for k in (ka, kb):
                    in_game.setdefault(k, []).append(self._kept_choice(world, k))
                continue
            t0 = budget_clock.now()
            result, choice = play(world, game, problems, warm, options, self.memory, self.solver, cutoff)
            estimate.measured(n_warm, n_cold, budget_clock.now() - t0)
            self.reuse.solved(world, ka, kb, problems, result, choice)
            self._record_game(world, game, result, decisions)
            for k, plan, option in ((ka, result.plans[0], choice[0]), (kb, result.plans[1], choice[1])):
                in_game.setdefault(k, []).append(Choice(float(plan.accelerations[0]), plan, option))
        return in_game

    def _play_clusters(self, world: World, games: dict, relations: Relations, options, cutoff: float,
                       decisions: Decisions, in_game: dict[int, list[Choice]]) -> dict:
        """The coupled game of every cluster of three or more vehicles, most urgent first
        (control/game/cluster_games.py); returns the pair games outside them."""
        clusters, rest = split_clusters(games)
        floor, ids = self.model.tcp_speed_floor, world.ids
        for members in sorted(clusters, key=lambda c: min(urgency(world, games[p], floor) for p in cluster_pairs(c, games))):
            out = self.clusters.play(world, members, games, options, relations, cutoff)
            if out is None:  # would not fit: its vehicles keep their plans
                decisions.deferred += 1
                for k in members:
                    in_game.setdefault(k, []).append(self._kept_choice(world, k))
                continue
            order, result, exits = out
            decisions.games += 1
            decisions.iterations += result.iterations
            decisions.pairs.extend((ids[a], ids[b]) for a, b in cluster_pairs(members, games))
            self.convergence.append(ConvergenceRecord(
                world.time, ids[order[0]], "+".join(ids[k] for k in order[1:]), self.equilibrium, result.status,
                result.iterations, tuple(float(r) for r in result.residuals), tuple(float(c) for c in result.costs)))
            for k, plan in zip(order, result.plans):
                in_game.setdefault(k, []).append(Choice(float(plan.accelerations[0]), plan, exits[k]))
        return rest

    def _keep_game(self, world: World, game: PairGame, plans: tuple, choice: tuple, in_game: dict,
                   decisions: Decisions) -> None:
        """Pair ``game`` keeps its last equilibrium (control/game/game_reuse.py): counted as a game in
        force this step, with no iteration and no convergence record."""
        ids = world.ids
        self.memory.store(GameKey(ids[game.a], ids[game.b], *choice), world.time, plans)
        decisions.games += 1
        decisions.pairs.append((ids[game.a], ids[game.b]))
        decisions.kept.append((ids[game.a], ids[game.b]))
        for k, plan, option in ((game.a, plans[0], choice[0]), (game.b, plans[1], choice[1])):
            in_game.setdefault(k, []).append(Choice(float(plan.accelerations[0]), plan, option))

    def _record_game(self, world: World, game: PairGame, result, decisions: Decisions) -> None:
        ids = world.ids
        decisions.games += 1
        decisions.iterations += result.iterations
        decisions.pairs.append((ids[game.a], ids[game.b]))
        self.convergence.append(ConvergenceRecord(
            world.time, ids[game.a], ids[game.b], self.equilibrium, result.status, result.iterations,
            tuple(float(r) for r in result.residuals), tuple(float(c) for c in result.costs)))

    def _kept_choice(self, world: World, k: int) -> Choice:
        plan = self.memory.kept_plan(world, k, self.settings.game.comfort_brake)
        option = self.memory.held_option(world.ids[k], self.paths[world.path_ids[k]].exit_lane)
        return Choice(float(plan.accelerations[0]), plan, option)

    def _apply(self, world: World, k: int, plan: Plan, option: str, decisions: Decisions) -> None:
        vid = world.ids[k]
        self.memory.apply(vid, plan, option)
        decisions.accel[vid] = float(plan.accelerations[0])
        if len(world.exit_choices.get(vid, ())) > 1:
            decisions.exit_lane[vid] = option

    def _filter(self, world: World, relations: Relations, decisions: Decisions) -> None:
        if self.settings.safety.enabled:
            # the pairs that play their game (none in a fallback step: stale plans)
            games = frozenset() if decisions.fallback else playing(world, relations)
            result = self.safety.apply(world, relations, self.memory.plans, self.memory.options, decisions.accel,
                                       games)
            decisions.accel.update(result.accel)
            decisions.caps.update(result.guest_caps)
            self._held = self._held | result.held
            self._stall_held = result.stall_held
            if self.settings.policy.filter_event:
                self._events |= result.events
                self._events = self._live_events(world)

    def _live_events(self, world: World) -> set[tuple[str, str]]:
        """The filter's events (PolicySettings.filter_event) that still hold: dropped once both
        vehicles of the pair are in the junction (the entry queue) and one of them is slower than
        ``SafetySettings.clear_speed`` [m/s] (the filter may raise it again). Forcing the game on
        for such a pair let two vehicles in the box plan to crawl for each other (J_lat a few
        metres apart), which locked a high-demand run (decision record 024)."""
        return self._in_force(world, self._events)

    def _in_force(self, world: World, pairs) -> set[tuple[str, str]]:
        """``pairs`` still in force (control/game/events.py, :func:`in_force`)."""
        return in_force(world, pairs, self.safety.entered, self._stall_held, self.settings.safety.clear_speed)

    def fallback(self, world: World) -> Decisions:
        """The last applied plan shifted by one period (comfortable braking where there is none),
        through the safety filter.

        Called by the scheduler when ``decide`` overran its budget or failed: this step drives
        the plans applied at the previous step, shifted, and the plans ``decide`` made in this
        step (late) become the ones the next step shifts, as a HIL box's late answer lands one
        period late. So in a stretch of missed deadlines every step drives the decisions of the
        step before (one period of latency) instead of plans that go staler each period (a
        junction whose every step overran once stood still for good: its kept plans braked
        everyone to a stop). The safety filter still runs (it costs about a millisecond, the
        games are what overran).
        """
        late = None
        if self._decided_at == world.time:
            late, self.memory.plans = self.memory.plans, self._applied
        decisions = Decisions(fallback=True)
        self.safety.record_entries(world)
        period = self.ctx.control_period
        active = set()
        for k in range(len(world)):
            vid = world.ids[k]
            if world.role[k] == "outside" or world.is_human(k) or world.is_guest(k):
                continue
            active.add(k)
            plan = self.memory.kept_plan(world, k, self.settings.game.comfort_brake)
            self.memory.plans[vid] = plan
            decisions.accel[vid] = max(float(plan.accelerations[0]), -float(world.v[k]) / period)
            self.controlled.add(vid)
        if active:
            self._filter(world, self._relations(world, active), decisions)
        if late is not None:  # the next step starts from decide's late plans
            self.memory.plans.update({vid: plan for vid, plan in late.items() if vid in self.memory.plans})
        return decisions


def _capped(settings: GameControllerSettings) -> GameSettings | None:
    """The game settings of a game in progress (GameSolver.solve): the equilibrium iterations
    capped at ``policy.game_max_iter`` and a Stackelberg follower not polished at the cap (its
    answer goes on at the next step); None for 0, not capped."""
    cap = settings.policy.game_max_iter
    if cap <= 0:
        return None
    sv = settings.games.solver
    return dataclasses.replace(settings.games, solver=dataclasses.replace(
        sv, nash_max_iter=min(cap, sv.nash_max_iter), stackelberg_max_iter=min(cap, sv.stackelberg_max_iter),
        polish_follower=False))
