"""The generated net: eight three-lane roads, lane centres, lane use, junction types, reproducibility."""

from pathlib import Path

import pytest
import sumolib

from intersection_cosim.network.build import build_network, net_body
from intersection_cosim.network.spec import ARMS, LANE_INDEX, LANE_USE, IntersectionSpec, exit_arm

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def net(tmp_path_factory):
    path = build_network(tmp_path_factory.mktemp("net"))
    return sumolib.net.readNet(str(path), withInternal=True)


def test_eight_roads_of_three_lanes(net):
    edges = [e for e in net.getEdges() if not e.getID().startswith(":")]
    assert sorted(e.getID() for e in edges) == sorted(f"{a}_{d}" for a in ARMS for d in ("in", "out"))
    assert all(e.getLaneNumber() == 3 for e in edges)
    assert all(ln.getWidth() == pytest.approx(4.0) for e in edges for ln in e.getLanes())


@pytest.mark.parametrize("arm", ARMS)
def test_lane_centres_in_paper_frame(net, arm):
    # Incoming lanes lie right of the driving direction: northbound (from the south) at x = 2, 6, 10.
    expected = {"inner": 2.0, "middle": 6.0, "outer": 10.0}
    sign = {"south": (1, 0), "north": (-1, 0), "west": (0, -1), "east": (0, 1)}[arm]
    for lane, offset in expected.items():
        shape = net.getLane(f"{arm}_in_{LANE_INDEX[lane]}").getShape()
        for x, y in shape:
            coord = x if sign[0] else y
            assert coord == pytest.approx((sign[0] or sign[1]) * offset, abs=0.05)
    # Outgoing lanes mirror them: southbound (to the south) at x = -2, -6, -10.
    for lane, offset in expected.items():
        shape = net.getLane(f"{arm}_out_{LANE_INDEX[lane]}").getShape()
        for x, y in shape:
            coord = x if sign[0] else y
            assert coord == pytest.approx(-(sign[0] or sign[1]) * offset, abs=0.05)


def test_connections_are_exactly_the_lane_use(net):
    found = set()
    for edge in net.getEdges():
        if edge.getID().startswith(":"):
            continue
        for lane in edge.getLanes():
            for conn in lane.getOutgoing():
                found.add((lane.getID(), conn.getToLane().getID()))
    expected = {
        (f"{arm}_in_{LANE_INDEX[lane]}", f"{exit_arm(arm, mv)}_out_{LANE_INDEX[exit_lane]}")
        for arm in ARMS for lane, moves in LANE_USE.items() for mv, exits in moves.items() for exit_lane in exits
    }
    assert found == expected
    assert len(found) == 4 * 7  # per arm: left x2, straight x3, right x2; no U-turns


def test_junction_is_centred_square(net):
    node = net.getNode("C")
    assert node.getCoord() == pytest.approx((0.0, 0.0))
    xs, ys = zip(*node.getShape())
    assert max(xs) == pytest.approx(12.0, abs=0.05) and min(ys) == pytest.approx(-12.0, abs=0.05)


@pytest.mark.parametrize("junction_type", ["priority", "allway_stop", "traffic_light", "right_before_left"])
def test_junction_type_option(tmp_path, junction_type):
    path = build_network(tmp_path, IntersectionSpec(junction_type=junction_type))
    assert sumolib.net.readNet(str(path)).getNode("C").getType() == junction_type


def test_approach_length_option(tmp_path):
    path = build_network(tmp_path, IntersectionSpec(approach_length=80.0))
    lane = sumolib.net.readNet(str(path)).getLane("south_in_1")
    assert lane.getLength() == pytest.approx(80.0 - 12.0, abs=0.01)


def test_committed_net_regenerates_identically(tmp_path):
    committed = REPO / "sumo_networks" / "intersection.net.xml"
    fresh = build_network(tmp_path)
    assert net_body(fresh) == net_body(committed)
    for name in ("intersection.nod.xml", "intersection.edg.xml", "intersection.con.xml"):
        assert (tmp_path / name).read_text() == (REPO / "sumo_networks" / name).read_text()
