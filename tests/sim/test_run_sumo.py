"""A real SUMO run of Case 1 A with SUMO's own controller, end to end through libsumo."""

import json
from pathlib import Path

import pandas as pd
import pytest

from intersection_cosim.cli import main
from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.results.sumo_outputs import read_tripinfo
from intersection_cosim.scenario import load_scenario, with_overrides

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


def _sumo(case: str):
    """A paper scenario under SUMO's own controller (the files default to the game, nash)."""
    return with_overrides(load_scenario(SCENARIOS / f"{case}.toml"), controller="sumo")


@pytest.fixture(scope="module")
def case1a_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "case1_A"
    assert main(["run", str(SCENARIOS / "case1_A.toml"), "--controller", "sumo", "--out", str(out)]) == 0
    return out


def test_outputs_present(case1a_run):
    names = {p.name for p in case1a_run.iterdir()}
    assert {"trajectories.csv", "vehicles.csv", "pairs.csv", "steps.csv", "summary.json", "tripinfo.xml",
            "ssm.xml", "collisions.xml", "scenario.sumocfg", "scenario.rou.xml",
            "intersection.net.xml"} <= names
    assert not [n for n in case1a_run.parent.iterdir() if n.name.startswith(".")]  # no temp folder left


def test_csv_columns(case1a_run):
    cols = {name: list(pd.read_csv(case1a_run / name, nrows=0).columns) for name in
            ("trajectories.csv", "vehicles.csv", "pairs.csv", "steps.csv")}
    assert cols["trajectories.csv"][:9] == ["time", "vehicle", "x", "y", "speed", "accel", "heading", "lane", "role"]
    assert cols["vehicles.csv"] == ["vehicle", "approach", "movement", "kappa", "depart", "arrival",
                                    "travel_time", "time_loss", "exit_lane", "collided", "driver", "vtype"]
    assert cols["pairs.csv"] == ["vehicle_a", "vehicle_b", "conflict", "min_ttc", "pet", "min_ttc_ssm", "time_min_ttc_ssm",
                                 "pet_ssm", "game_steps", "driver_a", "driver_b", "vtype_a", "vtype_b"]
    assert cols["steps.csv"] == ["time", "compute_ms", "games", "iterations", "deadline_missed", "fallback",
                                     "deferred", "qp_solves", "junction", "skipped"]


def test_all_arrive_no_collision_travel_time_is_tripinfo(case1a_run):
    vehicles = pd.read_csv(case1a_run / "vehicles.csv")
    assert sorted(vehicles["vehicle"]) == ["V1", "V2", "V3"]
    assert vehicles["arrival"].notna().all()
    assert not vehicles["collided"].any()
    trip = read_tripinfo(case1a_run / "tripinfo.xml").set_index("vehicle")
    for _, row in vehicles.iterrows():
        assert row["travel_time"] == pytest.approx(trip.loc[row["vehicle"], "duration"], abs=1e-6)
        assert row["travel_time"] > 0
    summary = json.loads((case1a_run / "summary.json").read_text())
    assert summary["counts"]["arrived"] == 3 and summary["counts"]["collisions"] == 0
    assert summary["seed"] == 42 and summary["controller"] == "sumo"
    assert summary["settings"]["model"]["vehicle_length"] == 4.5
    assert summary["versions"]["sumo"].startswith("1.")


def test_trajectories_start_at_the_paper_points_and_roles_progress(case1a_run):
    traj = pd.read_csv(case1a_run / "trajectories.csv")
    first = traj.sort_values("time").groupby("vehicle").first()
    # The first record is the insertion point: the paper's start points, at the start speeds.
    assert first.loc["V1", ["x", "y"]].tolist() == pytest.approx([2.0, -25.0], abs=0.05)
    assert first.loc["V2", ["x", "y"]].tolist() == pytest.approx([18.0, 2.0], abs=0.05)
    assert first.loc["V3", ["x", "y"]].tolist() == pytest.approx([-30.0, -2.0], abs=0.05)
    assert first["speed"].tolist() == pytest.approx([5.5, 4.5, 5.0])
    for vid, g in traj.groupby("vehicle"):
        roles = g.sort_values("time")["role"].tolist()
        order = [r for i, r in enumerate(roles) if i == 0 or r != roles[i - 1]]
        assert order == ["ready", "passing", "outside"], vid
    steps = pd.read_csv(case1a_run / "steps.csv")
    assert steps["time"].diff().dropna().round(6).eq(0.1).all()  # one row per 0.1 s control step


def test_pairs_are_the_two_cross_conflicts_with_ssm(case1a_run):
    pairs = pd.read_csv(case1a_run / "pairs.csv")
    pairs = pairs.set_index(pairs["vehicle_a"] + "-" + pairs["vehicle_b"])
    # The paper's two cross conflicts: V1 crosses both; V2 and V3 are opposite left turns, which on
    # this net pass each other 4 m apart (SUMO's left-turn geometry) and do not conflict.
    assert set(pairs.index) == {"V1-V2", "V1-V3"}
    assert (pairs["conflict"] == "cross").all()
    assert (pairs["min_ttc"] >= 0).all() and pairs["min_ttc"].notna().all()
    assert (pairs["game_steps"] == 0).all()


def test_same_seed_same_trajectories(case1a_run, tmp_path):
    out = tmp_path / "again"
    run_scenario(_sumo("case1_A"), out)
    assert (out / "trajectories.csv").read_text() == (case1a_run / "trajectories.csv").read_text()


def test_crash_before_rename_leaves_nothing(tmp_path):
    def boom():
        raise RuntimeError("simulated crash")

    with pytest.raises(RuntimeError):
        run_scenario(_sumo("case1_A"), tmp_path / "run", fail_hook=boom)
    assert list(tmp_path.iterdir()) == []


def test_case2_v4_starts_inside_the_junction(tmp_path):
    out = tmp_path / "case2"
    run_scenario(_sumo("case2_A"), out)
    traj = pd.read_csv(out / "trajectories.csv")
    v4 = traj[traj["vehicle"] == "V4"].sort_values("time").iloc[0]
    assert v4["role"] == "passing" and v4["lane"].startswith(":")
    assert (v4["x"], v4["y"]) == pytest.approx((2.9, 0.3), abs=0.1)
    vehicles = pd.read_csv(out / "vehicles.csv").set_index("vehicle")
    assert vehicles["arrival"].notna().all()
    assert vehicles.loc["V5", "exit_lane"] == "middle" and vehicles.loc["V4", "exit_lane"] == "inner"
    # desired_speed = 5 m/s: SUMO drives V4 no faster (the others reach the model's 10 m/s)
    top = traj.groupby("vehicle")["speed"].max()
    assert top["V4"] <= 5.0 + 1e-6 and top.drop("V4").max() > 9.0


def test_units_csv_declares_every_column_of_every_csv(case1a_run):
    from intersection_cosim.results.units import csv_columns
    from tests.results.test_units import assert_declared

    units = pd.read_csv(case1a_run / "units.csv", keep_default_na=False)
    assert units.groupby("file", sort=False)["column"].apply(list).to_dict() == csv_columns(case1a_run)
    assert_declared(units)
