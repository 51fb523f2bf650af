"""The game controllers' safety filter (control/safety/) under the ``fcfs`` controller's commands.

fcfs's reservations keep two AVs apart at the conflict points, and reserve the humans' predicted
occupancy; they know nothing of a human that stops where it was predicted to drive on, a guest's
cap, a vehicle standing in the box or SUMO holding a human for an AV. The filter's named rules
(:data:`~intersection_cosim.control.safety.rules.RULES`) guard all of that for the game
controllers; this module hands them fcfs's decided accelerations and, as the plans the rules check,
each AV's grant flown over the filter's horizon (:func:`flown_plan`). The filter lowers
accelerations (and raises one only to let a vehicle standing in a crossing drive out of it).
Before it, :func:`leader_caps` caps each command by Krauss' safe speed behind the vehicle's leader.

Units: arc lengths [m] along a vehicle's movement path, speeds [m/s], accelerations [m/s^2],
times [s].
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from intersection_cosim.control.base import ControlContext, World
from intersection_cosim.control.baselines.reservations import FcfsSettings, Grant
from intersection_cosim.control.game.relations import step_relations
from intersection_cosim.control.safety.context import GuardedJunction
from intersection_cosim.control.safety.filter import SafetyFilter
from intersection_cosim.control.safety.kinematics import occupancy_times, stopping_acceleration
from intersection_cosim.control.safety.onboard import krauss_safe_speed
from intersection_cosim.control.safety.settings import SafetySettings
from intersection_cosim.control.safety.step import SafetyResult
from intersection_cosim.games.problem import Plan
from intersection_cosim.games.settings import ProblemSettings
from intersection_cosim.models.cost import time_to_conflict_point
from intersection_cosim.network.conflicts import KIND_CONFLUENCE, KIND_FOLLOWING, ConflictTable, movement_conflict_table
from intersection_cosim.network.crossings import crossing_zones, movement_crossings
from intersection_cosim.network.waiting import waiting_watches


def leader_caps(world: World, table: ConflictTable, active: list[int], accel: np.ndarray, length: float,
                follow_gap: float, max_brake: float, period: float) -> None:
    """Cap each active vehicle's acceleration ``accel`` [m/s^2] (in place) by Krauss' safe speed
    behind its leader: the nearest vehicle ahead on a shared stretch (same approach lane, or the
    same exit lane after a merge point), ``length`` + ``follow_gap`` [m] kept, the leader counted on
    to brake at ``max_brake`` [m/s^2] within ``period`` [s]."""
    idx = table.indices(world.path_ids)
    for i in active:
        p = idx[i]
        kinds = table.kind[p, idx]
        s_cp_i = table.s_a[p, idx]
        s_cp_j = table.s_b[p, idx]
        # following: shared stretch from s = 0 on both paths; leader ahead, rear not past its end
        foll = (kinds == KIND_FOLLOWING) & (world.s > world.s[i]) & (world.s[i] < s_cp_i) \
            & (world.s - length < s_cp_j)
        gap_f = world.s - world.s[i]
        # confluence: leader past the merge point and ahead of i relative to it
        rel_i = world.s[i] - s_cp_i
        rel_j = world.s - s_cp_j
        conf = (kinds == KIND_CONFLUENCE) & (rel_j >= 0) & (rel_j > rel_i)
        gap_c = rel_j - rel_i
        gap = np.where(foll, gap_f, np.where(conf, gap_c, np.inf))
        gap[i] = np.inf
        j = int(np.argmin(gap))
        if not np.isfinite(gap[j]):
            continue
        v_safe = krauss_safe_speed(float(gap[j]) - length - follow_gap, float(world.v[j]), max_brake, period)
        accel[i] = min(accel[i], (v_safe - float(world.v[i])) / period)


def flown_plan(s0: float, v0: float, a0: float, s_line: float, t_go: float | None, v_go: float,
               limits: tuple[float, float, float], steps: int, dt: float) -> Plan:
    """The plan [m/s^2 per step of ``dt`` s] of a vehicle at ``s0`` [m], ``v0`` [m/s] flying its fcfs
    grant: ``a0`` first (the command, leader caps included), then, while it has not reached its
    stop line ``s_line`` [m] before ``t_go`` [s from now], the constant acceleration that reaches
    the line at ``t_go`` (``v_go`` > 0) or the braking that stops it there (``v_go`` = 0, or
    ``t_go`` None: held without a grant); once through, ``comfort`` up to ``v_max``.
    ``limits``: (comfort acceleration, hardest braking (> 0), v_max) [m/s^2, m/s^2, m/s]."""
    comfort, brake, v_max = limits
    accel = np.empty(steps)
    s, v = s0, max(v0, 0.0)
    for n in range(steps):
        t = n * dt
        if n == 0:
            a = a0
        elif s >= s_line or (t_go is not None and t >= t_go):
            a = comfort
        elif t_go is not None and v_go > 0:
            a = 2.0 * (s_line - s - v * (t_go - t)) / (t_go - t) ** 2
        else:
            a = stopping_acceleration(s, v, s_line)
            a = -v / dt if a is None else a
        a = min(max(a, -brake), comfort, (v_max - v) / dt)
        a = max(a, -v / dt)  # never backwards
        accel[n] = a
        s += v * dt + 0.5 * a * dt * dt
        v += a * dt
    return Plan.from_accelerations(s0, v0, accel, dt)


class FcfsGuard:
    """One junction's :class:`SafetyFilter` for fcfs, with the conflict table and settings it reads
    (the default safety settings, its exit_room rule on or off with fcfs's own ``exit_room``)."""

    def __init__(self, context: ControlContext, fs: FcfsSettings, settings: SafetySettings | None = None):
        model = context.model
        self.ctx, self.fs = context, fs
        self.problem = ProblemSettings(a_min=-fs.max_brake)  # [m/s^2] fcfs's hardest braking
        self.table = movement_conflict_table(context.movements, model.vehicle_width, model.vehicle_length,
                                             context.touch_width)
        if context.bodies:
            self.table.warm(context.bodies)
        longest = max([model.vehicle_length] + [length for length, _ in context.bodies])  # [m]
        zones = crossing_zones(context.movements, movement_crossings(context.movements), longest,
                               context.touch_width)
        waits = {pid: (context.paths[pid].s_wait, lanes) for pid, lanes in waiting_watches(context.movements).items()}
        self.filter = SafetyFilter(GuardedJunction(
            settings or SafetySettings(exit_room=fs.exit_room), self.problem, model, context.movements, self.table.s_stop,
            self.table.s_wait, waits, context.control_period,
            gap_slack=3.0 * math.sqrt(2.0) * context.position_noise, crossing_zones=zones))
        self._warm_up()

    def _warm_up(self) -> None:
        """Call the compiled kernels the rules use once before the first step (numba loads each
        from its cache at its first call, up to seconds: a first step over its budget would make
        the run depend on the machine's speed), as the game controller does."""
        occupancy_times(np.array([[0.0, 1.0]]), np.array([2], np.intp), np.array([0.1]), np.zeros(1, np.intp),
                        np.array([0.5]))
        Plan.from_accelerations(0.0, 5.0, np.zeros(self.problem.steps), self.problem.dt)
        time_to_conflict_point(np.array([1.0]), np.array([1.0]), self.ctx.model.tcp_speed_floor)

    @property
    def steps(self) -> int:
        """[-] samples of the plans the rules check (the game's horizon / dt)."""
        return self.problem.steps

    def plan(self, s: float, v: float, a0: float, s_stop: float, grant: Grant | None, past: bool,
             now: float) -> Plan:
        """The plan the rules check for an AV at ``s`` [m], ``v`` [m/s] commanded ``a0`` [m/s^2]:
        its ``grant`` flown (:func:`flown_plan`) from ``now`` [s]; through its stop line ``s_stop``
        [m] at once if it is ``past`` it or granted its earliest arrival; stopped ``follow_gap``
        before it without a grant (held) or with a stop-and-go one."""
        fs, p = self.fs, self.problem
        go = grant is not None and (past or grant.earliest or grant.t_arrive <= now)
        t_go = 0.0 if go else (None if grant is None else grant.t_arrive - now)
        v_go = 0.0 if grant is None else grant.v_arrive
        line = s_stop - (fs.follow_gap if v_go <= 0 and not go else 0.0)
        return flown_plan(s, v, a0, line, t_go, v_go, (fs.comfort_accel, fs.max_brake, self.ctx.model.v_max),
                          p.steps, p.dt)

    def release(self, vehicles) -> None:
        """Forget vehicles handed back to SUMO."""
        for vid in vehicles:
            self.filter.release(vid)

    def apply(self, world: World, accel: Mapping[str, float], plans: Mapping[str, Plan],
              options: Mapping[str, str]) -> SafetyResult:
        """The filter's rules on fcfs's decided ``accel`` [m/s^2] (vehicle id -> value), their
        ``plans`` and the exit lane each takes (``options``)."""
        self.filter.record_entries(world)
        index = {vid: k for k, vid in enumerate(world.ids)}
        active = {index[vid] for vid in accel}
        relations = step_relations(world, active, self.ctx.movements, self.table, self.ctx.model, self.ctx.etm,
                                   options, 0.0)
        return self.filter.apply(world, relations, plans, options, accel)
