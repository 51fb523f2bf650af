"""What every safety rule reads: the junction the filter guards (fixed for the run) and the step's
inputs (the World, the relations, the plans), with the predictions the rules share: how hard a
vehicle can brake, what each vehicle will do (its plan, a human's forecast), who ranks first at a
crossing, and whether a vehicle can still stay out of a zone. Read-only: a rule's output goes into
the step's :class:`~intersection_cosim.control.safety.step.FilterStep`.

Under a V2X link's position noise (``gap_slack`` > 0, three standard deviations of the difference
of two noisy positions) every crossing zone is widened by the slack at both ends and every gap to
a leader is shortened by it, so the rules' invariants hold for the true positions.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from intersection_cosim.control.base import World
from intersection_cosim.control.game.plan_memory import human_forecast
from intersection_cosim.control.game.relations import Relations
from intersection_cosim.control.safety.kinematics import block_starts, creep_acceleration, stopping_acceleration, zone_exit
from intersection_cosim.control.safety.kinematics import CREEP_CLEARANCE
from intersection_cosim.control.safety.settings import SafetySettings
from intersection_cosim.games.problem import Plan
from intersection_cosim.games.settings import ProblemSettings
from intersection_cosim.models.cost import time_to_conflict_point
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.conflict_zones import ZONE_RESOLUTION
from intersection_cosim.network.movements import Movements

EDGE_CLEARANCE = ZONE_RESOLUTION + 0.05  # [m] a vehicle held at a zone's edge stops this far before its
#                                         sampled start: clear of the true first touch (ZONE_RESOLUTION)
WAIT_REACH = 1.0  # [m] how far before its waiting position a standing human counts as waiting there


@dataclass(frozen=True)
class GuardedJunction:
    """What the filter knows of its junction, fixed for the run."""

    settings: SafetySettings
    problem: ProblemSettings
    model: ModelSettings
    movements: Movements
    s_stop: np.ndarray  # [m] each conflict-table path's stop line
    s_wait: np.ndarray  # [m] each conflict-table path's waiting position (inf: none)
    waits: Mapping[str, tuple[float, frozenset[str]]]  # path id -> ([m] its waiting position, the
    #                                                     approach lanes SUMO's internal junction there watches)
    period: float  # [s] the control period
    gap_slack: float = 0.0  # [m] taken off every gap and added to every zone (position noise)
    crossing_zones: Mapping = None  # path id -> its pedestrian crossing zones (network/crossings.py)


@dataclass(frozen=True)
class StepContext:
    """One step's inputs, read by every rule."""

    junction: GuardedJunction
    world: World
    relations: Relations  # the step's relations, crossing zones widened by the slack
    plans: Mapping[str, Plan]  # this step's plans, as the decision layer made them
    options: Mapping[str, str]  # the exit lane each vehicle takes
    accel: Mapping[str, float]  # [m/s^2] the decided accelerations (the vehicles the filter may cap)
    chosen: np.ndarray  # (R,) bool: the row is the exit lane its vehicle takes
    guarded: np.ndarray  # indices of the lateral pairs whose both rows are chosen
    games: frozenset[tuple[str, str]]  # sorted vehicle-id pairs that play their game this step
    entered: Mapping[str, float]  # [s] when each vehicle entered the junction (the entry queue)

    @property
    def settings(self) -> SafetySettings:
        return self.junction.settings

    def may_cap(self, vid: str) -> bool:
        """Whether the filter may cap vehicle ``vid``: one it decided for, or a guest (its cap goes
        to its owner)."""
        return vid in self.accel or vid in self.guest_ids

    @functools.cached_property
    def guest_ids(self) -> frozenset[str]:
        """The guests of this junction's World (World.guest)."""
        world = self.world
        if world.guest is None:
            return frozenset()
        return frozenset(vid for vid, g in zip(world.ids, world.guest) if g)

    @functools.cached_property
    def block_in(self) -> tuple[np.ndarray, np.ndarray]:
        """(len(guarded),) [m] each way, where the block of a guarded pair's zone starts on each
        vehicle's path: its zones of this step's guarded crossings chain into one block where they
        overlap or leave no room to stand between them (``CREEP_CLEARANCE`` past one and before
        the next), so a vehicle that waits for a crossing can stand in none of its crossings."""
        pairs, guarded = self.relations.pairs, self.guarded
        zone_i, zone_j = pairs.zone_i[guarded], pairs.zone_j[guarded]  # [m]
        rows = np.concatenate((pairs.ri[guarded], pairs.rj[guarded]))
        starts = block_starts(rows, np.concatenate((zone_i[:, 0], zone_j[:, 0])),
                              np.concatenate((zone_i[:, 1], zone_j[:, 1])), 2.0 * CREEP_CLEARANCE)
        return starts[:len(guarded)], starts[len(guarded):]

    # --- braking -----------------------------------------------------------------------------
    def brake(self, k: int) -> float:
        """[m/s^2] (< 0) the hardest braking counted on for vehicle k: the game's ``a_min``, or its
        vType's decel where that is weaker."""
        p = self.junction.problem
        return self.world.accel_limits(k, p.a_min, p.a_max)[0]

    def brakes(self) -> dict[str, float]:
        """:meth:`brake` per vehicle id; empty (``a_min`` for all) when the World carries no decel."""
        world = self.world
        return {} if world.decel is None else {vid: self.brake(k) for k, vid in enumerate(world.ids)}

    def would_stop_in(self, k: int, enter: float) -> bool:
        """Whether vehicle k, braking as hard as it may after one control period, stops at or past
        arc length ``enter`` [m]."""
        s, v = float(self.world.s[k]), float(self.world.v[k])  # [m], [m/s]
        return s + v * self.junction.period + v * v / (2.0 * -self.brake(k)) >= enter

    def stuck_inside(self, k: int, zone: tuple[float, float]) -> bool:
        """Whether vehicle k's front is inside ``zone`` [m] (in, out) and, braking as hard as it may
        from now, would stop before its end (standing in the way of whoever crosses it)."""
        s, v = float(self.world.s[k]), float(self.world.v[k])  # [m], [m/s]
        return zone[0] <= s and s + v * v / (2.0 * -self.brake(k)) < zone[1]

    # --- what each vehicle will do -------------------------------------------------------------
    def plan_of(self, k: int, plans: Mapping[str, Plan], partner: int | None = None) -> Plan | None:
        """The plan checked for vehicle k: its plan in ``plans``, constant speed for one SUMO drives
        again (it has left the junction), a human's forecast (starting at once at ``a_max`` against
        a ``partner`` that :meth:`may_release` says SUMO does not hold it for), a guest's forecast
        as a human's (another junction plans it; it is not known to brake); None without one."""
        world, p = self.world, self.junction.problem
        if world.is_human(k) or world.is_guest(k):
            release = world.is_human(k) and partner is not None and self.may_release(k, partner)
            return human_forecast(world, k, p.a_max, self.junction.model.v_max, p.steps, p.dt,
                                  p.a_max if release else None)
        plan = plans.get(world.ids[k])
        if plan is None and world.role[k] == "outside":
            return Plan.from_accelerations(float(world.s[k]), float(world.v[k]), np.zeros(p.steps), p.dt)
        return plan

    def waits_at_its_position(self, k: int) -> bool:
        """Whether vehicle k stands (below ``clear_speed``) at its path's waiting position (an
        internal junction of SUMO's, where a turn waits for the opposing stream)."""
        wait = self.junction.waits.get(self.world.path_ids[k])
        s = float(self.world.s[k])
        return (wait is not None and float(self.world.v[k]) < self.settings.clear_speed
                and wait[0] - WAIT_REACH <= s <= wait[0] + 0.5)

    def may_release(self, h: int, k: int) -> bool:
        """Whether SUMO may release human h from its waiting position while AV k approaches on a
        lane h's internal junction does not watch (SUMO lets h go whatever k does)."""
        world = self.world
        if world.is_human(k) or world.role[k] != "ready" or not self.waits_at_its_position(h):
            return False
        return world.lanes[k] not in self.junction.waits[world.path_ids[h]][1]

    def human_committed(self, k: int, enter: float) -> bool:
        """Whether moving human k can no longer stop before arc length ``enter`` [m]."""
        if float(self.world.v[k]) < self.settings.clear_speed:
            return False  # standing: it starts again only when SUMO lets it
        return self.would_stop_in(k, enter)

    # --- who goes first ------------------------------------------------------------------------
    def in_game(self, a: str, b: str) -> bool:
        """Whether vehicles ``a`` and ``b`` play their game this step."""
        return (min(a, b), max(a, b)) in self.games

    def rank(self, k: int, t_in: float, enter: float, queue: Mapping[str, float]) -> tuple:
        """Priority of vehicle k at a crossing it would reach in ``t_in`` [s] (smaller goes first), a
        total order: a vehicle SUMO drives again (it left the junction) or a human that can no
        longer stop before ``enter`` [m] first; then the vehicles in the junction by ``queue`` (entry
        times [s]); then a human not yet in (it does not yield to AVs); then the AVs not yet in by
        ``t_in``; ties by id."""
        world = self.world
        if world.role[k] == "outside" or (world.is_human(k) and self.human_committed(k, enter)):
            return (-1, 0.0, world.ids[k])
        entered = queue.get(world.ids[k])
        if entered is not None:
            return (0, entered, world.ids[k])
        return (0.5, t_in, world.ids[k]) if world.is_human(k) else (1, t_in, world.ids[k])

    def arrival(self, play: bool, zones: tuple, ki: int, kj: int, in_i: float, in_j: float) -> tuple[float, float]:
        """[s] the times that rank a pair: to the zone at the current speed (``yield_order = "tcp"``,
        Eqs. 21-22), or by the plans (``"plan"``, and a pair that played its game: the filter
        enforces the equilibrium's order, it does not overrule it)."""
        if self.settings.yield_order == "tcp" and not play:
            floor, world = self.junction.model.tcp_speed_floor, self.world
            return (time_to_conflict_point(zones[0][0] - float(world.s[ki]), float(world.v[ki]), floor),
                    time_to_conflict_point(zones[1][0] - float(world.s[kj]), float(world.v[kj]), floor))
        return in_i, in_j

    def in_junction(self, k: int) -> bool:
        """Whether vehicle k is in the entry queue (it entered the junction)."""
        return self.world.ids[k] in self.entered

    def avs_entered(self) -> np.ndarray:
        """(len(world),) bool: the AVs in the entry queue (in the junction)."""
        world = self.world
        return np.array([vid in self.entered and not world.is_human(k) for k, vid in enumerate(world.ids)], bool)

    # --- staying out of a zone -----------------------------------------------------------------
    def stay_out(self, k: int, s_stop: float, enter: float, margin: float, own: tuple | None = None) -> float | None:
        """[m/s^2] the acceleration that keeps vehicle k out of a zone starting at ``enter`` [m]: it
        stops at its stop line ``s_stop`` [m] (less ``margin`` of the settings) if it has not reached
        it and can, else before the zone (less ``margin`` [m], else less the settings' margin, or at
        its edge); a vehicle standing in the junction inside another of its crossing zones
        (``own``: the step's LateralPairs and k's row) that it can leave short of this one drives
        out of it and stands between the two. None if it cannot stay out any more. Under position
        noise a vehicle read inside the widened zone that can still stop short of the zone itself
        stops as soon as it can."""
        a = self.stop_short_of(k, s_stop, enter, margin, own)
        slack = self.junction.gap_slack
        if a is not None or slack <= 0.0:
            return a
        s_k, v_k = float(self.world.s[k]), float(self.world.v[k])
        brake = self.brake(k)
        if s_k + v_k * v_k / (-2.0 * brake) >= enter + slack:
            return None
        return max(brake, -v_k / self.junction.period)

    def stop_short_of(self, k: int, s_stop: float, enter: float, margin: float, own: tuple | None = None) -> float | None:
        """:meth:`stay_out` without the allowance for position noise."""
        st = self.settings
        s_k, v_k = float(self.world.s[k]), float(self.world.v[k])
        if s_k >= enter:
            return None
        if own is not None and v_k < st.clear_speed and s_k >= s_stop:  # in the junction: it entered to clear
            target = zone_exit(own[0], own[1], s_k, enter, CREEP_CLEARANCE)
            if target is not None:
                return creep_acceleration(s_k, v_k, target, st.clear_accel, self.junction.period)
        brake = self.brake(k)
        # one that has not reached its stop line stops at it, not on into the junction towards the
        # zone: inside, the entry queue would rank it ahead of the vehicle it stays out for
        line = min(s_stop - 0.05, enter - EDGE_CLEARANCE) if s_k < s_stop else -math.inf  # [m]
        for target in (s_stop - st.margin, line, enter - margin, enter - st.margin, enter - EDGE_CLEARANCE):
            if target <= s_k:
                continue
            a = stopping_acceleration(s_k, v_k, target)
            if a is not None and a >= brake:
                return a
        return max(brake, -v_k / self.junction.period) if v_k < 0.1 else None
