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
    assert scn.network.routes == str(tmp_path / "city.rou.xml")
    assert (scn.scenario.begin, scn.scenario.duration) == (100.0, 600.0)  # end 700 - begin 100


def test_begin_and_duration_of_the_scenario_override_the_config(tmp_path):
    _config(tmp_path)
    scn = load_scenario(_scenario(tmp_path, "begin = 120\nduration = 30"))
    assert (scn.scenario.begin, scn.scenario.duration) == (120.0, 30.0)
    # b departs at 130.5 s; a flow counts by its begin (f: 100 s, before the window)
    assert file_counts(scn) == {"in_files": 5, "in_window": 1}


def test_the_window_copy_keeps_what_departs_in_the_window(tmp_path):
    _config(tmp_path)
    scn = load_scenario(_scenario(tmp_path, "duration = 100"))  # [100, 200)
    run = tmp_path / "run"
    run.mkdir()
    assert write_window(scn, run) == WINDOW_FILE
    root = ET.parse(run / WINDOW_FILE).getroot()
    assert [el.get("id") for el in root if el.tag != "vType"] == ["a", "b", "f"]
    assert root.find("flow").get("end") == "200"  # cut to the window's end
    write_sumocfg(run / "scenario.sumocfg", str(CROSS), scn, WINDOW_FILE)
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


def test_two_route_files_are_refused(tmp_path):
    _config(tmp_path, routes="city.rou.xml,city.rou.xml")
    with pytest.raises(InputError, match="lists 2 route files"):
        load_scenario(_scenario(tmp_path))
