"""games.csv: the pairs that played a game at each control step (Decisions.pairs)."""

import dataclasses
from pathlib import Path

import pandas as pd
import pytest

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import load_scenario, with_overrides

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


def test_games_csv_has_one_row_per_game_of_steps_csv(tmp_path):
    out = tmp_path / "run"
    run_scenario(with_overrides(load_scenario(SCENARIOS / "case1_A.toml"), controller="nash", budget_ms=2000.0), out)
    games = pd.read_csv(out / "games.csv")
    steps = pd.read_csv(out / "steps.csv")
    assert list(games.columns) == ["time", "vehicle_a", "vehicle_b", "junction", "solved"]
    assert set(games["junction"]) == {"C"}  # the generated net's one junction
    per_step = games.groupby("time").size()
    played = steps.set_index("time")["games"]
    assert per_step.to_dict() == played[played > 0].to_dict()
    assert set(map(tuple, games[["vehicle_a", "vehicle_b"]].to_numpy())) == {("V1", "V2"), ("V1", "V3")}
    conv = pd.read_csv(out / "convergence.csv").drop_duplicates(["time", "vehicle_a", "vehicle_b"])
    assert len(conv) == games["solved"].sum()  # the games whose iterations convergence.csv records
    assert 0 < (~games["solved"]).sum() < len(games)  # steady games keep their equilibrium, not all


def test_games_csv_is_empty_for_a_controller_without_games(tmp_path):
    out = tmp_path / "run"
    run_scenario(with_overrides(load_scenario(SCENARIOS / "case1_A.toml"), controller="fcfs"), out)
    assert pd.read_csv(out / "games.csv").empty


@pytest.mark.slow
def test_case1_a_coupled_plays_one_checked_three_player_cluster(tmp_path):
    """Case 1 A under nash-coupled: the three left turns play one cluster game while they
    approach, every converged solve passes the N-player check, nobody collides."""
    out = tmp_path / "run"
    scn = with_overrides(load_scenario(SCENARIOS / "case1_A.toml"), controller="nash-coupled", budget_ms=2000.0)
    settings = scn.controller_settings
    scn = dataclasses.replace(scn, controller_settings=dataclasses.replace(
        settings, policy=dataclasses.replace(settings.policy, cluster_check=True)))
    summary = run_scenario(scn, out)
    games = pd.read_csv(out / "games.csv")
    clusters = games.dropna(subset=["cluster"]).drop_duplicates("time")
    assert len(clusters) >= 10 and set(clusters["size"]) == {3}
    assert set(clusters["cluster"].str.split("+").map(frozenset)) == {frozenset({"V1", "V2", "V3"})}
    converged = clusters[clusters["status"] == "converged"]
    assert len(converged) > 0 and (converged["check"] == "pass").all()
    assert summary["counts"]["arrived"] == 3 and summary["counts"]["collisions"] == 0
