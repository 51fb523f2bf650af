"""The comfort weight by aggressiveness (ProblemSettings.w_accel_kappa)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from intersection_cosim.games import GameSettings, Interaction, Plan, Player, Problem, best_response
from intersection_cosim.games.objective import PlayerObjective
from intersection_cosim.games.weights import comfort_weight
from intersection_cosim.games.settings import ProblemSettings
from intersection_cosim.models.settings import ModelSettings


def test_comfort_weight_falls_with_kappa_and_is_w_accel_at_one_half():
    p = ProblemSettings(w_accel=0.1, w_accel_kappa=0.15)
    assert comfort_weight(p, 0.5) == pytest.approx(0.1)
    assert comfort_weight(p, 0.2) == pytest.approx(0.145)
    assert comfort_weight(p, 0.9) == pytest.approx(0.04)
    # never below w_accel_floor (0.01 by default, so every best response stays strictly convex)
    assert comfort_weight(ProblemSettings(w_accel=0.1, w_accel_kappa=0.5), 1.0) == pytest.approx(0.01)
    assert comfort_weight(ProblemSettings(w_accel=0.1, w_accel_kappa=0.5, w_accel_floor=0.0), 1.0) == 0.0
    assert comfort_weight(ProblemSettings(w_accel=0.1, w_accel_kappa=0.25), 0.8) == pytest.approx(0.025)
    assert comfort_weight(ProblemSettings(w_accel=0.1, w_accel_kappa=0.0), 0.9) == pytest.approx(0.1)
    # ... nor raised by it above w_accel: a user's own small w_accel stands
    assert comfort_weight(ProblemSettings(w_accel=0.005), 0.5) == pytest.approx(0.005)
    assert comfort_weight(ProblemSettings(w_accel=0.005, w_accel_kappa=0.1), 0.9) == pytest.approx(0.005)
    assert {f for f, _ in ProblemSettings(w_accel_kappa=-1.0).check()} == {"w_accel_kappa"}
    assert {f for f, _ in ProblemSettings(w_accel_floor=-0.1).check()} == {"w_accel_floor"}


def test_true_cost_charges_the_players_own_comfort_weight(ms):
    gs = GameSettings(problem=ProblemSettings(w_accel_kappa=0.15))
    a = np.linspace(1.0, -1.0, gs.problem.steps)
    costs = {}
    for kappa in (0.2, 0.8):
        problem = Problem((Player(0.0, 6.0, kappa), Player(2.0, 5.0, 0.5)), (Interaction.cross(0, 1, 14.0, 12.0),))
        obj = PlayerObjective(problem, 0, gs, ms)
        obj.set_others([None, Plan.from_accelerations(2.0, 5.0, np.zeros(gs.problem.steps), gs.problem.dt)])
        same_but_flat = dataclasses.replace(gs.problem, w_accel=0.0, w_accel_kappa=0.0, w_accel_floor=0.0)
        obj_flat = PlayerObjective(problem, 0, GameSettings(problem=same_but_flat, solver=gs.solver), ms)
        obj_flat.set_others([None, Plan.from_accelerations(2.0, 5.0, np.zeros(gs.problem.steps), gs.problem.dt)])
        costs[kappa] = obj.cost(a) - obj_flat.cost(a)
    # the difference is dt * w(kappa) * sum a^2: 0.145 at kappa 0.2, 0.055 at 0.8
    assert costs[0.2] == pytest.approx(gs.problem.dt * 0.145 * np.sum(a**2), rel=1e-9)
    assert costs[0.8] == pytest.approx(gs.problem.dt * 0.055 * np.sum(a**2), rel=1e-9)


def test_comfort_by_kappa_spreads_a_lone_players_acceleration():
    """Alone at 5 m/s (no interaction) the only trade-off is J_e against comfort: with the weight
    falling by kappa, a cautious player (0.2) gains less speed over 2 s and an aggressive one
    (0.8) at least as much as with one weight for all; kappa 0.5 is unchanged."""
    def gain(kappa, w_accel_kappa):
        gs = GameSettings(problem=ProblemSettings(w_accel_kappa=w_accel_kappa))
        res = best_response(Problem((Player(0.0, 5.0, kappa),), ()), 0, [None], gs, ms)
        assert res.status == "converged"
        return float(np.sum(res.plan.accelerations[:20]) * gs.problem.dt)  # [m/s] gained over 2 s

    ms = ModelSettings()
    assert gain(0.5, 0.15) == pytest.approx(gain(0.5, 0.0), abs=1e-3)
    assert gain(0.2, 0.15) < gain(0.2, 0.0) - 0.2
    assert gain(0.8, 0.15) >= gain(0.8, 0.0) - 1e-3
    assert gain(0.2, 0.15) < gain(0.5, 0.15) < gain(0.8, 0.15)
