"""[[vtype]] tables (issue 16): how a vtype, a vehicle's driver and a flow's av_share combine, and
the SUMO vTypes the run's route file gets."""

import textwrap
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from intersection_cosim.experiments.files import write_routes
from intersection_cosim.network.paths import load_paths
from intersection_cosim.scenario.draws import draw_drivers, generate_flow_vehicles
from intersection_cosim.scenario.load import load_scenario

TEXT = """
[scenario]
name = "vt"
duration = 600.0
seed = 7

[[vtype]]
id = "bus"
length = 12.0
width = 2.5
accel = 1.2
decel = 4.0
max_speed = 8.0
kappa = 0.3
color = [230, 160, 20]

[[vtype]]
id = "hvan"
length = 6.0
driver = "human"

[[vehicle]]
id = "B1"
approach = "south"
lane = "middle"
distance = 30.0
movement = "straight"
speed = 5.0
vtype = "bus"

[[vehicle]]
id = "B2"
approach = "east"
lane = "middle"
distance = 30.0
movement = "straight"
speed = 5.0
kappa = 0.9
vtype = "bus"
driver = "human"

[[flow]]
id = "buses"
approach = "north"
movement = "straight"
rate = 600
vtype = "bus"
av_share = 0.5

[[flow]]
id = "vans"
approach = "west"
movement = "straight"
rate = 300
kappa = 0.5
vtype = "hvan"
"""


@pytest.fixture
def scn(tmp_path):
    path = tmp_path / "vt.toml"
    path.write_text(textwrap.dedent(TEXT))
    return load_scenario(path)


def test_a_vtype_fills_in_kappa_and_a_vehicle_may_override_it(scn):
    b1, b2 = scn.vehicles
    assert (b1.vtype, b1.kappa, b1.driver) == ("bus", 0.3, "av")
    assert (b2.vtype, b2.kappa, b2.driver) == ("bus", 0.9, "human")
    assert scn.flows[0].kappa.value == 0.3


def test_av_share_draws_on_an_av_vtype_and_a_human_vtype_is_all_human(scn):
    fv = draw_drivers(scn, generate_flow_vehicles(scn, np.random.default_rng(scn.scenario.seed)))
    buses = [v for v in fv if v["flow"] == "buses"]
    vans = [v for v in fv if v["flow"] == "vans"]
    assert len(buses) > 60 and len(vans) > 30
    share = np.mean([v["driver"] == "av" for v in buses])
    assert 0.3 < share < 0.7
    assert all(v["driver"] == "human" and v["vtype"] == "hvan" for v in vans)


def test_the_route_file_has_each_vtype_body_and_an_av_vtype_human_variant(scn, tmp_path, net_file):
    fv = draw_drivers(scn, generate_flow_vehicles(scn, np.random.default_rng(scn.scenario.seed)))
    write_routes(tmp_path / "r.rou.xml", scn, load_paths(net_file), fv)
    root = ET.parse(tmp_path / "r.rou.xml").getroot()
    types = {el.get("id"): el.attrib for el in root.iter("vType")}
    assert set(types) == {"av", "bus", "bus.human", "hvan"}  # no vehicle of the plain human vType
    assert (types["bus"]["length"], types["bus"]["width"], types["bus"]["accel"], types["bus"]["decel"]) == \
        ("12", "2.5", "1.2", "4")
    assert types["bus"]["maxSpeed"] == "8" and types["bus"]["color"] == "230,160,20"
    assert types["bus.human"]["length"] == "12" and types["bus.human"]["carFollowModel"] == "Krauss"
    assert types["hvan"]["length"] == "6" and types["hvan"]["width"] == "1.8"  # the model's width
    of = {el.get("id"): el.get("type") for el in root.iter("vehicle")}
    assert of["B1"] == "bus" and of["B2"] == "bus.human"
    drivers = {v["id"]: v["driver"] for v in fv}
    assert all(of[vid] == ("bus" if drivers[vid] == "av" else "bus.human") for vid in of if vid.startswith("buses."))
    assert all(of[vid] == "hvan" for vid in of if vid.startswith("vans."))
