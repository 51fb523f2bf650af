"""A non-player leader (Player.leader) enters the follower's J_log; nobody optimises it."""

import numpy as np
import pytest

from intersection_cosim.games.nash import nash_equilibrium
from intersection_cosim.games.problem import Player, Problem
from intersection_cosim.games.settings import GameSettings


@pytest.fixture
def slow_leader():
    t = np.arange(1, 31) * 0.1  # [s]
    return (20.0 + 3.0 * t, np.full(30, 3.0))  # 20 m ahead, 3 m/s


def test_cautious_follower_keeps_behind_a_slow_leader(slow_leader):
    gs = GameSettings()
    follow = nash_equilibrium(Problem((Player(0.0, 8.0, 0.2, leader=slow_leader),)), gs)
    free = nash_equilibrium(Problem((Player(0.0, 8.0, 0.2),)), gs)
    assert follow.status == "converged"
    gap = slow_leader[0] - follow.plans[0].positions[1:] - 4.5  # [m]
    assert gap.min() > 3.0
    # [m/s] 6.08 behind the leader (gap 4.25 m at 3 s, closing), 8.36 free
    assert follow.plans[0].speeds[-1] < 6.5 < free.plans[0].speeds[-1]


def test_leader_is_kept_by_decoupled_and_its_cost_counts(slow_leader):
    problem = Problem((Player(0.0, 8.0, 0.5, leader=slow_leader),))
    assert problem.decoupled().players[0].leader is slow_leader
    gs = GameSettings()
    with_leader = nash_equilibrium(problem, gs)
    without = nash_equilibrium(Problem((Player(0.0, 8.0, 0.5),)), gs)
    # the leader makes the same player slower and its cost higher
    assert with_leader.plans[0].mean_speed < without.plans[0].mean_speed - 1.0
    assert with_leader.costs[0] > without.costs[0]


def test_bad_leader_shape_is_a_solver_failure_not_an_exception():
    bad = (np.zeros(5), np.zeros(5))
    result = nash_equilibrium(Problem((Player(0.0, 8.0, 0.5, leader=bad),)), GameSettings())
    assert result.status == "solver failure"
    assert result.plans[0].speeds[-1] < 8.0
