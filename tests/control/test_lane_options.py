"""Exit-lane options of a step and J_lk from the net's lane geometry."""

import pytest

from intersection_cosim.control.game.lane_options import LaneChangeCosts, lane_options
from intersection_cosim.control.game.relations import step_relations
from intersection_cosim.games.lane_choice import lane_change_cost
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.spec import IntersectionSpec
from tests.control.conftest import make_world

MODEL = ModelSettings()
V3 = "north_inner_left_inner"  # a left turn that may take the inner or the middle exit lane


def test_lane_change_costs_come_from_the_exit_edge_lane_widths(movements):
    costs = LaneChangeCosts(movements, MODEL)
    width = IntersectionSpec().lane_width  # [m] what build_network wrote into the net
    assert movements.preferred(V3) == "inner" and movements.options(V3) == ("inner", "middle")
    assert costs.offset(V3, "inner") == 0.0
    assert costs.offset(V3, "middle") == pytest.approx(width)
    right = "south_outer_right_outer"
    assert costs.offset(right, "middle") == pytest.approx(width)
    assert costs.costs(V3, ("inner", "middle")) == {"inner": 0.0, "middle": lane_change_cost(width, MODEL)}


def test_a_choice_that_changes_no_partner_is_not_solved_and_one_that_does_is_held_between_decisions(
        paths, movements, conflict_table):
    s_stop = paths[V3].s_stop
    alone = make_world(paths, 0.0, [("V3", V3, s_stop - 10.0, 6.0)])
    alone.exit_choices["V3"] = ("inner", "middle")
    rel = step_relations(alone, {0}, movements, conflict_table, MODEL, True, {}, 30.0)
    lanes = lane_options(alone, rel, movements, {}, {}, 5)
    assert lanes.options == {0: ("inner",)} and lanes.choice_age == {}  # the preferred one only
    assert lane_options(alone, rel, movements, {"V3": "middle"}, {}, 5).options == {0: ("middle",)}  # held
    # V4 ahead on the inner branch makes the choice matter: follow V4 (inner) or not (middle)
    t = conflict_table
    parting = float(t.s_a[t.index[V3], t.index["north_inner_left_middle"]])  # [m] end of the shared stretch
    s_v4 = parting + MODEL.conflict_clearance + 2.0  # V4's front past it: no leader on the middle branch
    pair = make_world(paths, 0.0, [("V3", V3, s_stop - 10.0, 6.0), ("V4", V3, s_v4, 6.0)])
    pair.exit_choices["V3"] = ("inner", "middle")
    rel = step_relations(pair, {0, 1}, movements, conflict_table, MODEL, True, {}, 30.0)
    lanes = lane_options(pair, rel, movements, {}, {}, 5)
    assert lanes.options[0] == ("inner", "middle") and lanes.choice_age == {"V3": 0}
    held = lane_options(pair, rel, movements, {"V3": "middle"}, {"V3": 0}, 5)
    assert held.options[0] == ("middle",) and held.choice_age == {"V3": 1}
    due = lane_options(pair, rel, movements, {"V3": "middle"}, {"V3": 4}, 5)
    assert due.options[0] == ("inner", "middle") and due.choice_age == {"V3": 0}
