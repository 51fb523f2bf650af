"""Lane choice (Case 2's V3 in miniature) and the matrix-game rules."""

from __future__ import annotations

import numpy as np
import pytest

from intersection_cosim.games import (GameResult, Interaction, Player, Problem, lane_change_cost,
                                      lane_choice_game, nash_equilibrium, stackelberg_equilibrium)
from intersection_cosim.games.lane_choice import RULE_NO_PURE, RULE_PURE, RULE_PURE_SEVERAL

INNER, MIDDLE = ("inner", "straight", "turn"), ("middle", "straight", "turn")


def case2_v3(kappa_v3: float):
    """V3 (southbound inner lane, left turn) chooses its exit lane. V4 turns ahead of it into the
    inner exit lane (slow: 4 m/s, 5 m/s desired); V1 drives straight in the middle lane of the
    same exit road. Inner: V3 follows V4 (gap 7.5 m). Middle: V3 merges with V1 (V3 reaches the
    merge point after 15 m, V1 after 35 m) and leaves its preferred lane by 4 m (J_lk)."""
    v3 = Player(0.0, 5.5, kappa_v3, name="V3", preferred_lane="inner")
    v1 = Player(0.0, 6.0, 0.5, name="V1")
    v4 = Player(0.0, 4.0, 0.45, v_max=5.0, name="V4")
    problems = {INNER: Problem((v3, v1, v4), (Interaction.following(0, 2, offset=12.0),)),
                MIDDLE: Problem((v3, v1, v4), (Interaction.confluence(0, 1, 15.0, 35.0),))}
    lane_costs = [{"inner": 0.0, "middle": lane_change_cost(4.0)}]
    return problems, lane_costs


def test_lane_change_cost_is_eq23(ms):
    assert lane_change_cost(4.0, ms) == pytest.approx(ms.k_y_lk * 16.0)
    assert lane_change_cost(0.0, ms) == 0.0


def test_aggressive_v3_takes_middle_lane_cautious_keeps_inner(gs, ms):
    problems, lane_costs = case2_v3(0.85)
    aggressive = lane_choice_game(problems, lane_costs, settings=gs, model_settings=ms)
    assert aggressive.choice == MIDDLE
    assert aggressive.rule == RULE_PURE and aggressive.equilibria == (MIDDLE,)
    assert aggressive.result.status == "converged"
    # J_lk is charged in the middle lane: (1 - kappa) k_lk J_lk over the 3 s horizon
    no_lk = lane_choice_game(problems, None, settings=gs, model_settings=ms)
    extra = aggressive.costs[MIDDLE][0] - no_lk.costs[MIDDLE][0]
    assert extra == pytest.approx(gs.problem.horizon * 0.15 * ms.k_lk * lane_change_cost(4.0, ms), rel=0.05)
    # V3 is faster in the middle lane than stuck behind V4
    assert aggressive.results[MIDDLE].plans[0].mean_speed > aggressive.results[INNER].plans[0].mean_speed

    problems, lane_costs = case2_v3(0.2)
    cautious = lane_choice_game(problems, lane_costs, settings=gs, model_settings=ms)
    assert cautious.choice == INNER
    plans = cautious.result.plans
    gap = plans[2].positions + 12.0 - plans[0].positions - ms.vehicle_length
    assert gap.min() > 1.0  # V3 stays behind its leader V4
    assert plans[0].mean_speed < aggressive.result.plans[0].mean_speed


def test_lane_choice_with_stackelberg_solver(gs, ms):
    problems, lane_costs = case2_v3(0.85)
    pair = {c: Problem(p.players[:2], p.interactions) if c == MIDDLE else
            Problem(p.players[::2], (Interaction.following(0, 1, offset=12.0),))
            for c, p in problems.items()}
    pair = {(c[0], "x"): p for c, p in pair.items()}
    res = lane_choice_game(pair, lane_costs, solver=stackelberg_equilibrium, settings=gs, model_settings=ms)
    assert res.choice == ("middle", "x")


def _matrix_game(table):
    """Problems keyed by combination and a solver returning the table's fixed costs for each."""
    problems = {k: Problem((Player(0.0, 1.0, 0.5, name="/".join(k)), Player(0.0, 1.0, 0.5))) for k in table}

    def solver(problem, settings, model_settings, warm_start=None):
        costs = np.array(table[tuple(problem.players[0].name.split("/"))], dtype=float)
        return GameResult((), costs, (), np.zeros((0, 2)), 1, 0, "converged", "nash")

    return problems, solver


def test_matrix_game_without_pure_equilibrium_takes_least_regret():
    table = {("a", "a"): (0.0, 1.0), ("a", "b"): (1.0, 0.0), ("b", "a"): (1.0, 0.2), ("b", "b"): (0.0, 1.0)}
    problems, solver = _matrix_game(table)
    res = lane_choice_game(problems, None, solver=solver)
    assert res.equilibria == ()
    assert res.rule == RULE_NO_PURE
    # regrets: aa: player 1 gains 1 by b -> 1; ab: player 0 gains 1 -> 1; ba: 1 (p0), 0.8 (p1) -> 1;
    # bb: player 1 gains 0.8 by a -> 0.8: the least largest regret
    assert res.regret[("b", "b")] == pytest.approx(0.8)
    assert res.choice == ("b", "b")


def test_matrix_game_with_two_equilibria_takes_least_total_cost():
    table = {("a", "a"): (1.0, 1.0), ("a", "b"): (5.0, 5.0), ("b", "a"): (5.0, 5.0), ("b", "b"): (0.5, 0.7)}
    problems, solver = _matrix_game(table)
    res = lane_choice_game(problems, None, solver=solver)
    assert set(res.equilibria) == {("a", "a"), ("b", "b")}
    assert res.choice == ("b", "b") and res.rule == RULE_PURE_SEVERAL


def test_failed_combination_is_never_chosen():
    table = {("a",): (1.0,), ("b",): (0.1,)}
    problems, solver = _matrix_game(table)

    def failing(problem, settings, model_settings, warm_start=None):
        res = solver(problem, settings, model_settings)
        if problem.players[0].name == "b":
            return GameResult((), np.array([np.nan]), (), np.zeros((0, 1)), 0, 0, "solver failure", "nash")
        return res

    res = lane_choice_game(problems, None, solver=failing)
    assert res.choice == ("a",)


def test_the_driven_combination_is_solved_first_and_starts_the_others(gs, ms):
    """With ``lead`` the combination the players drive is solved first, from its own warm start,
    and every other one starts from its fresh equilibrium; the choice is the one without it."""
    problems, lane_costs = case2_v3(0.85)
    plain = lane_choice_game(problems, lane_costs, settings=gs, model_settings=ms)
    calls = []

    def solver(problem, g, m, warm_start=None, **kw):
        result = nash_equilibrium(problem, g, m, warm_start=warm_start, **kw)
        calls.append((problem.interactions, warm_start, result))
        return result

    stale = {c: r.plans for c, r in plain.results.items()}  # stand-ins for a decision-old start
    led = lane_choice_game(problems, lane_costs, solver=solver, settings=gs, model_settings=ms,
                           warm_starts=stale, lead=INNER)
    assert [c[0] for c in calls] == [problems[INNER].interactions, problems[MIDDLE].interactions]
    assert calls[0][1] is stale[INNER] and calls[1][1] is calls[0][2].plans
    assert list(led.results) == [INNER, MIDDLE]  # the given order, which breaks ties
    assert led.choice == plain.choice == MIDDLE
