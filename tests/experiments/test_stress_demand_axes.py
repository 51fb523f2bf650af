"""The stress axes that add demand the scenario does not name: U-turns (``uturn_share``) where the
net has U-turn connections at a managed junction, and people over the managed junctions'
crossings (``pedestrian_rate``) where it has crossings; neither on a net without them."""

from __future__ import annotations

import os
import tomllib
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from intersection_cosim.experiments.stress.draws import base_data, space, variant
from intersection_cosim.experiments.stress.people import routes_text, with_people
from intersection_cosim.experiments.stress.toml_text import dumps
from intersection_cosim.network.junction_net import uturn_exits
from intersection_cosim.network.kerb_walks import kerb_walks
from intersection_cosim.scenario import load_scenario, scenario_from_dict
from intersection_cosim.scenario.network import sumo_home
from intersection_cosim.scenario.stress_settings import StressSettings, stress_settings

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
FOKR = SCENARIOS / "fokr38_pedestrians_medium.toml"  # junction 38: U-turns on all four arms, 8 crossings
FOKR_NET = os.path.join(sumo_home(), "tools", "game", "fokr_bs_demo", "fokr_bs.net.xml.gz")


@pytest.fixture(scope="module")
def fokr():
    data = tomllib.loads(FOKR.read_text())
    scn = load_scenario(FOKR)
    return data, scn, base_data(data, scn, FOKR)


def test_the_network_layer_finds_uturns_and_kerb_to_kerb_walks_of_junction_38():
    assert uturn_exits(FOKR_NET, ("38",)) == {"-1.23": "1", "-2.10": "2", "-3.22": "3", "-5.5": "5"}
    walks = kerb_walks(FOKR_NET, ("38",))
    assert len(walks) == 4  # eight crossings over four median islands
    assert sorted(c for w in walks for c in w.crossings) == [f":38_c{k}" for k in range(8)]
    assert all(len(w.crossings) == 2 and w.start != w.end for w in walks)
    tjunction = str(SCENARIOS.parent / "sumo_networks" / "t_junction" / "intersection.net.xml")
    assert kerb_walks(tjunction, ("C",)) == () and uturn_exits(tjunction, ("C",)) == {}


def test_both_axes_are_drawn_only_where_the_net_allows_them(fokr):
    _data, scn, _base = fokr
    names = [p.name for p in space(scn, StressSettings())]
    assert "uturn_share" in names and "pedestrian_rate" in names
    off = stress_settings("s.toml", {"uturn_share": False, "pedestrian_rate": False})
    assert not {"uturn_share", "pedestrian_rate"} & {p.name for p in space(scn, off)}
    plain = [p.name for p in space(load_scenario(SCENARIOS / "tjunction_high.toml"), StressSettings())]
    assert "uturn_share" not in plain and "pedestrian_rate" not in plain
    balanced = [p.name for p in space(load_scenario(SCENARIOS / "demand_balanced_medium.toml"), StressSettings())]
    assert "uturn_share" not in balanced  # the generated net has no U-turns


def test_a_controller_that_does_not_see_people_gets_no_pedestrian_axis(fokr):
    data, _scn, _base = fokr
    fcfs = scenario_from_dict({**data, "controller": {"kind": "fcfs"}}, str(FOKR))
    assert "pedestrian_rate" not in [p.name for p in space(fcfs, StressSettings())]


def test_uturn_share_moves_that_share_of_each_flow_to_a_uturn_copy(fokr):
    _data, scn, base = fokr
    data = variant(base, scn, {"uturn_share": 0.25}, seed=3, duration=60.0, settings=StressSettings())
    flows = {t["id"]: t for t in data["flow"]}
    assert len(flows) == 16
    first = scn.flows[0]  # -5.5 -> 1 at 90 veh/h
    assert flows[first.id]["rate"] == pytest.approx(90 * 0.75)
    turn = flows[f"{first.id}_uturn"]
    assert turn["rate"] == pytest.approx(90 * 0.25) and turn["route"] == ["-5.5", "5"]
    assert "from" not in turn and "to" not in turn and turn["kappa"] == flows[first.id]["kappa"]
    again = scenario_from_dict(tomllib.loads(dumps(data)), str(FOKR))
    assert {f.id: f.route for f in again.flows}[f"{first.id}_uturn"] == ("-5.5", "5")


def test_pedestrian_rate_writes_people_over_every_crossing_and_keeps_the_scenarios_own(fokr, tmp_path):
    _data, scn, base = fokr
    assert routes_text(scn, 0.0, 60.0) is None
    root = ET.fromstring(routes_text(scn, 300.0, 60.0))
    drawn = [el for el in root if el.get("id", "").startswith("stress_ped")]
    assert len(drawn) == 8 and {el.get("perHour") for el in drawn} == {"150"}
    assert {el.get("end") for el in drawn} == {"60"}
    assert {el.get("id") for el in root if el.tag == "personFlow"} >= {"pa", "pb", "pc"}
    path = tmp_path / "people" / "run-00000.rou.xml"
    data = with_people(variant(base, scn, {"pedestrian_rate": 300.0}, seed=3, duration=60.0,
                               settings=StressSettings()), scn, {"pedestrian_rate": 300.0}, 60.0, path)
    assert data["network"]["routes"] == str(path.resolve()) and path.is_file()
    again = scenario_from_dict(tomllib.loads(dumps(data)), str(tmp_path / "failure.toml"))
    assert again.network.routes == (str(path.resolve()),)
