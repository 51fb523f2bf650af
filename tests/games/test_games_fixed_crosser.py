"""A crossing non-player (Player.crossers, a human driver) enters the player's J_lat with its
forecast fixed; nobody optimises it."""

import numpy as np
import pytest

from intersection_cosim.games.nash import nash_equilibrium
from intersection_cosim.games.problem import Player, Problem
from intersection_cosim.games.settings import GameSettings

T = np.arange(1, 31) * 0.1  # [s] the horizon's steps
S_CP = 30.0  # [m] the crossing on the player's path, 30 m ahead of it
# the crosser: 25 m before its point on its own path at a steady 10 m/s: there at t = 2.5 s
CROSSER = (S_CP, 40.0, 15.0 + 10.0 * T, np.full(30, 10.0))


def _short_of_the_point_when_the_crosser_is_there(plan) -> float:
    """[m] how far before its conflict point the player is at t = 2.5 s (the crosser at its own)."""
    return S_CP - float(plan.positions[25])


def test_a_cautious_player_leaves_a_wider_time_gap_at_a_fixed_crosser():
    gs = GameSettings()
    # at its 10 m/s (the model's v_max) the player reaches the point at t = 3 s, 0.5 s after
    alone = nash_equilibrium(Problem((Player(0.0, 10.0, 0.2),)), gs)
    crossed = nash_equilibrium(Problem((Player(0.0, 10.0, 0.2, crossers=(CROSSER,)),)), gs)
    assert crossed.status == "converged"
    assert _short_of_the_point_when_the_crosser_is_there(alone.plans[0]) == pytest.approx(5.0)
    # it slows down and lets the crosser go clearly first: 0.5 s at 10 m/s become > 1 s
    assert crossed.plans[0].speeds[-1] < alone.plans[0].speeds[-1] - 2.0
    assert _short_of_the_point_when_the_crosser_is_there(crossed.plans[0]) > 10.0
    assert crossed.costs[0] > alone.costs[0]  # the crossing costs it something
    # kept by decoupled(): it is part of the player's own problem, like Player.leader
    problem = Problem((Player(0.0, 10.0, 0.2, crossers=(CROSSER,)),))
    assert problem.decoupled().players[0].crossers == (CROSSER,)


def test_a_non_finite_crosser_is_a_solver_failure_not_an_exception():
    bad = (S_CP, 40.0, np.full(30, np.nan), np.full(30, 10.0))
    result = nash_equilibrium(Problem((Player(0.0, 10.0, 0.5, crossers=(bad,)),)), GameSettings())
    assert result.status == "solver failure"
