"""The game controllers in the closed loop with real SUMO: the paper's 24 runs and the scheduler."""

import json
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from intersection_cosim.control.game.controller import GameController
from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.results.metrics import body_overlaps
from intersection_cosim.scenario import load_scenario, with_overrides

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
CASES = ["case1_A", "case1_B", "case1_C", "case1_D", "case2_A", "case2_B"]
STACKELBERG_TOLERANCE = 0.2  # [s] Stackelberg's min TTC may fall this far below Nash's
# The paper runs test decisions, not this machine's load: with a budget that binds, a step's
# result depends on wall time by design (the HIL emulation), which the scheduler tests cover.
GENEROUS_BUDGET_MS = 2000.0


def _run(tmp: Path, case: str, controller: str, etm: bool = True, **overrides) -> Path:
    out = tmp / f"{case}-{controller}-{'etm' if etm else 'noetm'}"
    scn = with_overrides(load_scenario(SCENARIOS / f"{case}.toml"), controller=controller,
                         etm=None if etm else False, **overrides)
    run_scenario(scn, out)
    return out


@pytest.fixture(scope="module")
def paper_runs(tmp_path_factory):
    """All 24 paper runs: six scenarios x Nash / Stackelberg x trigger on / off."""
    tmp = tmp_path_factory.mktemp("paper")
    return {(case, c, etm): _run(tmp, case, c, etm, budget_ms=GENEROUS_BUDGET_MS) for case in CASES
            for c in ("nash", "stackelberg") for etm in (True, False)}


def _vehicles(run: Path) -> pd.DataFrame:
    return pd.read_csv(run / "vehicles.csv").set_index("vehicle")


def _pairs(run: Path) -> pd.Series:
    p = pd.read_csv(run / "pairs.csv")
    return pd.Series(p["min_ttc"].to_numpy(), index=p["vehicle_a"] + "-" + p["vehicle_b"])


@pytest.mark.slow
def test_all_24_runs_arrive_without_collision(paper_runs):
    assert len(paper_runs) == 24
    for key, run in paper_runs.items():
        vehicles = _vehicles(run)
        assert vehicles["arrival"].notna().all(), key
        assert not vehicles["collided"].any(), key
        assert pd.read_csv(run / "steps.csv")["fallback"].sum() == 0, key


@pytest.mark.slow
def test_game_diagnostics_reach_summary_and_convergence_csv(paper_runs):
    """GameController.diagnostics(): one convergence.csv row per iteration of every game, and the
    safety filter's counts as integers in summary.json."""
    for key, run in paper_runs.items():
        counts = json.loads((run / "summary.json").read_text())["counts"]
        assert isinstance(counts["safety_interventions"], int) and counts["safety_interventions"] >= 0, key
        assert isinstance(counts["box_rule_clearances"], int) and counts["box_rule_clearances"] >= 0, key
        conv = pd.read_csv(run / "convergence.csv")
        steps = pd.read_csv(run / "steps.csv")
        assert steps["games"].sum() > 0 and len(conv) > 0 and (conv["iteration"] >= 1).all(), key
        assert set(conv["solver"]) <= {"nash", "stackelberg", key[1]}, key


@pytest.mark.slow
def test_games_are_played_and_the_trigger_plays_fewer(paper_runs):
    """The trigger plays fewer games for the same pairs. Only those count: with the trigger
    Case 2 A's V3 takes the middle exit (its lane choice is made alone, k_lat = 0, before its
    pair with V1 triggers), which makes pairs (V1-V3, V3-V5) that the run without it never has."""
    for case in ("case1_A", "case2_A"):
        for c in ("nash", "stackelberg"):
            on, off = (pd.read_csv(paper_runs[(case, c, etm)] / "pairs.csv") for etm in (True, False))
            on, off = (p.set_index(p["vehicle_a"] + "-" + p["vehicle_b"])["game_steps"] for p in (on, off))
            common = on.index.intersection(off.index)
            assert 0 < on[common].sum() < off[common].sum(), (case, c, on.to_dict(), off.to_dict())
            games = pd.read_csv(paper_runs[(case, c, True)] / "steps.csv")["games"].sum()
            assert games == on.sum()  # steps.csv and pairs.csv count the same games
    pairs = pd.read_csv(paper_runs[("case1_A", "nash", False)] / "pairs.csv")
    assert (pairs["game_steps"] > 0).all()
    # and the work falls: QPs solved per control step (load-free, unlike the wall time). At the
    # defaults the filter's events and the trigger's hold keep Case 1 A's guarded pair in its game
    # from the filter's first check to the crossing, as without the trigger: measured 1.00 of the
    # no-trigger figure for Nash, 0.88 for Stackelberg; Case 2 A 0.57 and 0.55
    for case, c, share in (("case1_A", "nash", 1.02), ("case1_A", "stackelberg", 0.95),
                           ("case2_A", "nash", 0.7), ("case2_A", "stackelberg", 0.7)):
        assert 0 < _qps_per_step(paper_runs[(case, c, True)]) < share * _qps_per_step(paper_runs[(case, c, False)])


def _qps_per_step(run: Path) -> float:
    return float(pd.read_csv(run / "steps.csv")["qp_solves"].mean())


@pytest.mark.slow
def test_the_trigger_alone_cuts_case1_a_work(paper_runs, tmp_path):
    """The trigger alone (no filter events, no hold: Gamma_cp > Gamma_sf starts every game, Eq. 39)
    in Case 1 A, the paper's comparison: QPs per step 0.85 of the no-trigger figure for Nash,
    0.61 for Stackelberg (measured 5 December 2026; 0.84 for Nash with OSQP answering every QP
    with an active row, qp_box_iter = 0)."""
    case = tmp_path / "case1_A.toml"
    case.write_text((SCENARIOS / "case1_A.toml").read_text()
                    + "\n[controller.policy]\nfilter_event = false\ntrigger_hold_gap = 0.0\n")
    for c, share in (("nash", 0.9), ("stackelberg", 0.7)):
        scn = with_overrides(load_scenario(case), controller=c, budget_ms=GENEROUS_BUDGET_MS)
        run_scenario(scn, tmp_path / c)
        assert 0 < _qps_per_step(tmp_path / c) < share * _qps_per_step(paper_runs[("case1_A", c, False)])


@pytest.mark.slow
def test_case1_aggressive_v1_is_faster_cautious_v2_v3_are_slower(paper_runs):
    for c in ("nash", "stackelberg"):
        a, b, cc = (_vehicles(paper_runs[(f"case1_{s}", c, True)]) for s in "ABC")
        assert cc.loc["V1", "travel_time"] < a.loc["V1", "travel_time"], c  # kappa_V1 0.8 vs 0.5
        for vid in ("V2", "V3"):  # kappa 0.2 in B vs 0.5 in A
            assert b.loc[vid, "travel_time"] > a.loc[vid, "travel_time"], (c, vid)


@pytest.mark.slow
def test_case1_cautious_v2_v3_keep_larger_margins_and_aggressive_v1_v2_the_smallest(paper_runs):
    """Table II's orderings by our min TTC: the cautious V2 and V3 of B (kappa 0.2) keep larger
    margins to V1 than the moderate ones of A (0.5), and the V1-V2 pair is closest in D, where
    both are aggressive (0.8, 0.9)."""
    for c in ("nash", "stackelberg"):
        ttc = {s: _pairs(paper_runs[(f"case1_{s}", c, True)]) for s in "ABCD"}
        for pair in ("V1-V2", "V1-V3"):
            assert ttc["B"][pair] > ttc["A"][pair] + 0.05, (c, pair, ttc["B"][pair], ttc["A"][pair])
        others = [ttc[s]["V1-V2"] for s in "ABC"]
        assert ttc["D"]["V1-V2"] < min(others), (c, ttc["D"]["V1-V2"], others)


@pytest.mark.slow
def test_no_vehicle_stands_in_the_junction(paper_runs):
    """With the trigger or without, nobody stands (below 0.5 m/s) inside the junction for more
    than 1 s: these cases have no queue, so a stop inside is a standoff between the filter and
    a game (Case 1 A without the trigger once stood for 5 s)."""
    for key, run in paper_runs.items():
        traj = pd.read_csv(run / "trajectories.csv")
        dt = float(traj["time"].drop_duplicates().diff().median())  # [s] sampling period
        standing = traj[(traj["role"] == "passing") & (traj["speed"] < 0.5)].groupby("vehicle").size() * dt
        assert (standing <= 1.0).all(), (key, standing.to_dict())


@pytest.mark.slow
def test_stackelberg_min_ttc_not_below_nash(paper_runs):
    for case in CASES:
        nash = _pairs(paper_runs[(case, "nash", True)])
        stack = _pairs(paper_runs[(case, "stackelberg", True)])
        for pair in nash.index.intersection(stack.index):
            if np.isfinite(nash[pair]) and np.isfinite(stack[pair]):
                assert stack[pair] >= nash[pair] - STACKELBERG_TOLERANCE, (case, pair)


@pytest.mark.slow
def test_case2_a_aggressive_v3_takes_the_middle_exit_and_v1_yields(paper_runs):
    for c in ("nash", "stackelberg"):
        a, b = _vehicles(paper_runs[("case2_A", c, True)]), _vehicles(paper_runs[("case2_B", c, True)])
        assert a.loc["V3", "exit_lane"] == "middle", c
        # past the end of the shared stretch V3 leaves slow V4 behind: seconds faster than in B
        assert a.loc["V3", "travel_time"] < b.loc["V3", "travel_time"] - 2.0, c
        assert "V1-V3" in _pairs(paper_runs[("case2_A", c, True)]).index  # they now merge
        # V1 yields: V3 is the first of the two out of the junction onto the shared exit lane
        traj = pd.read_csv(paper_runs[("case2_A", c, True)] / "trajectories.csv")
        out = traj[traj["x"] > 12.0].groupby("vehicle")["time"].min()  # [s] past the east edge
        assert out["V3"] < out["V1"] - 0.5, (c, out["V3"], out["V1"])


@pytest.mark.slow
def test_case2_b_v3_follows_v4_on_the_inner_lane_without_v1_conflict(paper_runs):
    for c in ("nash", "stackelberg"):
        run = paper_runs[("case2_B", c, True)]
        assert _vehicles(run).loc["V3", "exit_lane"] == "inner"
        pairs = _pairs(run)
        assert "V1-V3" not in pairs.index
        assert "V3-V4" in pairs.index


@pytest.mark.slow
def test_realised_speed_is_the_commanded_speed(paper_runs):
    traj = pd.read_csv(paper_runs[("case2_A", "nash", True)] / "trajectories.csv")
    checked = 0
    for _, g in traj.groupby("vehicle"):
        g = g.sort_values("time")
        cmd = g["accel_cmd"].to_numpy()[:-1]
        v0, v1 = g["speed"].to_numpy()[:-1], g["speed"].to_numpy()[1:]
        dt = np.diff(g["time"].to_numpy())
        # a vehicle that reached its exit lane during the period is SUMO's from that step on
        still_owned = g["role"].to_numpy()[1:] != "outside"
        ok = np.isfinite(cmd) & np.isclose(dt, 0.1) & still_owned
        expected = np.maximum(v0 + cmd * 0.1, 0.0)
        # speeds are written with 4 decimals
        assert np.allclose(v1[ok], expected[ok], atol=2e-4)
        checked += ok.sum()
    assert checked > 100


@pytest.mark.slow
def test_same_seed_same_trajectories(paper_runs, tmp_path):
    again = _run(tmp_path, "case1_A", "nash", budget_ms=GENEROUS_BUDGET_MS)
    first = paper_runs[("case1_A", "nash", True)]
    assert (again / "trajectories.csv").read_text() == (first / "trajectories.csv").read_text()


@pytest.mark.slow
def test_slow_solver_gets_the_fallback_and_causes_no_collision(tmp_path, monkeypatch):
    decide = GameController.decide

    def slow(self, world, deadline):
        if 1.0 <= world.time < 2.0:  # one simulated second of overruns
            time.sleep(0.15)
        return decide(self, world, deadline)

    monkeypatch.setattr(GameController, "decide", slow)
    # a budget that an ordinary step meets even on a loaded machine; the sleep overruns it
    run = _run(tmp_path, "case1_A", "nash", budget_ms=100.0)
    steps = pd.read_csv(run / "steps.csv")
    slow_steps = steps[(steps["time"] >= 1.0) & (steps["time"] < 2.0)]
    assert slow_steps["deadline_missed"].all() and slow_steps["fallback"].all()
    assert not steps.loc[steps["time"] >= 2.05, "fallback"].any()
    vehicles = _vehicles(run)
    assert vehicles["arrival"].notna().all() and not vehicles["collided"].any()


@pytest.mark.slow
def test_no_two_bodies_ever_overlap(paper_runs):
    """An independent geometric check next to SUMO's collision count."""
    for key, run in paper_runs.items():
        traj = pd.read_csv(run / "trajectories.csv")
        assert body_overlaps(traj, 4.5, 1.8) == [], key
