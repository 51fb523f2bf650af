"""scripts/try_any_net.py: a net with nothing to manage gives one line and exit status 2; the walks
of ``--people`` go round a junction between its arms, and only those SUMO can route."""

from __future__ import annotations

from pathlib import Path

import pytest

from intersection_cosim.scenario.network import resolve_path

from tests.scripts.script_module import load_script


def _script():
    return load_script("try_any_net")


@pytest.mark.parametrize("net", ["rail/net.net.xml",  # every junction's connections are rail only
                                 "racing/spreewaldring.net.xml"])  # a ring: no intersection at all
def test_a_net_without_a_manageable_junction_says_so(capsys, net):
    assert _script().main([f"$SUMO_HOME/tools/game/{net}"]) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and "no manageable junction in the net" in captured.err
    assert captured.out == ""  # no JSON line of an empty result


RILSA = "$SUMO_HOME/tools/sumolib/scenario/scenarios/RiLSA1/rilsa1.net.xml"
INGOLSTADT = "$SUMO_HOME/tools/game/fkk_in/ingolstadt.net.xml.gz"


def _net(path):
    return resolve_path("--net", "net", path, Path.cwd())


def test_walks_round_a_junction_go_between_arms_from_30_m_before_it_to_30_m_past_it():
    script = _script()
    walks = script.walk_pairs(_net(RILSA), "0")  # four arms, each with a sidewalk both ways
    assert len(walks) == 12  # every road in to the road out of each of the three other arms
    own_arm = {("nm", "mn"), ("em", "me"), ("sm", "ms"), ("wm", "mw")}
    assert not own_arm & {(a, b) for a, b, _, _ in walks}  # never back along its own arm
    assert {(a, b) for a, b, _, _ in walks} >= {("nm", "ms"), ("nm", "me"), ("em", "mw")}
    assert all(dp == pytest.approx(87.0 - 30.0, abs=1.0) and ap == 30.0 for _, _, dp, ap in walks)  # [m]


def test_a_walk_sumo_cannot_route_is_dropped_before_the_run(tmp_path):
    script = _script()
    net = _net(INGOLSTADT)
    walks = script.walk_pairs(net, "335525545")
    assert ("29119849#1", "-gneE9") in {(a, b) for a, b, _, _ in walks}  # sumolib finds a way, SUMO does not
    kept = script.routable_walks(net, walks, tmp_path)
    assert ("29119849#1", "-gneE9") not in {(a, b) for a, b, _, _ in kept} and 0 < len(kept) < len(walks)
