"""A wait at a crossing always ends: when crossing_order makes the vehicle ranked first stay out
because the other can no longer, the other drives on even where its own plan waits (box_clear).

The state is the one of a lock found on demand_unbalanced_high (nash, seed 1, 20 ms budget): at
the north-west corner a right turn from the north merges into the lane the eastern straight-on
movement leaves by; its zone of the merge starts 0.7 m before its stop line. The right-turner
stood 4 cm past (stop line - margin), front inside that zone, the straight-on AV stood in the box
at the zone's edge, and their game (played every step) gave the straight-on AV +2.5 m/s^2 and the
turner 0: the filter held the straight-on AV for the turner, which never moved. 22 vehicles did
not arrive.
"""

import time

import numpy as np
import pytest

from intersection_cosim.control.base import ControlContext, Decisions
from intersection_cosim.control.game.controller import GameController
from intersection_cosim.control.game.relations import step_relations
from intersection_cosim.control.game.settings import GameControllerSettings, PolicySettings
from intersection_cosim.control.safety.settings import SafetySettings
from intersection_cosim.games.problem import Plan
from intersection_cosim.games.settings import ProblemSettings
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.movements import paper_movements
from tests.control.conftest import FilterUnderTest, make_world

GS, PROBLEM, MODEL = SafetySettings(), ProblemSettings(), ModelSettings()
STRAIGHT = "east_outer_straight_outer"  # westbound, leaves by west_out_0
RIGHT = "north_outer_right_outer"  # southbound turning right: merges into west_out_0
S_STRAIGHT, S_RIGHT = 157.7089, 137.5359  # [m] where the two stood in the lock


def _lock_world(paths, t=505.0, s_straight=S_STRAIGHT, s_right=S_RIGHT, v=(0.0, 0.0)):
    world = make_world(paths, t, [("E", STRAIGHT, s_straight, v[0]), ("N", RIGHT, s_right, v[1])])
    world.role = ["passing" if s_straight >= paths[STRAIGHT].s_stop else "ready",
                  "passing" if s_right >= paths[RIGHT].s_stop else "ready"]
    world.lanes = [":C_9_0" if s_straight < 158.6 else "west_out_0", "north_in_0" if s_right < 138.0 else ":C_0_0"]
    return world


def test_the_lock_state_is_a_merge_whose_zone_holds_the_turner_at_its_line(paths, movements, conflict_table):
    """The premise: the turner's front is inside its zone of the merge, before its stop line, and
    past (stop line - margin); the straight-on AV is short of its zone."""
    world = _lock_world(paths)
    rel = step_relations(world, {0, 1}, movements, conflict_table, MODEL, True, {}, PolicySettings().lane_choice_range)
    (zone_e, zone_n), = zip(rel.pairs.zone_i, rel.pairs.zone_j)
    assert zone_n[0] < S_RIGHT < paths[RIGHT].s_stop and S_RIGHT > paths[RIGHT].s_stop - GS.margin
    assert S_STRAIGHT < zone_e[0] < S_STRAIGHT + 0.1


def test_the_vehicle_the_first_one_is_held_for_drives_on(paths, movements, conflict_table):
    """crossing_order holds E (in the box, ranked first) for N (which can no longer stay out), and
    N, standing in its zone with a plan that waits, drives out at clear_accel (box_clear)."""
    world = _lock_world(paths)
    f = FilterUnderTest(GS, conflict_table.s_stop, 0.1)
    f.record_entries(world)
    rel = step_relations(world, {0, 1}, movements, conflict_table, MODEL, True, {}, PolicySettings().lane_choice_range)
    plans = {"E": Plan.from_accelerations(S_STRAIGHT, 0.0, np.full(PROBLEM.steps, 2.5), PROBLEM.dt),
             "N": Plan.from_accelerations(S_RIGHT, 0.0, np.zeros(PROBLEM.steps), PROBLEM.dt)}
    d = Decisions(accel={"E": 2.5, "N": 0.0})
    f.apply(world, rel, plans, {}, d, games=frozenset({("E", "N")}))
    assert d.accel["E"] <= 0.0 and f.result.lowered["E"] == "crossing_order"
    assert d.accel["N"] == GS.clear_accel and f.result.raised["N"] == "box_clear"


@pytest.mark.parametrize("equilibrium", ["nash", "stackelberg"])
def test_the_game_of_the_lock_state_resolves(net_file, paths, equilibrium):
    """The game controller on the lock state, every pair playing (ETM off, as the run's pair played
    every step), the vehicles moving as commanded: N passes its stop line within 2 s and E is
    through the merge zone within 8 s (in the lock both stood for 215 s)."""
    settings = GameControllerSettings()
    c = GameController(equilibrium, settings)
    c.setup(ControlContext(movements=paper_movements(net_file), model=MODEL, control_period=0.1, settings=None,
                           etm=False))
    state = {"E": [S_STRAIGHT, 0.0], "N": [S_RIGHT, 0.0]}
    passed_line, e_through = None, None
    for step in range(80):
        t = 505.0 + 0.1 * step
        world = _lock_world(paths, t, state["E"][0], state["N"][0], (state["E"][1], state["N"][1]))
        d = c.decide(world, time.perf_counter() + 10.0)
        for vid, (s, v) in state.items():
            v_next = max(0.0, v + d.accel.get(vid, 0.0) * 0.1)
            state[vid] = [s + 0.05 * (v + v_next), v_next]
        if passed_line is None and state["N"][0] > paths[RIGHT].s_stop:
            passed_line = t
        if e_through is None and state["E"][0] > 164.1:
            e_through = t
    assert passed_line is not None and passed_line - 505.0 < 2.0
    assert e_through is not None and e_through - 505.0 < 8.0
