"""RESCO's delay measure on hand-made tripinfo and route files, against RESCO's formula."""

import math

import pandas as pd
import pytest

from intersection_cosim.experiments.benchmark import published_table
from intersection_cosim.results.resco_delay import resco_delay

TRIPINFO = """<tripinfos>
  <tripinfo id="a" depart="11" departDelay="1" arrival="50" duration="39" timeLoss="5"/>
  <tripinfo id="b" depart="22" departDelay="2" arrival="80" duration="58" timeLoss="3"/>
  <tripinfo id="c" depart="30" departDelay="0" arrival="130" duration="100" timeLoss="60"/>
</tripinfos>
"""
ROUTES = """<routes>
  <vehicle id="a" depart="10"><route edges="e"/></vehicle>
  <vehicle id="b" depart="20"><route edges="e"/></vehicle>
  <vehicle id="c" depart="30"><route edges="e"/></vehicle>
  <vehicle id="d" depart="40"><route edges="e"/></vehicle>
  <flow id="f" begin="0" end="100" period="10"><route edges="e"/></flow>
</routes>
"""


def _files(tmp_path, tripinfo=TRIPINFO):
    (tmp_path / "tripinfo.xml").write_text(tripinfo)
    (tmp_path / "demand.rou.xml").write_text(ROUTES)
    return tmp_path / "tripinfo.xml", [tmp_path / "demand.rou.xml"]


def test_delay_adds_insertion_delay_and_charges_the_backlog_up_to_the_end(tmp_path):
    trips, routes = _files(tmp_path)
    # arrived by 100 s: a (5 + 1) and b (3 + 2); last scheduled depart among them 20 s, so c (which
    # arrives after the end) and d wait in RESCO's sense: 100 - 30 and 100 - 40; the flow is left out
    assert resco_delay(trips, routes, 100.0) == pytest.approx((6 + 5 + 70 + 60) / 4)
    # a later end takes c in as a trip (60 + 0) and leaves only d waiting (200 - 40)
    assert resco_delay(trips, routes, 200.0) == pytest.approx((6 + 5 + 60 + 160) / 4)


def test_no_trip_and_no_demand_gives_nan_not_zero(tmp_path):
    trips, _ = _files(tmp_path, "<tripinfos/>")
    assert math.isnan(resco_delay(trips, [], 100.0))
    assert resco_delay(trips, [tmp_path / "demand.rou.xml"], 100.0) == pytest.approx((90 + 80 + 70 + 60) / 4)


def test_published_values_stand_beside_ours_only_for_the_baselines_both_ran():
    ours = pd.DataFrame({"sumo-tls": [31.3, 20.0], "nash": [6.5, 3.0]}, index=["cologne1", "paris"])
    ours.index.name = "scenario"
    table = published_table(ours)
    assert list(table.columns) == ["scenario", "sumo-tls (ours)", "sumo-tls (RESCO)"]
    assert table.loc[0, "sumo-tls (RESCO)"] == pytest.approx(56.6) and math.isnan(table.loc[1, "sumo-tls (RESCO)"])
