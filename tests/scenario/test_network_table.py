"""The [network] table and demand by edge ids on real SUMO nets (SUMO's cross and RiLSA examples)."""

import os
import textwrap
from pathlib import Path

import numpy as np
import pytest
import sumo

from intersection_cosim.scenario import load_scenario, scenario_from_dict
from intersection_cosim.scenario.draws import generate_flow_vehicles
from intersection_cosim.scenario.model import NetworkSettings
from intersection_cosim.settings import to_dict

SUMO_HOME = Path(sumo.SUMO_HOME)
CROSS = SUMO_HOME / "tools/game/cross/cross.net.xml"
RILSA = SUMO_HOME / "tools/sumolib/scenario/scenarios/RealWorld/RiLSA_example1/net.net.xml"
SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"

CROSS_SCENARIO = """
[scenario]
name = "cross"
duration = 30.0

[network]
file = "$SUMO_HOME/tools/game/cross/cross.net.xml"
junctions = ["0"]
control_range = 80.0

[[flow]]
from = "1fi"
to = "2o"
rate = 600
kappa = {dist = "uniform", low = 0.2, high = 0.8}

[[flow]]
id = "south"
route = ["3si", "4o"]
rate = 300
kappa = 0.5
lane = 1
speed = 8.0
pos = 10.0

[[vehicle]]
id = "A"
edge = "1si"
lane = 2
pos = 100.0
to = "3o"
speed = 5.0
kappa = 0.4

[[vehicle]]
id = "B"
position = [300.0, 214.1]
route = ["2si", "4o"]
speed = 5.0
kappa = 0.6
depart = 1.5
desired_speed = 8.0
"""


def _write(folder: Path, text: str, name: str = "scenario.toml") -> Path:
    path = folder / name
    path.write_text(textwrap.dedent(text))
    return path


def test_cross_net_every_form(tmp_path):
    scn = load_scenario(_write(tmp_path, CROSS_SCENARIO))
    assert scn.network == NetworkSettings(file=str(CROSS.resolve()), junctions=("0",), signals="off",
                                          control_range=80.0, routes=())
    by_edges, by_route = scn.flows
    assert by_edges.route == ("1fi", "1si", "2o")  # SUMO's router through junction m1 and 0
    assert (by_edges.id, by_edges.rate, by_edges.depart_lane, by_edges.depart_speed, by_edges.depart_pos) == (
        "1fi_2o_0", 600.0, "best", "max", None)
    assert by_route.route == ("3si", "4o")
    assert (by_route.id, by_route.depart_lane, by_route.depart_speed, by_route.depart_pos) == ("south", "1", "8", 10.0)
    assert (by_route.approach, by_route.movement) == ("", "")
    a, b = scn.vehicles
    assert a.route == ("1si", "3o") and (a.lane, a.depart_lane, a.depart_pos, a.s0) == ("1si_2", 2, 100.0, 100.0)
    # 1si_2 runs from (48.37, 189.19) to (183.76, 198.68), 135.75 m long: 100 m along it
    assert (a.x, a.y) == pytest.approx((48.37 + 100 / 135.75 * 135.39, 189.19 + 100 / 135.75 * 9.49), abs=0.05)
    assert b.route == ("2si", "4o") and (b.lane, b.depart_lane) == ("2si_0", 0)
    assert b.depart_pos == pytest.approx(42.74, abs=0.01)  # (300, 214.1) projected onto 2si_0
    assert (b.x, b.y) == pytest.approx((300.0, 214.07), abs=0.01)
    assert (b.speed, b.kappa, b.depart, b.desired_speed) == (5.0, 0.6, 1.5, 8.0)


def test_rilsa_net_signals_on_and_routes(tmp_path):
    scn = load_scenario(_write(tmp_path, f"""
        [network]
        file = "{RILSA}"
        junctions = ["0"]
        signals = "on"
        [[flow]]
        from = "wm"
        to = "me"
        rate = 360
        kappa = 0.5
        [[flow]]
        from = "sm"
        to = "mw"
        rate = 360
        kappa = 0.5
        lane = "free"
        distance = 91.9
        """))
    assert scn.network.signals == "on" and scn.network.junctions == ("0",)
    assert [f.route for f in scn.flows] == [("wm", "me"), ("sm", "mw")]
    assert scn.flows[1].depart_lane == "free"
    assert scn.flows[1].depart_pos == pytest.approx(491.9 - 91.9, abs=0.05)  # distance before the junction


def test_sumo_home_from_the_package_when_unset_and_from_the_environment_when_set(tmp_path, monkeypatch):
    scenario = _write(tmp_path, CROSS_SCENARIO)
    monkeypatch.delenv("SUMO_HOME", raising=False)
    assert load_scenario(scenario).network.file == str(CROSS.resolve())
    fake_home = tmp_path / "home"
    (fake_home / "tools/game/cross").mkdir(parents=True)
    (fake_home / "tools/game/cross/cross.net.xml").write_bytes(CROSS.read_bytes())
    monkeypatch.setenv("SUMO_HOME", str(fake_home))
    assert load_scenario(scenario).network.file == str((fake_home / "tools/game/cross/cross.net.xml").resolve())


def test_other_variables_and_relative_paths(tmp_path, monkeypatch):
    nets = tmp_path / "nets"
    nets.mkdir()
    (nets / "cross.net.xml").write_bytes(CROSS.read_bytes())
    (nets / "bg.rou.xml").write_text('<routes><trip id="bg" depart="0" from="4fi" to="3fo"/></routes>')
    sub = tmp_path / "scenarios"
    sub.mkdir()
    text = CROSS_SCENARIO.replace('"$SUMO_HOME/tools/game/cross/cross.net.xml"', '"../nets/cross.net.xml"')
    text = text.replace('control_range = 80.0', 'control_range = 80.0\nroutes = "${MY_NETS}/bg.rou.xml"')
    monkeypatch.setenv("MY_NETS", str(nets))
    monkeypatch.chdir(tmp_path)  # relative to the scenario file, not to the working folder
    scn = load_scenario(_write(sub, text))
    assert scn.network.file == str((nets / "cross.net.xml").resolve())
    assert scn.network.routes == (str((nets / "bg.rou.xml").resolve()),)
    assert to_dict(scn.network)["file"] == str((nets / "cross.net.xml").resolve())


def test_a_route_file_alone_is_demand_enough(tmp_path):
    (tmp_path / "bg.rou.xml").write_text('<routes><vType id="car"/>'
                                         '<flow id="bg" type="car" begin="0" end="60" vehsPerHour="300" '
                                         'from="4fi" to="3fo"/></routes>')
    scn = load_scenario(_write(tmp_path, f"""
        [network]
        file = "{CROSS}"
        junctions = ["0", "m1"]
        routes = "bg.rou.xml"
        """))
    assert (scn.vehicles, scn.flows, scn.network.junctions) == ((), (), ("0", "m1"))


def test_generic_flow_draws(tmp_path):
    scn = load_scenario(_write(tmp_path, CROSS_SCENARIO))
    fv = generate_flow_vehicles(scn, np.random.default_rng(1))
    assert [(d["id"], d["depart"]) for d in fv] == [
        ("1fi_2o_0.0", 6.44), ("1fi_2o_0.1", 6.88), ("1fi_2o_0.2", 9.08), ("south.0", 9.44), ("south.1", 10.98),
        ("1fi_2o_0.3", 19.88), ("south.2", 22.06), ("1fi_2o_0.4", 23.18), ("south.3", 27.6), ("1fi_2o_0.5", 27.77),
        ("1fi_2o_0.6", 29.15)]  # 600 veh/h and 300 veh/h over the 30 s duration
    first = fv[0]
    assert (first["flow"], first["route"], first["depart_lane"], first["speed"], first["depart_pos"]) == (
        "1fi_2o_0", ("1fi", "1si", "2o"), "best", "max", None)
    assert first["kappa"] == pytest.approx(0.7703, abs=1e-4)
    south = [d for d in fv if d["flow"] == "south"]
    assert [(d["depart_lane"], d["speed"], d["depart_pos"], d["kappa"]) for d in south] == [("1", "8", 10.0, 0.5)] * 4


def test_paper_flows_draw_as_before():
    """The paper flows' Poisson draws: the numbers the generator gave before generic flows existed
    (same ids, lanes and departs as commit b558f6e)."""
    scn = load_scenario(SCENARIOS / "demand_balanced_high.toml")
    fv = generate_flow_vehicles(scn, np.random.default_rng(scn.scenario.seed))
    assert len(fv) == 297 and all(d["route"] is None for d in fv)
    assert [(d["id"], d["lane"], d["depart"]) for d in fv[:3]] == [
        ("west_left_9.0", "inner", 0.97), ("east_straight_4.0", "outer", 4.04), ("south_straight_7.0", "outer", 12.61)]
    scn = load_scenario(SCENARIOS / "demand_unbalanced_high.toml")
    fv = generate_flow_vehicles(scn, np.random.default_rng(scn.scenario.seed))
    assert len(fv) == 273
    assert sum(d["depart"] for d in fv) == pytest.approx(83109.46, abs=1e-6)  # [s]
    assert sum(d["kappa"] for d in fv) == pytest.approx(134.271762, abs=1e-6)
    assert [sum(d["lane"] == ln for d in fv) for ln in ("inner", "middle", "outer")] == [109, 52, 112]


def test_paper_net_flows_by_edge_names_are_paper_flows():
    base = {"scenario": {"duration": 5.0}}
    by_edges = scenario_from_dict({**base, "flow": [{"from": "south_in", "to": "west_out", "rate": 100, "kappa": 0.5},
                                                    {"route": ["east_in", "west_out"], "rate": 100, "kappa": 0.5}]})
    by_name = scenario_from_dict({**base, "flow": [{"approach": "south", "movement": "left", "rate": 100, "kappa": 0.5},
                                                   {"approach": "east", "movement": "straight", "rate": 100,
                                                    "kappa": 0.5}]})
    assert by_edges.flows == by_name.flows
    assert [f.id for f in by_edges.flows] == ["south_left_0", "east_straight_1"]
    assert by_edges.network == NetworkSettings() and by_edges.network.generated


def test_network_table_without_file_is_the_generated_net():
    scn = scenario_from_dict({"network": {"junctions": ["C"], "signals": "off", "control_range": 100.0},
                              "flow": [{"approach": "south", "movement": "left", "rate": 100, "kappa": 0.5}]})
    assert scn.network == NetworkSettings() and scn.network.file is None and scn.network.junctions == ("C",)


PAPER_NET_SCENARIOS = sorted(p for p in SCENARIOS.glob("*.toml") if p.stem.startswith(("case", "demand_")))
NET_FILE_SCENARIOS = sorted(p for p in SCENARIOS.glob("*.toml") if p not in PAPER_NET_SCENARIOS)


@pytest.mark.parametrize("path", PAPER_NET_SCENARIOS, ids=lambda p: p.stem)
def test_the_paper_and_demand_scenarios_run_on_the_generated_net(path):
    scn = load_scenario(path)
    assert scn.network == NetworkSettings()
    assert all(v.route is None for v in scn.vehicles) and all(f.route is None for f in scn.flows)


@pytest.mark.parametrize("path", NET_FILE_SCENARIOS, ids=lambda p: p.stem)
def test_the_net_file_scenarios_route_every_flow_through_their_junction(path):
    """Each shipped net-file scenario names an existing net and junctions, and SUMO's router found
    a route for every flow that passes a managed junction (its edges enter and leave it)."""
    import sumolib

    scn = load_scenario(path)
    assert scn.network.file is not None and Path(scn.network.file).is_file()
    net = sumolib.net.readNet(scn.network.file)
    nodes = [net.getNode(j) for j in scn.network.junctions]
    assert len(scn.flows) >= 6
    for f in scn.flows:
        assert f.route and any({e.getID() for e in n.getIncoming()} & set(f.route)
                               and {e.getID() for e in n.getOutgoing()} & set(f.route) for n in nodes), f.id


def test_sumo_home_is_the_package_home_unless_the_variable_names_a_sumo_installation(monkeypatch, tmp_path):
    from intersection_cosim.scenario.network import sumo_home

    monkeypatch.delenv("SUMO_HOME", raising=False)
    assert sumo_home() == str(sumo.SUMO_HOME)
    (tmp_path / "sumo" / "tools").mkdir(parents=True)
    monkeypatch.setenv("SUMO_HOME", str(tmp_path / "sumo"))
    assert sumo_home() == str(tmp_path / "sumo")
    # importing libsumo sets SUMO_HOME to its data-only folder (no tools/, no nets): not a home
    (tmp_path / "sumo_data" / "data").mkdir(parents=True)
    monkeypatch.setenv("SUMO_HOME", str(tmp_path / "sumo_data"))
    assert sumo_home() == str(sumo.SUMO_HOME)
    assert os.path.isfile(os.path.join(str(sumo.SUMO_HOME), "bin", "sumo"))


def test_junctions_all_is_every_manageable_junction_and_a_wrong_word_is_an_error(tmp_path):
    from intersection_cosim.errors import InputError
    from intersection_cosim.network.junction_net import junction_table

    scn = load_scenario(Path(__file__).resolve().parents[2] / "scenarios" / "grid_low.toml")
    listed = junction_table(scn.network.file)
    assert scn.network.junctions == tuple(listed.loc[listed["manageable"], "id"])
    assert scn.network.junctions == ("A0", "A1", "A2", "B0", "B1", "B2", "C0", "C1", "C2")
    bad = tmp_path / "bad.toml"
    bad.write_text((Path(__file__).resolve().parents[2] / "scenarios" / "grid_low.toml").read_text()
                   .replace('junctions = "all"', 'junctions = "every"')
                   .replace("../sumo_networks", str(Path(__file__).resolve().parents[2] / "sumo_networks")))
    with pytest.raises(InputError) as err:
        load_scenario(bad)
    assert "network.junctions" in str(err.value) and "every" in str(err.value)


def test_desired_speed_is_road_by_default_and_a_wrong_word_or_a_generated_net_is_named(tmp_path):
    from intersection_cosim.errors import InputError

    path = tmp_path / "cross.toml"
    path.write_text(CROSS_SCENARIO)
    assert load_scenario(path).network.desired_speed == "road"
    path.write_text(CROSS_SCENARIO.replace("control_range = 80.0", 'control_range = 80.0\ndesired_speed = "v_max"'))
    assert load_scenario(path).network.desired_speed == "v_max"
    path.write_text(CROSS_SCENARIO.replace("control_range = 80.0", 'control_range = 80.0\ndesired_speed = "fast"'))
    with pytest.raises(InputError) as err:
        load_scenario(path)
    assert "network.desired_speed" in str(err.value) and "fast" in str(err.value)
    with pytest.raises(InputError) as err:  # the generated net has no route-file vehicles
        scenario_from_dict({"network": {"desired_speed": "v_max"},
                            "flow": [{"approach": "south", "movement": "left", "rate": 100, "kappa": 0.5}]})
    assert "network.desired_speed" in str(err.value) and "needs network.file" in str(err.value)
