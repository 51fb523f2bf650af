"""Equilibrium checks (paper Section IV): what a player gains by deviating alone.

Independent of the SQP/OSQP solvers: each player's true cost (models.cost) is minimised by
``scipy.optimize.minimize(method="SLSQP")`` over its accelerations, the others' plans fixed, from
several starts (the equilibrium plan, full acceleration, comfortable braking, constant speed, then
seeded random plans), subject to a_min <= a <= a_max and 0 <= v <= v_cap. The gradient passed to
SLSQP is the analytic gradient of the smooth parts of the cost; the value is always the true cost.

* Nash (Eq. 25): the point is an equilibrium to ``tolerance`` when no player's best deviation
  lowers its cost by more than ``tolerance * max(|cost|, cost_floor)``.
* Stackelberg (Eqs. 34-35): (a) the follower is at its best response to the leader's plan (the
  same deviation test), (b) the leader's cost is not above its cost at the Nash equilibrium (its
  payoff is at least the Nash payoff), to the same relative tolerance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.optimize import minimize

from intersection_cosim.games.objective import PlayerObjective
from intersection_cosim.games.problem import GameResult, Plan, Problem, project_accelerations
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.models.settings import ModelSettings

COST_FLOOR = 1e-3  # [-] relative gains are taken of max(|cost|, COST_FLOOR)


@dataclass(frozen=True)
class Deviation:
    """Best unilateral deviation found for one player."""

    player: int
    cost: float  # [-] cost at the checked point
    best_cost: float  # [-] lowest cost found by deviating alone
    plan: Plan  # the deviation that achieves best_cost

    @property
    def gain(self) -> float:
        """[-] how much the player could lower its cost by deviating alone (>= 0)."""
        return max(0.0, self.cost - self.best_cost)

    @property
    def relative_gain(self) -> float:
        """[-] gain / max(|cost|, COST_FLOOR)."""
        return self.gain / max(abs(self.cost), COST_FLOOR)


@dataclass(frozen=True)
class NashCheck:
    deviations: tuple[Deviation, ...]
    tolerance: float  # [-] allowed relative gain

    @property
    def max_relative_gain(self) -> float:
        return max(d.relative_gain for d in self.deviations)

    @property
    def passed(self) -> bool:
        return self.max_relative_gain <= self.tolerance


@dataclass(frozen=True)
class StackelbergCheck:
    leader: int
    follower: int
    follower_deviation: Deviation
    leader_cost: float  # [-] at the Stackelberg point
    leader_cost_nash: float  # [-] at the Nash equilibrium
    tolerance: float  # [-]

    @property
    def follower_at_best_response(self) -> bool:
        return self.follower_deviation.relative_gain <= self.tolerance

    @property
    def leader_not_worse(self) -> bool:
        """The leader's payoff is at least its Nash payoff (cost not above, to tolerance)."""
        slack = self.tolerance * max(abs(self.leader_cost_nash), COST_FLOOR)
        return self.leader_cost <= self.leader_cost_nash + slack

    @property
    def passed(self) -> bool:
        return self.follower_at_best_response and self.leader_not_worse


def _plans(result_or_plans: GameResult | Sequence[Plan]) -> list[Plan]:
    return list(result_or_plans.plans if isinstance(result_or_plans, GameResult) else result_or_plans)


def best_deviation(problem: Problem, plans: Sequence[Plan], player: int,
                   settings: GameSettings | None = None, model_settings: ModelSettings | None = None,
                   starts: int = 4, seed: int = 0) -> Deviation:
    """Lowest true cost ``player`` reaches by changing only its own plan (module docstring)."""
    gs = settings or GameSettings()
    ms = model_settings or ModelSettings()
    obj = PlayerObjective(problem, player, gs, ms)
    obj.set_others(plans)
    n, dt = obj.n, gs.problem.dt
    a_eq = np.asarray(plans[player].accelerations, dtype=float)
    cost_eq = float(obj.cost(a_eq))
    Lv = np.tril(np.ones((n, n))) * dt
    cons = ({"type": "ineq", "fun": lambda a: obj.v0 + Lv @ a, "jac": lambda a: Lv},
            {"type": "ineq", "fun": lambda a: obj.v_cap - obj.v0 - Lv @ a, "jac": lambda a: -Lv})
    rng = np.random.default_rng(seed)
    candidates = [a_eq, np.full(n, gs.problem.a_max), np.full(n, -gs.problem.comfort_brake), np.zeros(n)]
    while len(candidates) < starts:
        candidates.append(rng.uniform(gs.problem.a_min, gs.problem.a_max, n))
    best_a, best_c = a_eq, cost_eq

    def fun(a):
        return float(obj.cost(a)), obj.model(a)[0]

    for a0 in candidates[:max(starts, 1)]:
        a0 = project_accelerations(a0, obj.v0, obj.v_cap, gs)
        res = minimize(fun, a0, jac=True, method="SLSQP", bounds=[(gs.problem.a_min, gs.problem.a_max)] * n,
                       constraints=cons, options={"maxiter": 300, "ftol": 1e-12})
        a = project_accelerations(res.x, obj.v0, obj.v_cap, gs)  # remove SLSQP's tiny violations
        c = float(obj.cost(a))
        if math.isfinite(c) and c < best_c:
            best_a, best_c = a, c
    return Deviation(player, cost_eq, best_c, Plan.from_accelerations(obj.s0, obj.v0, best_a, dt))


def check_nash(problem: Problem, result: GameResult | Sequence[Plan],
               settings: GameSettings | None = None, model_settings: ModelSettings | None = None,
               starts: int = 4, seed: int = 0, tolerance: float = 0.01) -> NashCheck:
    """Each player's best unilateral deviation from ``result`` (Eq. 25)."""
    plans = _plans(result)
    devs = tuple(best_deviation(problem, plans, p, settings, model_settings, starts, seed + p)
                 for p in range(problem.n))
    return NashCheck(devs, tolerance)


def check_stackelberg(problem: Problem, result: GameResult, nash: GameResult | None = None,
                      settings: GameSettings | None = None,
                      model_settings: ModelSettings | None = None, starts: int = 4, seed: int = 0,
                      tolerance: float = 0.01) -> StackelbergCheck:
    """Conditions (a) and (b) of the Stackelberg equilibrium (Eqs. 34-35) for a two-player result.

    ``nash`` defaults to a cold :func:`nash_equilibrium` of the same problem.
    """
    from intersection_cosim.games.nash import nash_equilibrium

    gs = settings or GameSettings()
    ms = model_settings or ModelSettings()
    if problem.n != 2 or result.leader is None:
        raise ValueError("check_stackelberg needs a two-player Stackelberg result")
    leader, follower = result.leader, 1 - result.leader
    nash = nash if nash is not None else nash_equilibrium(problem, gs, ms)
    dev = best_deviation(problem, result.plans, follower, gs, ms, starts, seed)
    leader_obj = PlayerObjective(problem, leader, gs, ms)
    leader_obj.set_others(result.plans)
    c_se = float(leader_obj.cost(result.plans[leader].accelerations))
    leader_obj.set_others(nash.plans)
    c_ne = float(leader_obj.cost(nash.plans[leader].accelerations))
    return StackelbergCheck(leader, follower, dev, c_se, c_ne, tolerance)
