"""The safety filter's named rules: each documented (invariant, trigger, action, setting, test),
each needed by its test (the test fails with the rule removed from RULES), and the tests of the
rules that have none elsewhere."""

import ast
import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from intersection_cosim.control.base import Decisions
from intersection_cosim.control.game.relations import step_relations
from intersection_cosim.control.game.settings import PolicySettings
from intersection_cosim.control.safety.rules import LIVENESS, RULES, SAFETY, rule_table
from intersection_cosim.control.safety.settings import SafetySettings
from intersection_cosim.games.problem import Plan
from intersection_cosim.games.settings import ProblemSettings
from intersection_cosim.models.settings import ModelSettings
from tests.conftest import DROP_RULE
from tests.control.conftest import FilterUnderTest, make_world

ROOT = Path(__file__).resolve().parents[3]
GS, PROBLEM, MODEL = SafetySettings(), ProblemSettings(), ModelSettings()
LEFT = "west_inner_left_inner"  # eastbound, turning left to the north
STRAIGHT = "north_middle_straight_middle"  # southbound, straight on: the left turn crosses it


def test_every_rule_states_its_invariant_trigger_action_setting_and_test():
    """The docs' table: one row per rule, no field empty, names unique, both kinds present, and
    each test it names exists."""
    rows = rule_table()
    assert [r["name"] for r in rows] == [rule.name for rule in RULES]
    assert len({r["name"] for r in rows}) == len(rows) == 10
    assert {r["kind"] for r in rows} == {SAFETY, LIVENESS}
    for row in rows:
        assert all(row[key] for key in ("invariant", "trigger", "action", "setting", "test")), row["name"]
        file, _, name = row["test"].partition("::")
        tree = ast.parse((ROOT / file).read_text())
        assert name in {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}, row["test"]


DROPPING = """
import json, os, sys
import pytest
out = {}
for rule, node in json.loads(sys.argv[1]):
    os.environ[%r] = rule
    out[rule] = int(pytest.main(["-q", "-x", "-p", "no:cacheprovider", node]))
print("EXIT CODES", json.dumps(out))
""" % DROP_RULE


@pytest.mark.slow
def test_each_rule_is_needed_by_its_test():
    """Each rule's own test, run without that rule (tests/conftest.py drops it from RULES), fails
    (pytest's exit code 1); with every rule it passes in the suite itself. One process runs them
    all, one pytest session per rule."""
    import json

    nodes = [(r["name"], r["test"]) for r in rule_table()]
    run = subprocess.run([sys.executable, "-c", DROPPING, json.dumps(nodes)], cwd=ROOT, capture_output=True,
                         text=True, timeout=1200)
    codes = json.loads(run.stdout.rpartition("EXIT CODES ")[2])
    assert codes == {name: 1 for name, _ in nodes}, run.stdout[-3000:]


def _relations(world, movements, table):
    return step_relations(world, set(range(len(world))), movements, table, MODEL, True, {},
                          PolicySettings().lane_choice_range)


def test_no_entry_towards_a_full_exit_lane(paths, movements, conflict_table):
    """exit_room: E, 8 m before its stop line at 5 m/s, turns onto an exit lane whose last vehicle
    stands 3 m from its start (less than a body and a gap): it is held to stop ``margin`` before its
    line (-5^2 / (2 x 7 m)); with room on the lane (30 m free) it keeps its plan."""
    path = paths[LEFT]
    s = path.s_stop - 8.0  # [m]
    out = {}
    for free in (3.0, 30.0):
        world = make_world(paths, 0.0, [("E", LEFT, s, 5.0)])
        world = dataclasses.replace(world, exit_free={path.lanes[-1]: (free, 0.0)})
        plans = {"E": Plan.from_accelerations(s, 5.0, np.full(PROBLEM.steps, 1.0), PROBLEM.dt)}
        d = Decisions(accel={"E": 1.0})
        f = FilterUnderTest(GS, conflict_table.s_stop, 0.1)
        f.apply(world, _relations(world, movements, conflict_table), plans, {}, d)
        out[free] = d.accel["E"]
    assert out[3.0] == pytest.approx(-5.0 ** 2 / (2 * (8.0 - GS.margin)))
    assert out[30.0] == 1.0


def test_a_stalled_box_holds_an_entrant(paths, movements, conflict_table):
    """stalled_box: B stands in the junction 3 m before its zone with A's left turn; A, 8 m before its
    stop line at 5 m/s, plans to cross before B could move (the plans alone keep the crossing
    clear). A waits at its stop line (-5^2 / (2 x 7 m)) and B, waited for, drives out at
    ``clear_accel``."""
    t = conflict_table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    s_a, s_b = float(t.s_stop[p]) - 8.0, float(t.zone_in[q, p]) - 3.0  # [m]
    f = FilterUnderTest(GS, t.s_stop, 0.1)
    world = make_world(paths, 1.0, [("A", LEFT, s_a, 5.0), ("B", STRAIGHT, s_b, 0.0)])
    world.role, world.a = ["ready", "passing"], np.array([1.0, 0.0])
    f.record_entries(world)
    plans = {"A": Plan.from_accelerations(s_a, 5.0, np.full(PROBLEM.steps, 1.0), PROBLEM.dt),
             "B": Plan.from_accelerations(s_b, 0.0, np.zeros(PROBLEM.steps), PROBLEM.dt)}
    d = Decisions(accel={"A": 1.0, "B": 0.0})
    held = f.apply(world, _relations(world, movements, t), plans, {}, d)
    assert d.accel["A"] == pytest.approx(-5.0 ** 2 / (2 * (8.0 - GS.margin)), rel=1e-9) and "A" in held
    assert d.accel["B"] == GS.clear_accel
    assert f.result.lowered["A"] == "stalled_box" and f.result.raised["B"] == "stalled_box"


def test_the_docs_rules_table_is_what_the_rules_say():
    """docs/safety-rules.md is generated from the rules' docstrings and up to date."""
    run = subprocess.run([sys.executable, str(ROOT / "scripts" / "rules_table.py"), "--check"], cwd=ROOT,
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stdout


def test_no_drive_into_a_standing_body(paths, movements, conflict_table):
    """standing_obstacle: A, in the junction 2 m past its stop line at 3 m/s on its left turn, has
    entered first; human H stands inside their crossing, its body across A's path. Whatever the
    crossing rules rank, A stops short of H's body: its front stays ``margin`` and more short of
    the first point where its swept body would touch H's (at most its braking), and a
    standing vehicle off its path leaves it alone."""
    from intersection_cosim.models.bodies import bodies_overlap, body_corners

    t = conflict_table
    p, q = t.index[LEFT], t.index[STRAIGHT]
    s_a = float(t.s_stop[p]) + 2.0  # [m]
    out = {}
    for s_h in (float(t.zone_in[q, p]) + 3.0, 5.0):  # inside the crossing; far back on its approach
        world = make_world(paths, 1.0, [("A", LEFT, s_a, 3.0), ("H", STRAIGHT, s_h, 0.0)])
        world.heading = np.array([float(paths[LEFT].heading_at(s_a)), float(paths[STRAIGHT].heading_at(s_h))])
        world.role, world.human = ["passing", "ready"], np.array([False, True])
        world.lanes = [paths[LEFT].lane_at(s_a)[0], paths[STRAIGHT].lane_at(s_h)[0]]
        f = FilterUnderTest(GS, t.s_stop, 0.1)
        f.record_entries(world)
        plans = {"A": Plan.from_accelerations(s_a, 3.0, np.full(PROBLEM.steps, 1.0), PROBLEM.dt)}
        d = Decisions(accel={"A": 1.0})
        f.apply(world, _relations(world, movements, t), plans, {}, d)
        out[s_h > 5.0] = d.accel["A"], f.result.lowered.get("A"), world

    def body(path, s, length=MODEL.vehicle_length):  # [m] a body with its front at s on path
        xy, h = paths[path].point_at(np.array([s])), paths[path].heading_at(np.array([s]))
        return body_corners(xy[:, 0], xy[:, 1], h, np.array([length]), np.array([MODEL.vehicle_width]))

    assert out[False][:2] == (1.0, None)
    a, rule, world = out[True]
    assert rule == "standing_obstacle" and PROBLEM.a_min <= a < 0.0
    stop = s_a + 3.0 ** 2 / (2.0 * -a)  # [m] where A's front stops
    h = body(STRAIGHT, float(world.s[1]))
    assert not bodies_overlap(body(LEFT, stop + GS.margin), h)[0]  # a margin short of H's body
    assert bodies_overlap(body(LEFT, stop + GS.margin + 2.0), h)[0]  # and not far short of it
