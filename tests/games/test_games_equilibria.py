"""Equilibrium quality on a seeded battery, decoupled games, aggressiveness, warm starts."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from intersection_cosim.games import (GameSettings, Interaction, Player, Problem, best_response,
                                      check_nash, check_stackelberg, nash_equilibrium,
                                      shift_plans, stackelberg_equilibrium, stackelberg_leader)
from intersection_cosim.games.battery import advance
from intersection_cosim.games.qp import reset_workspaces
from intersection_cosim.games.settings import SolverSettings
from intersection_cosim.models.cost import time_to_conflict_point


def test_nash_gap_on_battery(pair_battery, nash_battery, gs, ms):
    """Item 5 check on >= 50 random crossing / merging pairs: median gap < 1 %, >= 95 % under 5 %."""
    assert len(pair_battery) >= 50
    assert all(r.status == "converged" for r in nash_battery)
    gaps = []
    for problem, result in zip(pair_battery, nash_battery):
        check = check_nash(problem, result, gs, ms, starts=3)
        gaps.extend(d.relative_gain for d in check.deviations)
    gaps = np.array(gaps)
    assert np.median(gaps) < 0.01
    assert np.mean(gaps < 0.05) >= 0.95


def test_stackelberg_passes_checks_on_battery(pair_battery, nash_battery, gs, ms):
    """Every Stackelberg solution: leader no worse than at Nash; follower at its best response
    (within the check's 1 %) in all but one problem in 60 and within 2 % in every one. (The
    leader's iteration ends once a single follower SQP step gains less than nash_cost_rtol; with
    the default k_lat = 5 one battery problem's follower could still gain 1.2 % by polishing on.
    Polishing every follower to convergence doubled the warm solve, 1.25 -> 2.3 ms.)"""
    gains, follower_gaps = [], []
    for problem, nash in zip(pair_battery, nash_battery):
        se = stackelberg_equilibrium(problem, gs, ms, nash=nash)
        assert se.status == "converged"
        assert se.leader == stackelberg_leader(problem, ms)
        check = check_stackelberg(problem, se, nash, gs, ms, starts=2)
        follower_gaps.append(check.follower_deviation.relative_gain)
        assert check.leader_not_worse, (check.leader_cost, check.leader_cost_nash)
        gains.append(check.leader_cost_nash - check.leader_cost)
    assert min(gains) >= 0.0  # the leader never loses against its Nash payoff
    follower_gaps = np.array(follower_gaps)
    assert np.sum(follower_gaps >= 0.01) <= 1 and follower_gaps.max() < 0.02, follower_gaps.max()


def test_decoupled_game_gives_own_optimum_in_one_iteration(gs, ms):
    players = (Player(0.0, 4.0, 0.3), Player(5.0, 7.0, 0.8), Player(0.0, 6.0, 0.5))
    result = nash_equilibrium(Problem(players), gs, ms)
    assert result.status == "converged"
    assert result.iterations == 1
    assert result.residuals[0] < gs.solver.nash_tol
    for p in range(3):
        alone = best_response(Problem(players), p, None, gs, ms)
        assert alone.status == "converged"
        assert result.plans[p].accelerations == pytest.approx(alone.plan.accelerations, abs=2e-3)
        assert result.costs[p] == pytest.approx(alone.cost, rel=1e-4)
    # the own optimum of a kappa > 0 player accelerates towards v_max
    assert result.plans[1].speeds[-1] > players[1].v0


def test_a_single_player_game_is_its_best_response(gs, ms):
    """A vehicle alone (the controller's solo solve) is one best response: cold, it ends near the
    stand-alone best response; warm from that, one QP confirms it."""
    lead = (15.0 + 4.0 * 0.1 * np.arange(1, gs.problem.steps + 1), np.full(gs.problem.steps, 4.0))  # [m], [m/s]
    problem = Problem((Player(0.0, 8.0, 0.5, leader=lead),))
    cold = nash_equilibrium(problem, gs, ms)
    alone = best_response(problem, 0, None, gs, ms)
    assert cold.status == "converged" and cold.iterations < gs.solver.nash_max_iter
    # the iteration stops on the Nash criteria (a step gaining < nash_cost_rtol): near, not at,
    # the stand-alone best response (within the 1 % Nash-gap target of the issue)
    assert alone.cost - 1e-9 <= cold.costs[0] <= alone.cost * 1.015
    warm = nash_equilibrium(problem, gs, ms, warm_start=cold.plans)
    assert (warm.status, warm.iterations, warm.qp_count) == ("converged", 1, 1)
    assert warm.costs[0] <= cold.costs[0] + 1e-9



def _min_lateral_ttc(problem, result, ms):
    it = problem.interactions[0]
    p0, p1 = result.plans
    tcp0 = time_to_conflict_point(it.s_cp_i - p0.positions, p0.speeds, ms.tcp_speed_floor)
    tcp1 = time_to_conflict_point(it.s_cp_j - p1.positions, p1.speeds, ms.tcp_speed_floor)
    active = ((p0.positions - it.s_cp_i) <= ms.conflict_clearance) & \
        ((p1.positions - it.s_cp_j) <= ms.conflict_clearance)
    return float(np.abs(tcp0 - tcp1)[1:][active[1:]].min())  # states x_1..x_N


def test_higher_kappa_faster_and_closer(gs, ms):
    """Raising kappa of player 0 (all else equal): its mean speed rises, the min TTC_lat falls.

    From kappa 0.3 to 0.7 player 0 yields and the margin stays on a plateau at 0.677 s (within
    1e-4 s: player 1's own trade-off sets it) while player 0 brakes less (mean speed 3.39, 4.18,
    5.19 m/s); at 0.9 (comfort weight at its floor, ProblemSettings.w_accel_kappa) it takes the
    crossing first, 8.61 m/s, and passes 0.21 s ahead."""
    speeds, ttcs = [], []
    for kappa in (0.3, 0.5, 0.7, 0.9):
        problem = Problem((Player(0.0, 5.5, kappa), Player(0.0, 5.0, 0.5)),
                          (Interaction.cross(0, 1, 20.0, 17.0),))
        result = nash_equilibrium(problem, gs, ms)
        assert result.status == "converged"
        speeds.append(result.plans[0].mean_speed)
        ttcs.append(_min_lateral_ttc(problem, result, ms))
    assert np.all(np.diff(speeds) > 0.1), speeds
    assert np.all(np.diff(ttcs) < 1e-4), ttcs
    assert ttcs[2] - ttcs[3] > 0.4, ttcs


def test_a_yielder_keeps_more_margin_from_an_aggressive_partner(gs, ms):
    """The risk a partner poses grows with its kappa (ModelSettings.k_lat_partner, Eq. 7's
    exp(kappa) field amplitude): player 1 (kappa 0.5, 14 m from the point) yields to player 0
    (12 m, faster). At k_lat_partner = 0 its margin is its own trade-off whoever comes (1.06 s
    against kappa 0.2 and 0.8 alike); at the default 3.5 it slows more for an aggressive player 0
    (mean speed 3.22 against 4.23 m/s) and keeps 1.11 s instead of 1.07 s. A partner at kappa 0.5
    weighs 1, and so does a cautious one (the weight's floor): the same equilibria either way.
    Every player has the comfort weight of kappa 0.5 here (w_accel_kappa 0), so only the partner's
    weight differs between the three partners."""
    assert ms.k_lat_partner == 3.5
    flat = dataclasses.replace(ms, k_lat_partner=0.0)
    gs = dataclasses.replace(gs, problem=dataclasses.replace(gs.problem, w_accel_kappa=0.0))

    def solve(kappa0, settings):
        problem = Problem((Player(0.0, 6.0, kappa0), Player(0.0, 5.0, 0.5)), (Interaction.cross(0, 1, 12.0, 14.0),))
        reset_workspaces()  # no OSQP warm start from the solve before: comparable bit for bit
        result = nash_equilibrium(problem, gs, settings)
        assert result.status == "converged"
        return result.plans[1].mean_speed, _min_lateral_ttc(problem, result, settings), result

    (_, m_c, r_c), (v_m, m_m, r_m), (v_a, m_a, _) = (solve(k, ms) for k in (0.2, 0.5, 0.8))
    assert v_a < v_m - 0.5, (v_m, v_a)  # [m/s] the yielder's mean speed
    assert m_a > m_m + 0.04, (m_m, m_a)  # [s] its margin
    (_, f_c, f_rc), (_, f_m, f_r), (_, f_a, _) = (solve(k, flat) for k in (0.2, 0.5, 0.8))
    assert max(f_c, f_m, f_a) - min(f_c, f_m, f_a) < 0.01, (f_c, f_m, f_a)
    assert m_a - m_c > 0.04
    assert np.array_equal(r_m.accelerations, f_r.accelerations)
    assert np.array_equal(r_c.accelerations, f_rc.accelerations)


def test_a_cautious_player_weighs_its_risk_more_and_no_player_less(gs, ms):
    """A player's own kappa scales its J_lat terms (ModelSettings.k_lat_own, Eq. 7's exp(kappa) of
    its own field), never below Eq. 19's weight: player 1 (14 m from the point) yields to player 0
    (kappa 0.5, 12 m, faster). Against k_lat_own = 0 a cautious yielder (kappa 0.2) slows more
    (2.70 against 2.96 m/s); an aggressive one (0.8) would weigh the crossing at 0.74 and is
    held at 1 by the floor, and at kappa 0.5 the weight is 1: the same equilibria bit for bit."""
    assert ms.k_lat_own == 1.0
    flat = dataclasses.replace(ms, k_lat_own=0.0)

    def solve(kappa1, settings):
        problem = Problem((Player(0.0, 6.0, 0.5), Player(0.0, 5.0, kappa1)), (Interaction.cross(0, 1, 12.0, 14.0),))
        reset_workspaces()  # no OSQP warm start from the solve before: comparable bit for bit
        result = nash_equilibrium(problem, gs, settings)
        assert result.status == "converged"
        return result.plans[1].mean_speed, _min_lateral_ttc(problem, result, settings), result

    (v_c, _, _), (_, _, r_m), (_, _, r_a) = (solve(k, ms) for k in (0.2, 0.5, 0.8))
    (f_c, _, _), (_, _, f_r), (_, _, f_a) = (solve(k, flat) for k in (0.2, 0.5, 0.8))
    assert v_c < f_c - 0.15, (v_c, f_c)  # [m/s] the cautious yielder's mean speed
    assert np.array_equal(r_m.accelerations, f_r.accelerations)
    assert np.array_equal(r_a.accelerations, f_a.accelerations)


def test_warm_start_median_iterations(pair_battery, nash_battery, gs, ms):
    """Receding horizon over 3 s (30 shifted problems per pair): median iterations <= 2."""
    iterations = []
    for problem, result in list(zip(pair_battery, nash_battery))[:8]:
        for _ in range(int(round(3.0 / gs.problem.dt))):
            problem = advance(problem, result.plans)
            result = nash_equilibrium(problem, gs, ms, warm_start=shift_plans(result))
            assert result.status == "converged"
            iterations.append(result.iterations)
    assert np.median(iterations) <= 2


def test_warm_start_reproduces_converged_plans(pair_battery, nash_battery, gs, ms):
    """Warm-starting the same problem from its own equilibrium converges at once and stays there,
    for every pair of the battery (before the iteration restored a collapsed trust region before
    stopping, 4 of the 60 moved by 0.6-1.5 m/s^2: their cold stop was not an equilibrium)."""
    for problem, result in zip(pair_battery, nash_battery):
        again = nash_equilibrium(problem, gs, ms, warm_start=result)
        assert again.iterations <= 2
        assert again.accelerations == pytest.approx(result.accelerations, abs=gs.solver.nash_cost_guard)


def test_jacobi_converges_to_same_equilibrium(pair_battery, nash_battery, gs, ms):
    """Jacobi iteration reaches the equilibrium Gauss-Seidel reaches wherever both are verified
    (no player gains 1 % by deviating). A strongly coupled pair can have several local
    equilibria: in battery problem 3 one of the two schemes may stop where a player could still
    gain 11-12 % by passing first, depending on the solves before it (warm OSQP workspaces)."""
    jacobi = GameSettings(solver=SolverSettings(scheme="jacobi", nash_max_iter=60))
    same = 0
    for problem, result in list(zip(pair_battery, nash_battery))[:10]:
        other = nash_equilibrium(problem, jacobi, ms)
        assert other.status == "converged"
        verified = [max(d.relative_gain for d in check_nash(problem, r, gs, ms, starts=3).deviations) < 0.01
                    for r in (result, other)]
        if all(verified):  # a verified point is one within 1 % of each best response; two of
            # them on a flat ridge of the coupled costs differ by a few % (2.3 % in problem 1)
            assert other.costs == pytest.approx(result.costs, rel=0.05, abs=1e-3)
            same += 1
    assert same >= 8


def test_stackelberg_warm_sequence(pair_battery, gs, ms):
    problem = pair_battery[0]
    result = stackelberg_equilibrium(problem, gs, ms)
    for _ in range(10):
        problem = advance(problem, result.plans)
        result = stackelberg_equilibrium(problem, gs, ms, warm_start=shift_plans(result))
        assert result.status == "converged"
        assert result.iterations <= 3


def test_leader_is_smaller_tcp(ms):
    # player 0: 30 m at 5 m/s (6 s); player 1: 20 m at 5 m/s (4 s) -> player 1 leads
    problem = Problem((Player(0.0, 5.0, 0.5), Player(0.0, 5.0, 0.5)), (Interaction.cross(0, 1, 30.0, 20.0),))
    assert stackelberg_leader(problem, ms) == 1
    following = Problem((Player(0.0, 5.0, 0.5), Player(20.0, 5.0, 0.5)), (Interaction.following(0, 1),))
    assert stackelberg_leader(following, ms) == 1
    result = stackelberg_equilibrium(problem, leader=0)
    assert result.leader == 0


def test_stackelberg_needs_two_players():
    with pytest.raises(ValueError):
        stackelberg_equilibrium(Problem((Player(0.0, 5.0, 0.5),)))
