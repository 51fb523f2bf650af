"""Coupled cluster games in the controller's step (control/game/cluster_games.py)."""

import time

import pytest

from intersection_cosim.control import registry
from intersection_cosim.control.base import ControlContext
from intersection_cosim.control.game.cluster_games import ClusterRow, split_clusters
from intersection_cosim.control.game.controller import GameController
from intersection_cosim.control.game.pair_games import PairGame
from intersection_cosim.control.game.settings import GameControllerSettings, PolicySettings
from intersection_cosim.experiments.run_tables import games_table
from intersection_cosim.games.settings import ProblemSettings
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.movements import paper_movements
from tests.control.conftest import make_world

# Case 1 A's three left turns near their stop lines: V1 crosses V2 and V3; (path, metres past the
# stop line, speed [m/s])
CASE1A = [("V1", "south_inner_left_inner", -2.0, 6.8), ("V2", "east_inner_left_inner", 0.5, 3.5),
          ("V3", "west_inner_left_inner", -5.0, 5.7)]


def _world(paths):
    return make_world(paths, 0.65, [(v, p, paths[p].s_stop + ds, speed) for v, p, ds, speed in CASE1A])


def _controller(net_file, kind: str) -> GameController:
    settings = GameControllerSettings(policy=PolicySettings(cluster_check=True))
    c = registry.create(kind, settings, "priority")
    c.setup(ControlContext(movements=paper_movements(net_file), model=ModelSettings(), control_period=0.1,
                           settings=settings, etm=True))
    return c


def test_split_clusters_keeps_small_components_pairwise():
    games = {(0, 1): PairGame(0, 1), (1, 2): PairGame(1, 2), (3, 4): PairGame(3, 4)}
    clusters, rest = split_clusters(games)
    assert clusters == [(0, 1, 2)] and list(rest) == [(3, 4)]


def test_coupling_is_validated():
    assert ("coupling", "must be one of pairwise, cluster") in ProblemSettings(coupling="all").check()
    assert ProblemSettings().coupling == "pairwise"


@pytest.mark.parametrize("kind", ["nash-coupled", "stackelberg-coupled"])
def test_three_crossing_vehicles_play_one_cluster_game(net_file, paths, kind):
    c = _controller(net_file, kind)
    assert c.settings.game.coupling == "cluster"
    d = c.decide(_world(paths), time.perf_counter() + 10.0)
    assert d.games == 1 and sorted(d.pairs) == [("V1", "V2"), ("V1", "V3")]
    (row,) = c.diagnostics().clusters
    assert isinstance(row, ClusterRow) and sorted(row.members) == ["V1", "V2", "V3"]
    assert row.status == "converged" and row.check == "pass"
    assert set(d.accel) == {"V1", "V2", "V3"}
    # the pairwise controller plays the same step as two pair games
    pair = GameController(kind.split("-")[0])
    pair.setup(ControlContext(movements=paper_movements(net_file), model=ModelSettings(), control_period=0.1,
                              settings=None, etm=True))
    assert pair.decide(_world(paths), time.perf_counter() + 10.0).games == 2
    assert pair.diagnostics().clusters is None


def test_games_table_marks_the_pairs_of_a_cluster():
    rows = [(0.5, "V1", "V2", "C", True), (0.5, "V1", "V3", "C", True), (0.6, "V4", "V5", "C", True)]
    row = ClusterRow(0.5, ("V1", "V3", "V2"), 4, 0.004, "converged", "pass", 1e-6, 2e-6)
    table = games_table(rows, (row,))
    assert list(table["cluster"]) == ["V1+V3+V2", "V1+V3+V2", ""]
    assert list(table["size"].iloc[:2]) == [3, 3] and list(table["check"].iloc[:2]) == ["pass", "pass"]
    assert list(games_table(rows, None).columns) == ["time", "vehicle_a", "vehicle_b", "junction", "solved"]
