"""[network] sumocfg: net, route file, additional files, begin and end read from a user's SUMO
config; the demand window [begin, begin + duration) and its refusal when nothing departs in it."""

import textwrap
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import sumo

from intersection_cosim.errors import InputError
from intersection_cosim.experiments.files import route_files, write_sumocfg
from intersection_cosim.experiments.route_window import WINDOW_FILE, file_counts, write_window
from intersection_cosim.scenario import load_scenario
from intersection_cosim.scenario.sumocfg import route_demand

CROSS = Path(sumo.SUMO_HOME) / "tools/game/cross/cross.net.xml"
ROUTES = """<routes>
    <vType id="car" length="4.3"/>
    <trip id="early" type="car" depart="50" from="1fi" to="2o"/>
    <trip id="a" type="car" depart="100" from="1fi" to="2o"/>
    <trip id="b" type="car" depart="130.5" from="3fi" to="4o"/>
    <flow id="f" type="car" begin="100" end="400" period="60" from="4fi" to="3o"/>
    <trip id="late" type="car" depart="200" from="2fi" to="1o"/>
</routes>
"""


def _config(folder: Path, routes: str = "city.rou.xml", extra: str = "") -> Path:
    (folder / "city.rou.xml").write_text(ROUTES)
    cfg = folder / "city.sumocfg"
    cfg.write_text(f"""<configuration>
  <input><net-file value="{CROSS}"/><route-files value="{routes}"/>{extra}</input>
  <time><begin value="100"/><end value="700"/></time>
</configuration>""")
    return cfg


def _scenario(folder: Path, scenario: str = "", network: str = "") -> Path:
    path = folder / "s.toml"
    path.write_text(textwrap.dedent(f"""
        [scenario]
        name = "city"
        {scenario}
        [network]
        sumocfg = "city.sumocfg"
        junctions = ["0"]
        {network}
        """))
    return path


def test_net_routes_begin_and_end_come_from_the_config(tmp_path):
    _config(tmp_path)
    scn = load_scenario(_scenario(tmp_path))
    assert scn.network.file == str(CROSS)
    assert scn.network.routes == (str(tmp_path / "city.rou.xml"),)
    assert (scn.scenario.begin, scn.scenario.duration) == (100.0, 600.0)  # end 700 - begin 100


def test_begin_and_duration_of_the_scenario_override_the_config(tmp_path):
    _config(tmp_path)
    scn = load_scenario(_scenario(tmp_path, "begin = 120\nduration = 30"))
    assert (scn.scenario.begin, scn.scenario.duration) == (120.0, 30.0)
    # b departs at 130.5 s; f inserts at 100, 160, 220, 280 and 340 s: none of them in [120, 150)
    assert file_counts(scn) == {"in_files": 9, "in_window": 1}


def test_the_window_copy_keeps_what_departs_in_the_window(tmp_path):
    _config(tmp_path)
    scn = load_scenario(_scenario(tmp_path, "duration = 100"))  # [100, 200)
    run = tmp_path / "run"
    run.mkdir()
    assert write_window(scn, run) == (WINDOW_FILE,)
    root = ET.parse(run / WINDOW_FILE).getroot()
    assert [el.get("id") for el in root if el.tag != "vType"] == ["a", "b", "f"]
    assert root.find("flow").get("end") == "200"  # cut to the window's end
    write_sumocfg(run / "scenario.sumocfg", str(CROSS), scn, (WINDOW_FILE,))
    cfg = ET.parse(run / "scenario.sumocfg").getroot()
    assert cfg.find("time/begin").get("value") == "100"
    assert float(cfg.find("time/end").get("value")) == 100 + 100 + scn.scenario.drain
    assert cfg.find("input/route-files").get("value").split(",")[-1] == WINDOW_FILE


def test_keep_all_demand_reads_the_users_file_itself(tmp_path):
    _config(tmp_path)
    scn = load_scenario(_scenario(tmp_path, "duration = 10\nkeep_all_demand = true"))
    assert write_window(scn, tmp_path) is None
    assert route_files(scn)[-1] == str(tmp_path / "city.rou.xml")


def test_an_empty_window_names_the_file_the_window_and_the_first_depart(tmp_path):
    _config(tmp_path)
    with pytest.raises(InputError) as err:
        load_scenario(_scenario(tmp_path, "begin = 0\nduration = 40"))
    text = str(err.value)
    assert "city.rou.xml" in text and "[0, 40) s" in text and "first vehicle departs at 50 s" in text
    assert "\n" not in text


def test_additional_files_of_the_config_are_passed_on(tmp_path):
    (tmp_path / "det.add.xml").write_text("<additional/>")
    _config(tmp_path, extra='<additional-files value="det.add.xml"/>')
    scn = load_scenario(_scenario(tmp_path))
    assert scn.network.additional == (str(tmp_path / "det.add.xml"),)
    write_sumocfg(tmp_path / "scenario.sumocfg", str(CROSS), scn)
    cfg = ET.parse(tmp_path / "scenario.sumocfg").getroot()
    assert cfg.find("input/additional-files").get("value") == str(tmp_path / "det.add.xml")


def test_an_additional_file_holding_only_demand_is_read_as_a_route_file(tmp_path):
    """SUMO's own demo configs (tools/game/square.sumocfg) list their routes as additional files:
    such a file is demand (counted, cut to the window, loaded before the route files); one with
    anything else stays an additional file."""
    (tmp_path / "more.rou.xml").write_text('<routes><vType id="bus" length="12"/>'
                                           '<flow id="g" type="bus" begin="100" end="300" period="100" '
                                           'from="1fi" to="2o"/></routes>')
    (tmp_path / "det.add.xml").write_text('<additional><vType id="x"/><inductionLoop id="d" lane="1fi_0" '
                                          'pos="5" period="60" file="NUL"/></additional>')
    _config(tmp_path, extra='<additional-files value="det.add.xml,more.rou.xml"/>')
    scn = load_scenario(_scenario(tmp_path))
    assert scn.network.routes == (str(tmp_path / "more.rou.xml"), str(tmp_path / "city.rou.xml"))
    assert scn.network.additional == (str(tmp_path / "det.add.xml"),)


@pytest.mark.parametrize("extra, network, field", [
    ("", 'routes = "missing.rou.xml"', "network.routes"),
    ("", 'sumocfg = "nope.sumocfg"', "network.sumocfg"),
])
def test_bad_config_input_is_one_line(tmp_path, extra, network, field):
    _config(tmp_path, extra=extra)
    path = _scenario(tmp_path, network=network)
    if "sumocfg" in network:
        path.write_text(path.read_text().replace('sumocfg = "city.sumocfg"\n', ""))
    with pytest.raises(InputError) as err:
        load_scenario(path)
    assert err.value.field == field


BUSES = """<routes>
    <trip id="bus1" type="car" depart="110" from="2fi" to="4o"/>
    <trip id="bus2" type="car" depart="500" from="3fi" to="1o"/>
</routes>
"""


def test_several_route_files_are_read_in_order_each_cut_to_the_window(tmp_path):
    """A config listing two route files (the second uses the first's vType): both are read, counted
    and cut to the window, each into its own sorted copy, loaded in the config's order."""
    (tmp_path / "buses.rou.xml").write_text(BUSES)
    _config(tmp_path, routes="city.rou.xml,buses.rou.xml")
    scn = load_scenario(_scenario(tmp_path, "duration = 100"))  # [100, 200)
    assert scn.network.routes == (str(tmp_path / "city.rou.xml"), str(tmp_path / "buses.rou.xml"))
    assert file_counts(scn) == {"in_files": 11, "in_window": 5}  # a, b, f at 100 and 160 s, bus1
    run = tmp_path / "run"
    run.mkdir()
    names = write_window(scn, run)
    assert names == (WINDOW_FILE, "demand-2.rou.xml")
    assert [el.get("id") for el in ET.parse(run / names[1]).getroot()] == ["bus1"]
    assert route_files(scn, names)[-2:] == list(names)


def test_a_route_file_list_in_the_scenario_and_its_bad_entries(tmp_path):
    (tmp_path / "buses.rou.xml").write_text(BUSES)
    _config(tmp_path)
    scn = load_scenario(_scenario(tmp_path, network='routes = ["city.rou.xml", "buses.rou.xml"]'))
    assert len(scn.network.routes) == 2
    for bad in ('routes = []', 'routes = ["city.rou.xml", 3]', 'routes = ["city.rou.xml", "nope.rou.xml"]'):
        with pytest.raises(InputError) as err:
            load_scenario(_scenario(tmp_path, network=bad))
        assert err.value.field == "network.routes"
    (tmp_path / "only_buses.rou.xml").write_text(BUSES)  # without the file of its vType: SUMO refuses it
    with pytest.raises(InputError, match="SUMO refuses it"):
        load_scenario(_scenario(tmp_path, network='routes = ["only_buses.rou.xml"]'))


def test_a_flow_counts_the_vehicles_it_inserts_in_the_window(tmp_path):
    """A regular flow counts its departures (by period, per-hour rate, or number over its
    interval), a random one its expected number; a flow that began before the window and runs
    into it has vehicles in it (the window is not empty)."""
    path = tmp_path / "flows.rou.xml"
    path.write_text("""<routes>
    <flow id="p" begin="0" end="100" period="10" from="1fi" to="2o"/>
    <flow id="h" begin="0" end="3600" vehsPerHour="360" from="1fi" to="2o"/>
    <flow id="n" begin="50" end="150" number="4" from="1fi" to="2o"/>
    <flow id="q" begin="0" end="1000" probability="0.2" from="1fi" to="2o"/>
    <flow id="c" begin="0" period="20" number="3" from="1fi" to="2o"/>
</routes>""")
    p, h, n, q, c = route_demand(str(path))
    assert [p.count(0, 100), p.count(25, 55), p.count(95, 1e9)] == [10, 3, 0]  # 30, 40, 50 s; none at 100
    assert h.count(0, 60) == 6 and h.count(-1e9, 1e9) == 360
    assert n.count(0, 1e9) == 4 and n.count(50, 100) == 2  # at 50, 75, 100, 125 s
    assert q.count(0, 100) == pytest.approx(20.0)  # expected
    assert c.count(0, 1e9) == 3 and c.end == 60.0  # 0, 20, 40 s
    _config(tmp_path)
    scn = load_scenario(_scenario(tmp_path, "begin = 205\nduration = 25"))  # f's 220 s only
    assert file_counts(scn)["in_window"] == 1
