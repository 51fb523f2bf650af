"""The coupled N-player game of a conflict cluster (games/coupled.py), without SUMO."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from intersection_cosim.games import Interaction, Player, Problem, nash_equilibrium
from intersection_cosim.games.coupled import (conflict_clusters, coupled_nash, coupled_stackelberg,
                                              hierarchy_order)
from intersection_cosim.games.coupled_check import check_cluster

PLAYER = Player(0.0, 8.0, 0.5)  # [m], [m/s]: 20 m (2.5 s) before the first conflict point below


def _mirror() -> Problem:
    """Player 0 crosses players 1 and 2 at the same points of its path; 1 and 2 are mirror images
    (swapping them maps the problem onto itself) and do not meet."""
    return Problem((PLAYER,) * 3, (Interaction.cross(0, 1, 20.0, 15.0), Interaction.cross(0, 2, 20.0, 15.0)))


def _disagreeing() -> Problem:
    """Player 0 reaches its point with 1 later than 1 does, and its point with 2 earlier than 2."""
    return Problem((PLAYER,) * 3, (Interaction.cross(0, 1, 20.0, 15.0), Interaction.cross(0, 2, 15.0, 20.0)))


def test_conflict_clusters_are_the_connected_components():
    assert conflict_clusters([(0, 1), (5, 6), (1, 2), (7, 3), (3, 6)]) == [(0, 1, 2), (3, 5, 6, 7)]
    assert conflict_clusters([]) == []


def test_hierarchy_is_ordered_by_tcp_and_a_leader_ranks_above_its_follower():
    far = Player(-30.0, 8.0, 0.5)
    prob = Problem((far, PLAYER, PLAYER), (Interaction.cross(0, 1, 10.0, 30.0), Interaction.following(2, 0)))
    # TCP: player 0 40/8 = 5 s, player 1 30/8 = 3.75 s; player 2 (no conflict point) follows 0
    assert hierarchy_order(prob) == (1, 0, 2)


@pytest.mark.parametrize("scheme", ["jacobi", "gauss-seidel"])
def test_symmetric_crossing_has_the_symmetric_equilibrium(gs, ms, scheme):
    prob = _mirror()
    settings = dataclasses.replace(gs, solver=dataclasses.replace(gs.solver, scheme=scheme))
    res = coupled_nash(prob, settings, ms)
    assert res.status == "converged"
    # by symmetry the mirror images 1 and 2 plan alike, to within the iteration's stopping rule
    # (plans still move a few nash_tol when it stops on a small cost gain; under Jacobi the two
    # answers differ by the QP solver's own tolerance, 1e-4 in a fresh environment)
    tol = 5 * gs.solver.nash_tol
    assert np.abs(res.accelerations[1] - res.accelerations[2]).max() < tol
    assert res.costs[1] == pytest.approx(res.costs[2], rel=1e-2)
    check = check_cluster(prob, res, "nash", settings, ms)
    assert check.passed, check
    # player 0 carries J_lat of both partners: it yields more than in its pairwise game with one
    pair = nash_equilibrium(Problem((PLAYER, PLAYER), (Interaction.cross(0, 1, 20.0, 15.0),)), gs, ms)
    assert res.plans[0].mean_speed < pair.plans[0].mean_speed - 0.3
    assert res.plans[1].mean_speed == pytest.approx(pair.plans[1].mean_speed, abs=0.05)


def test_coupled_game_resolves_pairwise_answers_that_disagree(gs, ms):
    prob = _disagreeing()
    g01 = nash_equilibrium(Problem((PLAYER, PLAYER), (prob.interactions[0],)), gs, ms)
    g02 = nash_equilibrium(Problem((PLAYER, PLAYER), (Interaction.cross(0, 1, 15.0, 20.0),)), gs, ms)
    first = (g01.plans[0].accelerations[0], g02.plans[0].accelerations[0])
    assert first[0] < -3.0 and first[1] > 2.0  # yield to 1, go before 2
    # the pairwise controller's combination (the lowest first acceleration) is no equilibrium
    combined = [min((g01.plans[0], g02.plans[0]), key=lambda p: p.accelerations[0]), g01.plans[1], g02.plans[1]]
    assert not check_cluster(prob, combined, "nash", gs, ms).passed
    res = coupled_nash(prob, gs, ms)
    assert res.status == "converged"
    check = check_cluster(prob, res, "nash", gs, ms)
    assert check.passed and check.resolve_gain < 1e-3, check


def test_stackelberg_hierarchy_leader_no_worse_than_nash_and_followers_answer(gs, ms):
    prob = Problem((PLAYER,) * 3, (Interaction.cross(0, 1, 20.0, 15.0), Interaction.cross(1, 2, 20.0, 15.0),
                                   Interaction.cross(2, 0, 20.0, 15.0)))
    nash = coupled_nash(prob, gs, ms)
    res = coupled_stackelberg(prob, gs, ms, nash=nash)
    assert res.status == "converged" and res.leader == hierarchy_order(prob, ms)[0] == 0
    assert res.costs[0] <= nash.costs[0] + 1e-9
    check = check_cluster(prob, res, "stackelberg", gs, ms)
    assert check.players == (2,) and check.passed, check


def test_warm_coupled_stackelberg_keeps_a_converged_point(gs, ms):
    prob = _disagreeing()
    cold = coupled_stackelberg(prob, gs, ms)
    warm = coupled_stackelberg(prob, gs, ms, warm_start=cold.plans)
    assert warm.status == "converged"
    assert np.abs(warm.accelerations - cold.accelerations).max() < 0.05
