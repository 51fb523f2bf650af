"""Issue 7 groundwork: the sumo-* baselines, the fcfs reservation controller, the demand scenarios.

The closed-loop tests run real SUMO through libsumo; the reservation logic is also tested as a
pure unit (no simulation).
"""

from __future__ import annotations

import dataclasses
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from intersection_cosim.control import registry
from intersection_cosim.network.movements import paper_movements
from intersection_cosim.control.base import ControlContext, World
from intersection_cosim.control.baselines.fcfs import FcfsController
from intersection_cosim.control.baselines.reservations import FcfsSettings, free_slot, time_to_cover
from intersection_cosim.errors import InputError
from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.scenario import load_scenario, scenario_from_dict
from intersection_cosim.scenario.load import with_overrides
from intersection_cosim.settings import from_table

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
BASELINES = {"sumo-priority": "priority", "sumo-allway-stop": "allway_stop", "sumo-tls": "traffic_light"}


def _run(scn, out: Path):
    """Run ``scn`` into ``out``; returns (summary, the controller instance the run used)."""
    made = []
    original = registry.create
    registry.create = lambda *args: made.append(original(*args)) or made[-1]
    try:
        summary = run_scenario(scn, out)
    finally:
        registry.create = original
    return summary, made[0]


def _centre_type(net: Path) -> str:
    m = re.search(r'<junction id="C" type="([a-z_]+)"', net.read_text())
    assert m, "no centre junction in the net"
    return m.group(1)


def _min_separation(history: dict) -> float:
    """[s] least gap between two vehicles' granted slots at any shared point (inf if none)."""
    by_point: dict[int, list[tuple[float, float, str]]] = {}
    for vid, slots in history.items():
        for key, (enter, leave) in slots.items():
            by_point.setdefault(key, []).append((enter, leave, vid))
    worst = np.inf
    for ivs in by_point.values():
        ivs.sort()
        for a, b in zip(ivs, ivs[1:]):
            worst = min(worst, b[0] - a[1])
    return worst


# ------------------------------------------------------------------ registry
def test_registry_has_the_baselines_and_fcfs():
    names = registry.names()
    for name in (*BASELINES, "fcfs"):
        assert name in names
    scn = load_scenario(SCENARIOS / "case1_A.toml")
    for name, jtype in BASELINES.items():
        ctrl = registry.get(name).factory(scn.controller_settings, scn.scenario.junction_type)
        assert ctrl.junction_type == jtype and not ctrl.controls_vehicles
    assert registry.get("fcfs").settings is FcfsSettings and registry.get("fcfs").table == "solver"


def test_fcfs_settings_from_the_solver_table():
    data = tomllib.loads((SCENARIOS / "case1_A.toml").read_text())
    data["controller"] = {"kind": "fcfs", "solver": {"buffer": 1.0, "comfort_accel": 1.5}}
    scn = scenario_from_dict(data)
    assert scn.controller_settings == FcfsSettings(buffer=1.0, comfort_accel=1.5)
    with pytest.raises(InputError):
        from_table(FcfsSettings, {"buffer": -0.1}, "<t>", "controller.solver")
    with pytest.raises(InputError):
        from_table(FcfsSettings, {"slot_step": 0}, "<t>", "controller.solver")


# ------------------------------------------------------------------ pure reservation logic
def test_time_to_cover():
    assert time_to_cover(0.0, 5.0, 2.0, 10.0) == 0.0
    assert time_to_cover(-3.0, 5.0, 2.0, 10.0) == 0.0
    assert time_to_cover(20.0, 10.0, 2.0, 10.0) == pytest.approx(2.0)  # at v_max
    assert time_to_cover(4.0, 0.0, 2.0, 10.0) == pytest.approx(2.0)  # d = a t^2 / 2
    # 25 m to reach v_max from 0, then 10 m at 10 m/s
    assert time_to_cover(35.0, 0.0, 2.0, 10.0) == pytest.approx(5.0 + 1.0)


def test_free_slot_skips_candidates_that_collide():
    # one point (key 7) busy over [0.5, 2.0]; candidates shifted by 0.5 s each, 1 s long
    starts = np.arange(0.0, 5.0, 0.5)
    enter, leave = starts[:, None], starts[:, None] + 1.0
    busy_in, busy_out, busy_pt = np.array([0.5]), np.array([2.0]), np.array([7])
    assert free_slot(enter, leave, busy_in, busy_out, np.array([7]), busy_pt, 0.0) == 4  # starts at 2.0
    assert free_slot(enter, leave, busy_in, busy_out, np.array([7]), busy_pt, 0.5) == 5  # 2.0 + 0.5
    assert free_slot(enter, leave, busy_in, busy_out, np.array([3]), busy_pt, 0.5) == 0  # other point
    # every candidate blocked
    assert free_slot(enter, leave, np.array([-1.0]), np.array([99.0]), np.array([7]), busy_pt, 0.0) == -1


def _world(paths, t, vehicles):
    """A World of vehicles (id, path id, distance to the stop line [m], speed [m/s])."""
    ids = [v[0] for v in vehicles]
    s = np.array([paths[p].s_stop - d for _, p, d, _ in vehicles])
    v = np.array([sp for *_, sp in vehicles], float)
    z = np.zeros(len(ids))
    return World(time=t, ids=ids, path_ids=[v_[1] for v_ in vehicles], s=s, v=v, a=z, x=z, y=z,
                 heading=z, kappa=z + 0.5, role=["ready"] * len(ids),
                 lanes=[paths[p].approach_lane for _, p, _, _ in vehicles],
                 exit_choices={vid: (paths[p].exit_lane,) for vid, p, _, _ in vehicles})


def test_fcfs_grants_do_not_overlap_and_the_later_vehicle_waits(net_file, paths):
    ctrl = FcfsController()
    ctrl.setup(ControlContext(movements=paper_movements(net_file), model=ModelSettings(),
                              control_period=0.1, settings=None, etm=True))
    # northbound and eastbound straight through at 10 m/s, placed so that both would reach their
    # crossing point at about the same time (B 0.5 m further: A comes first); C follows A
    a, b = "south_middle_straight_middle", "west_middle_straight_middle"
    p, q = ctrl.table.index[a], ctrl.table.index[b]
    to_cp_a = ctrl.table.s_a[p, q] - paths[a].s_stop  # [m] stop line to the point
    to_cp_b = ctrl.table.s_b[p, q] - paths[b].s_stop
    d_b = 20.0 + to_cp_a - to_cp_b + 0.5
    world = _world(paths, 0.0, [("A", a, 20.0, 10.0), ("B", b, d_b, 10.0), ("C", a, 30.0, 10.0)])
    decisions = ctrl.decide(world, deadline=float("inf"))
    ga, gb, gc = ctrl.grants["A"], ctrl.grants["B"], ctrl.grants["C"]
    # first come (earliest arrival at the stop line, both at 10 m/s = v_max): the nearer one
    first, second = ("A", "B") if 20.0 < d_b else ("B", "A")
    assert ctrl.grants[first].earliest and not ctrl.grants[second].earliest
    assert ctrl.grants[first].t_arrive == pytest.approx(min(20.0, d_b) / 10.0)
    assert decisions.accel[first] == pytest.approx(0.0)  # at v_max already
    assert decisions.accel[second] < 0.0  # slows down for its later slot
    shared = set(ga.slots) & set(gb.slots)
    assert shared
    for key in shared:
        (ea, la), (eb, lb) = ga.slots[key], gb.slots[key]
        assert eb >= la + ctrl.fs.buffer - 1e-9 or ea >= lb + ctrl.fs.buffer - 1e-9
    # C behind A on the same lane: after A at the stop line (and it never overtakes A's slot)
    line = set(ga.slots) & set(gc.slots)
    assert line and all(gc.slots[k][0] >= ga.slots[k][1] + ctrl.fs.buffer - 1e-9 for k in line)
    assert decisions.release == []


def test_fcfs_releases_vehicles_that_left(net_file, paths):
    ctrl = FcfsController()
    ctrl.setup(ControlContext(movements=paper_movements(net_file), model=ModelSettings(),
                              control_period=0.1, settings=None, etm=True))
    pid = "south_middle_straight_middle"
    ctrl.decide(_world(paths, 0.0, [("A", pid, 5.0, 8.0)]), float("inf"))
    world = _world(paths, 5.0, [("A", pid, -40.0, 10.0)])
    world.role = ["outside"]
    decisions = ctrl.decide(world, float("inf"))
    assert decisions.release == ["A"] and decisions.accel == {}


# ------------------------------------------------------------------ closed loop (real SUMO)
@pytest.mark.parametrize("name", sorted(BASELINES))
def test_baseline_runs_case1a_on_its_junction_type(name, tmp_path):
    scn = with_overrides(load_scenario(SCENARIOS / "case1_A.toml"), controller=name)
    summary, _ = _run(scn, tmp_path / "run")
    assert summary["counts"]["collisions"] == 0
    assert summary["counts"]["arrived"] == 3
    assert summary["counts"]["safety_interventions"] is None  # Diagnostics(): no safety filter
    assert not (tmp_path / "run" / "convergence.csv").exists()  # and no games
    assert _centre_type(tmp_path / "run" / "intersection.net.xml") == BASELINES[name]


@pytest.mark.parametrize("case, n", [("case1_A", 3), ("case2_A", 5)])
def test_fcfs_runs_the_paper_cases(case, n, tmp_path):
    scn = with_overrides(load_scenario(SCENARIOS / f"{case}.toml"), controller="fcfs")
    summary, ctrl = _run(scn, tmp_path / "run")
    assert summary["counts"]["collisions"] == 0
    assert summary["counts"]["arrived"] == n == summary["counts"]["vehicles"]
    assert summary["counts"]["fallbacks"] == 0
    assert summary["counts"]["safety_interventions"] >= 0  # the safety filter runs under fcfs (rule 6)
    assert summary["counts"]["box_rule_clearances"] == 0  # no AV stood in a crossing
    assert not (tmp_path / "run" / "convergence.csv").exists()
    assert _centre_type(tmp_path / "run" / "intersection.net.xml") == "priority"
    assert set(ctrl.history) == {v.id for v in scn.vehicles}
    assert _min_separation(ctrl.history) >= ctrl.fs.buffer - 1e-6


def _short(name: str, duration: float, kind: str):
    data = tomllib.loads((SCENARIOS / name).read_text())
    data["scenario"]["duration"] = duration
    for flow in data["flow"]:
        flow["end"] = min(flow["end"], duration)
    data["controller"]["kind"] = kind
    return scenario_from_dict(data, name)


@pytest.mark.slow
def test_fcfs_demand_balanced_low(tmp_path):
    scn = _short("demand_balanced_low.toml", 120.0, "fcfs")
    summary, ctrl = _run(scn, tmp_path / "run")
    counts = summary["counts"]
    assert counts["vehicles"] > 10
    assert counts["collisions"] == 0
    assert counts["departed"] == counts["arrived"] == counts["vehicles"]  # none left in the network
    assert counts["fallbacks"] == 0
    assert _min_separation(ctrl.history) >= ctrl.fs.buffer - 1e-6


@pytest.mark.slow
def test_fcfs_mixed_high_demand_has_no_collision_and_drains(tmp_path):
    """High demand (1800 veh/h) for 60 s and 60 s to drain, av_share 0.5, seed 2: fcfs without the
    safety filter under its commands (rule 6) and with standing humans reserving their points
    let an AV into a human in the box (1 collision by SUMO's count and by our overlap check); now
    none, and every vehicle arrives."""
    scn = _short("demand_balanced_high.toml", 60.0, "fcfs")
    scn = dataclasses.replace(scn, flows=tuple(dataclasses.replace(f, av_share=0.5) for f in scn.flows),
                              scenario=dataclasses.replace(scn.scenario, drain=60.0))
    summary, ctrl = _run(with_overrides(scn, seed=2), tmp_path / "run")
    counts = summary["counts"]
    assert counts["vehicles"] > 25
    assert counts["collisions"] == 0 and summary["collisions"]["overlap_pairs"] == 0
    assert counts["departed"] == counts["arrived"] == counts["vehicles"]
    assert counts["safety_interventions"] > 0  # the filter did act


# ------------------------------------------------------------------ demand scenarios
@pytest.mark.parametrize("kind", ["balanced", "unbalanced"])
@pytest.mark.parametrize("level, total", [("low", 600), ("medium", 1200), ("high", 1800)])
def test_demand_scenarios_parse(kind, level, total):
    scn = load_scenario(SCENARIOS / f"demand_{kind}_{level}.toml")
    assert scn.scenario.duration == 600.0
    assert scn.controller.kind == "nash"
    assert not scn.vehicles
    assert sum(f.rate for f in scn.flows) == pytest.approx(total, rel=0.02)
    assert {(f.approach, f.movement) for f in scn.flows} == {
        (a, m) for a in ("north", "east", "south", "west") for m in ("left", "straight", "right")}
    ns = sum(f.rate for f in scn.flows if f.approach in ("north", "south")) / total
    assert ns == pytest.approx(0.5 if kind == "balanced" else 0.6, abs=0.01)


def test_fcfs_yields_to_a_human_and_never_commands_it(net_file, paths):
    """Mixed traffic: A and B would meet at their crossing point, A a little earlier at its stop
    line. Both AVs: first come (A) is served first and B waits. B a human: B is not commanded and
    its predicted occupancy is reserved first, so A waits."""
    a, b = "west_middle_straight_middle", "south_middle_straight_middle"
    results = {}
    for human in (False, True):
        ctrl = FcfsController()
        ctrl.setup(ControlContext(movements=paper_movements(net_file), model=ModelSettings(),
                                  control_period=0.1, settings=None, etm=True))
        p, q = ctrl.table.index[a], ctrl.table.index[b]
        d_b = 20.0 + (ctrl.table.s_a[p, q] - paths[a].s_stop) - (ctrl.table.s_b[p, q] - paths[b].s_stop) + 0.3
        assert d_b > 20.0  # B reaches its stop line later than A, the crossing point at about A's time
        world = _world(paths, 0.0, [("A", a, 20.0, 10.0), ("B", b, d_b, 10.0)])
        world.human = np.array([False, human])
        results[human] = (ctrl.decide(world, deadline=float("inf")), dict(ctrl.grants))
    (av_decisions, av_grants), (h_decisions, h_grants) = results[False], results[True]
    assert av_grants["A"].earliest and not av_grants["B"].earliest and "B" in av_decisions.accel
    assert "B" not in h_decisions.accel and "B" not in h_grants
    assert not h_grants["A"].earliest and h_decisions.accel["A"] < 0.0


def test_fcfs_reserves_nothing_for_a_human_standing_at_its_stop_line(net_file, paths):
    """Mixed traffic, seed 1 of demand_mixed_medium stood still for good: SUMO held a human at its
    stop line for AVs while fcfs held the AVs for the human's reservation from its earliest start.
    A human standing short of its line reserves nothing (A keeps its earliest arrival); the same
    human moving reserves its points (A waits)."""
    a, b = "west_middle_straight_middle", "south_middle_straight_middle"
    grants = {}
    for case, v_b in {"standing human": 0.0, "moving human": 3.0}.items():
        ctrl = FcfsController()
        ctrl.setup(ControlContext(movements=paper_movements(net_file), model=ModelSettings(),
                                  control_period=0.1, settings=None, etm=True))
        world = _world(paths, 0.0, [("A", a, 15.0, 10.0), ("B", b, 0.3, v_b)])
        world.human = np.array([False, True])
        decisions = ctrl.decide(world, deadline=float("inf"))
        grants[case] = (dict(ctrl.grants), decisions.accel)
    grant_a, accel = grants["standing human"]
    assert grant_a["A"].earliest and grant_a["A"].t_arrive == pytest.approx(1.5)
    assert accel["A"] == pytest.approx(0.0) and "B" not in accel  # at v_max, not braked by the filter
    assert not grants["moving human"][0]["A"].earliest and grants["moving human"][1]["A"] < 0.0
