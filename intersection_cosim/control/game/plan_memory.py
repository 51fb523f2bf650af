"""What the game controller remembers between control steps: the plan and exit lane each vehicle
drives, and the solved plans that warm-start the next solve of the same game or solo problem.

Plans are receding-horizon sequences at the solver step ``dt``; one control period is ``shift``
solver steps, so a plan one period old is the stored plan shifted by ``shift``
(:func:`~intersection_cosim.games.problem.shift_plan`: drop the first steps, repeat the last).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Union

import numpy as np

from intersection_cosim.control.base import World
from intersection_cosim.games.problem import Plan, shift_plan
from intersection_cosim.models.prediction import human_accelerations


@dataclass(frozen=True)
class SoloKey:
    """The solo problem of one vehicle for one exit lane."""

    vehicle: str
    exit_lane: str

    def vehicles(self) -> tuple[str, ...]:
        return (self.vehicle,)


@dataclass(frozen=True)
class GameKey:
    """The game of a pair (``a`` the first player) for one combination of exit lanes."""

    a: str
    b: str
    exit_a: str
    exit_b: str

    def vehicles(self) -> tuple[str, ...]:
        return (self.a, self.b)


WarmKey = Union[SoloKey, GameKey]

SHIFT_CACHE_SIZE = 4096  # [-] shifted plans one step may keep (a few per controlled vehicle)


def human_forecast(world: World, k: int, a_max: float, v_max: float, steps: int, dt: float,
                   a0: float | None = None) -> Plan:
    """The plan human driver k is predicted to drive (models.prediction.human_accelerations: its
    acceleration clipped to [0, ``a_max``] [m/s^2], up to its desired speed, else ``v_max``
    [m/s]) over ``steps`` steps of ``dt`` [s], from its measured state; ``a0`` [m/s^2] in place
    of its measured acceleration (``a_max``: it starts now)."""
    v_cap = v_max
    if world.desired_speed is not None and math.isfinite(float(world.desired_speed[k])):
        v_cap = float(world.desired_speed[k])
    v0 = float(world.v[k])
    a = human_accelerations(v0, float(world.a[k]) if a0 is None else a0, a_max, max(v_cap, v0), steps, dt)
    return Plan.from_accelerations(float(world.s[k]), v0, a, dt)


class PlanMemory:
    """Applied plans and exit lanes per vehicle, and warm starts per problem.

    ``shift``: solver steps per control period; ``period`` [s] the control period;
    ``steps`` the horizon N; ``dt`` [s] the solver step; ``a_max`` [m/s^2] and ``v_max`` [m/s]
    bound the forecast of a human driver (:meth:`human_plan`).
    """

    def __init__(self, shift: int, period: float, steps: int, dt: float, a_max: float, v_max: float):
        self.shift, self.period, self.steps, self.dt = shift, period, steps, dt
        self.a_max, self.v_max = a_max, v_max
        self.plans: dict[str, Plan] = {}  # plan applied at the last step, per vehicle
        self.options: dict[str, str] = {}  # exit lane chosen at the last step, per vehicle
        self._warm: dict[WarmKey, tuple[float, tuple[Plan, ...]]] = {}  # key -> ([s] solved at, plans)
        self._shifts: dict[int, tuple[Plan, Plan]] = {}  # id(plan) -> (plan, shift_plan(plan)), this step
        self._shifts_before: dict[int, tuple[Plan, Plan]] = {}  # the same, of the last step
        self._anchored: dict[str, tuple[Plan, float, float, Plan]] = {}  # vehicle -> (applied plan, s [m], v [m/s], kept plan)

    # ------------------------------------------------------------ applied plans
    def apply(self, vehicle: str, plan: Plan, option: str) -> None:
        self.plans[vehicle] = plan
        self.options[vehicle] = option

    def forget(self, vehicle: str) -> None:
        """Drop a vehicle handed back to SUMO."""
        self.plans.pop(vehicle, None)
        self.options.pop(vehicle, None)
        self._anchored.pop(vehicle, None)

    def new_step(self) -> None:
        """Start a control step: shifted plans not used in the last step are dropped. Freeing
        them step by step keeps a step's cost even; emptying a full cache of 4096 entries at
        once (some 16 000 arrays) took about 9 ms of one step, half a 20 ms budget."""
        self._shifts_before, self._shifts = self._shifts, {}

    def prune_warm(self, present: set[str]) -> None:
        """Drop the warm starts of problems with a vehicle no longer controlled."""
        self._warm = {key: v for key, v in self._warm.items() if present.issuperset(key.vehicles())}

    def shifted(self, plan: Plan, periods: int = 1) -> Plan:
        """``plan`` moved on by ``periods`` control periods."""
        for _ in range(periods * self.shift):
            plan = self._shift_once(plan)
        return plan

    def _shift_once(self, plan: Plan) -> Plan:
        """:func:`shift_plan`, computed once per Plan object: a step shifts the same plan as a
        vehicle's own warm start, its reuse check and its follower's leader prediction (Plans
        are immutable; the entry holds the plan itself, so a recycled id never matches)."""
        key = id(plan)
        hit = self._shifts.get(key) or self._shifts_before.get(key)
        if hit is not None and hit[0] is plan:
            self._shifts[key] = hit  # used this step: kept for the next one too
            return hit[1]
        if len(self._shifts) >= SHIFT_CACHE_SIZE:  # a guard; one step uses a few hundred
            self._shifts.clear()
        out = shift_plan(plan)
        self._shifts[key] = (plan, out)
        return out

    def from_state(self, world: World, k: int, a) -> Plan:
        """The plan of accelerations ``a`` [m/s^2] started from vehicle k's measured state."""
        return Plan.from_accelerations(float(world.s[k]), float(world.v[k]), a, self.dt)

    def coasting_plan(self, world: World, k: int) -> Plan:
        """Vehicle k at constant speed (one SUMO drives again, having left the junction)."""
        return self.from_state(world, k, np.zeros(self.steps))

    def human_plan(self, world: World, k: int) -> Plan:
        """Human driver k's forecast (:func:`human_forecast`)."""
        return human_forecast(world, k, self.a_max, self.v_max, self.steps, self.dt)

    def kept_plan(self, world: World, k: int, comfort_brake: float) -> Plan:
        """Vehicle k's last applied plan shifted by one period and started from its measured
        state; braking at ``comfort_brake`` [m/s^2] if it has none."""
        plan = self.anchored(world, k)
        if plan is not None:
            return plan
        return self.from_state(world, k, np.full(self.steps, -comfort_brake))

    def anchored(self, world: World, k: int) -> Plan | None:
        """Vehicle k's last applied plan shifted by one period and started from its measured
        state, None when it has none. Computed once per applied plan and state: a step asks for
        it as the vehicle's kept plan, in its reuse check and as its follower's leader prediction."""
        vid = world.ids[k]
        plan = self.plans.get(vid)
        if plan is None:
            return None
        s, v = float(world.s[k]), float(world.v[k])  # [m], [m/s]
        hit = self._anchored.get(vid)
        if hit is not None and hit[0] is plan and hit[1] == s and hit[2] == v:
            return hit[3]
        out = Plan.from_accelerations(s, v, self.shifted(plan).accelerations, self.dt)
        self._anchored[vid] = (plan, s, v, out)
        return out

    def driven_plan(self, vehicle: str, option: str) -> Plan | None:
        """The plan ``vehicle`` drives (applied at the last step), shifted by one period, if it
        is for exit lane ``option``: the warm start of its own solo solve, and of a game its
        vehicles have not played yet (a cold start would first solve each player's decoupled
        optimum, which the solo plan it drives already is, up to its real-time iteration)."""
        plan = self.plans.get(vehicle)
        if plan is None or self.options.get(vehicle) != option:
            return None
        return self.shifted(plan)

    def held_option(self, vehicle: str, default: str) -> str:
        """The exit lane ``vehicle`` holds: its last choice, else ``default``."""
        return self.options.get(vehicle, default)

    # ------------------------------------------------------------ warm starts
    def store(self, key: WarmKey, now: float, plans: tuple[Plan, ...]) -> None:
        """Keep ``plans`` solved at ``now`` [s] as the next warm start of ``key``."""
        self._warm[key] = (now, plans)

    def warm_start(self, key: WarmKey, now: float) -> tuple[Plan, ...] | None:
        """The plans stored under ``key``, shifted by the control periods since they were solved
        (a pair's game may pause while its trigger is off), or None when there are none or they
        are older than half the horizon (little of them would be left to reuse)."""
        periods = self.periods_since(key, now)
        if periods is None:
            return None
        periods = max(1, periods)
        if periods * self.shift > self.steps // 2:
            return None
        return tuple(self.shifted(p, periods) for p in self._warm[key][1])

    def periods_since(self, key: WarmKey, now: float) -> int | None:
        """Control periods since the plans under ``key`` were stored at ``now`` [s] (None: none)."""
        entry = self._warm.get(key)
        return None if entry is None else int(round((now - entry[0]) / self.period))

    def keys(self) -> Iterable[WarmKey]:
        return tuple(self._warm)
