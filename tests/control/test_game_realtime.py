"""A game in progress runs at most ``PolicySettings.game_max_iter`` equilibrium iterations a
control step and goes on from its last iterate at the next one (a real-time iteration); a pair's
first solve is not capped (control/game/pair_games.py)."""

from __future__ import annotations

import time

import numpy as np

from intersection_cosim.control.base import ControlContext
from intersection_cosim.control.game.controller import GameController
from intersection_cosim.control.game.settings import GameControllerSettings, PolicySettings
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.movements import paper_movements
from tests.control.conftest import make_world, record_solves

LEFT = "west_inner_left_inner"  # eastbound, turning left to the north
STRAIGHT = "north_middle_straight_middle"  # southbound, straight on: the left turn crosses it


def _run(paths, net_file, equilibrium: str, cap: int, steps: int = 8, slower: float = 0.3):
    """The (iterations, status, first accelerations) of every game solve over ``steps`` control
    steps in which S is ``slower`` [m/s] than its plan (so the pair's game moves every step)."""
    c = GameController(equilibrium)
    settings = GameControllerSettings(policy=PolicySettings(game_resolve_steps=1, game_max_iter=cap))
    c.setup(ControlContext(movements=paper_movements(net_file), model=ModelSettings(), control_period=0.1,
                           settings=settings, etm=True))
    solves = record_solves(c, lambda r: (r.iterations, r.status, [float(p.accelerations[0]) for p in r.plans]))
    t = c.table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    world = make_world(paths, 0.0, [("L", LEFT, t.s_a[p, q] - 22.0, 8.0), ("S", STRAIGHT, t.s_a[q, p] - 24.0, 8.0)])
    for n in range(steps):
        c.decide(world, time.perf_counter() + 10.0)
        ps = [c.memory.plans[v] for v in ("L", "S")]
        world = make_world(paths, 0.1 * (n + 1), [("L", LEFT, float(ps[0].positions[1]), float(ps[0].speeds[1])),
                                                  ("S", STRAIGHT, float(ps[1].positions[1]),
                                                   float(ps[1].speeds[1]) - slower)])
    return solves


def test_a_game_in_progress_runs_at_most_game_max_iter_iterations_a_step(paths, net_file):
    full = _run(paths, net_file, "nash", 0)
    capped = _run(paths, net_file, "nash", 1)
    assert len(full) == len(capped) == 8  # solved every step (game_resolve_steps 1)
    assert min(it for it, _, _ in full[1:]) >= 2  # S off its plan: the equilibrium moves each step
    assert capped[0][:2] == full[0][:2] and capped[0][0] >= 2  # the pair's first solve runs in full
    assert all(it == 1 and status == "iteration cap" for it, status, _ in capped[1:])
    # the real-time iteration tracks the moving equilibrium: the applied accelerations [m/s^2]
    gaps = [max(abs(x - y) for x, y in zip(a, b)) for (_, _, a), (_, _, b) in zip(full, capped)]
    assert max(gaps) < 0.3 and gaps[-1] < 0.1


def test_a_cap_of_zero_leaves_the_games_alone_and_a_negative_cap_is_refused(paths, net_file):
    assert PolicySettings().check() == [] and PolicySettings(game_max_iter=0).check() == []
    assert [f for f, _ in PolicySettings(game_max_iter=-1).check()] == ["game_max_iter"]
