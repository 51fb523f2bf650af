"""control.game.solo.cheapest: a solo vehicle's exit lane from its options' solves."""

import numpy as np
import pytest

from intersection_cosim.control.game.solo import cheapest
from intersection_cosim.games.lane_choice import lane_choice_game
from intersection_cosim.games.nash import solo_response
from intersection_cosim.games.problem import GameResult, Player, Problem
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.models.settings import ModelSettings


@pytest.mark.parametrize("j_lk_far", [0.0, 0.05, 0.5, 5.0])
def test_the_cheapest_exit_lane_is_the_lane_choice_games_pick(j_lk_far):
    """For one player, cheapest() picks what lane_choice_game picks from the same solves: the
    least cost with the option's J_lk (which grows with ``j_lk_far`` for the far lanes)."""
    gs, ms = GameSettings(), ModelSettings()
    n, dt = gs.problem.steps, gs.problem.dt
    v_l = np.full(n, 4.0)  # [m/s]
    options = {  # the same vehicle (s0 -40 m, 8 m/s): behind a slow leader, free, or behind a far one
        "near": Problem((Player(-40.0, 8.0, 0.5, leader=(-28.0 + np.cumsum(v_l) * dt, v_l)),)),
        "middle": Problem((Player(-40.0, 8.0, 0.5),)),
        "far": Problem((Player(-40.0, 8.0, 0.5, leader=(-5.0 + np.cumsum(v_l) * dt, v_l)),)),
    }
    lane_costs = {"near": 0.0, "middle": 0.5 * j_lk_far, "far": j_lk_far}  # [-] J_lk
    lc = lane_choice_game({(o,): p for o, p in options.items()}, [lane_costs], solver=solo_response,
                          settings=gs, model_settings=ms)
    assert cheapest(lc.results) == lc.choice
    if j_lk_far == 0.0:
        assert lc.choice == ("middle",)  # no leader and no lane cost: the cheapest
    if j_lk_far == 5.0:
        assert lc.choice == ("near",)


def test_a_failed_option_is_never_cheapest_unless_all_failed():
    ok = GameResult((), np.array([3.0]), (), np.zeros((0, 1)), 1, 1, "converged", "nash", 0.0)
    failed = GameResult((), np.array([np.nan]), (), np.zeros((0, 1)), 0, 0, "solver failure", "nash", 0.0)
    assert cheapest({("a",): failed, ("b",): ok}) == ("b",)
    assert cheapest({("a",): failed, ("b",): failed}) == ("a",)
