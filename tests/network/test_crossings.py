"""Pedestrian crossings of a real junction mapped onto its movement paths (network/crossings.py):
SUMO's Braunschweig junction 38 (tools/game/fokr_bs_demo), eight zebra crossings, one over each
road in and out."""

import math
from pathlib import Path

import pytest
import sumo

from intersection_cosim.network.crossings import crossing_zones, junction_crossings
from intersection_cosim.network.junction_net import load_movements
from intersection_cosim.network.movements import paper_movements

NET = str(Path(sumo.SUMO_HOME) / "tools" / "game" / "fokr_bs_demo" / "fokr_bs.net.xml.gz")


@pytest.fixture(scope="module")
def fokr():
    movements = load_movements(NET, ("38",), 100.0)
    crossings = junction_crossings(NET, ("38",))
    return movements, crossings, crossing_zones(movements, crossings, 5.0, 1.8)


def test_every_crossing_of_the_junction_is_read_with_its_axis_width_and_walking_areas(fokr):
    _, crossings, _ = fokr
    assert sorted(crossings) == [f":38_c{i}_0" for i in range(8)]
    c0 = crossings[":38_c0_0"]
    assert c0.edge == ":38_c0" and c0.junction == "38" and c0.width == 3.5  # [m]
    assert c0.length == pytest.approx(19.15, abs=0.05)  # [m] the lane's length in the net
    assert c0.walking_areas == (":38_w0_0", ":38_w4_0")
    assert c0.along(*c0.end) == pytest.approx(c0.length) and c0.along(*c0.start) == pytest.approx(0.0)


def test_every_path_runs_over_the_crossing_of_its_road_in_then_of_its_road_out(fokr):
    movements, crossings, zones = fokr
    assert set(zones) == set(movements.paths)  # every road of the junction has a crossing
    for pid, path in movements.paths.items():
        first, last = zones[pid]
        # just past the stop line, and ending where the rear has left the junction (5 m body)
        assert path.s_stop <= first.zone_in <= path.s_stop + 2.0
        assert path.s_exit - 12.0 <= last.zone_in < path.s_exit < last.zone_out <= path.s_exit + 5.0 + 0.5
        for z in (first, last):
            body = z.zone_out - z.zone_in  # [m] front over the crossing until the rear is off it
            assert crossings[z.lane].width + 5.0 - 0.5 <= body <= crossings[z.lane].width / abs(
                math.cos(math.radians(35))) + 5.0 + 2.0
            lo, hi = z.span
            assert -1.0 <= lo < hi <= crossings[z.lane].length + 1.0 and 1.8 <= hi - lo <= 8.0  # [m] one lane's stretch
    # the two lanes of one road in cross its crossing side by side
    inner, outer = (zones[p][0].span for p in ("-1.23_6>5_4", "-1.23_7>3_3"))
    assert inner[0] > outer[1] - 1.0


def test_the_generated_paper_net_has_no_crossings(net_file):
    movements = paper_movements(net_file)
    assert junction_crossings(net_file, movements.junctions) == {}
    assert crossing_zones(movements, {}, 5.0, 1.8) == {}


def test_the_outline_draws_the_crossings_apart_from_the_lanes_and_leaves_out_the_walking_areas():
    import sumolib

    from intersection_cosim.network.outline import read_outline

    net = sumolib.net.readNet(NET, withInternal=True)
    functions = [e.getFunction() for e in net.getEdges(withInternal=True)]
    outline = read_outline(NET)
    assert len(outline.crossings) == functions.count("crossing") >= 8
    normal = sum(len(e.getLanes()) for e in net.getEdges(withInternal=True) if e.getFunction() in ("", "normal"))
    assert len(outline.lanes) == normal  # no walking area drawn as a lane


def test_the_crossings_that_count_are_those_of_every_junction_the_approaches_pass(fokr):
    """The approaches run through upstream junctions within the control range (their internal
    lanes are on the paths); a zebra crossing there would count too. Here only 38 has any."""
    from intersection_cosim.network.crossings import movement_crossings, path_junctions

    movements, crossings, _ = fokr
    passed = path_junctions(movements)
    assert "38" in passed and {"J4", "J9", "J12", "J3"} <= set(passed)
    assert movement_crossings(movements) == crossings
