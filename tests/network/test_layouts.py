"""Generated layouts other than the paper's: T-junction (3 arms) and 1-3 lanes per road.

Every (arms, lanes) combination is built with netconvert and read back with sumolib: its roads,
lane widths, lane centres and the junction's connections (by direction) against the spec's
lane-use table. The default spec must still give the committed paper net byte for byte, and the
shipped nets under sumo_networks/ must regenerate from their command.
"""

import hashlib
from collections import Counter
from pathlib import Path

import pytest
import sumolib

from intersection_cosim.cli import main
from intersection_cosim.errors import InputError
from intersection_cosim.network.build import NET_FILE, PLAIN_FILES, build_network, net_body
from intersection_cosim.network.spec import (
    ARM_DIRECTION,
    ARMS,
    EXIT_ARM,
    LANE_INDEX,
    LANE_NAME,
    LANE_USE,
    LANES,
    IntersectionSpec,
)

REPO = Path(__file__).resolve().parents[2]
NETS = REPO / "sumo_networks"
DIRECTION = {"left": "l", "straight": "s", "right": "r"}  # sumolib's Connection.getDirection()
LAYOUTS = [(arms, lanes) for arms in (3, 4) for lanes in (1, 2, 3)]


def _sha256(data: str | bytes) -> str:
    return hashlib.sha256(data.encode() if isinstance(data, str) else data).hexdigest()


@pytest.fixture(scope="module", params=LAYOUTS, ids=[f"arms{a}-lanes{n}" for a, n in LAYOUTS])
def built(request, tmp_path_factory):
    arms, lanes = request.param
    spec = IntersectionSpec(arms=arms, lanes_per_road=lanes)
    path = build_network(tmp_path_factory.mktemp(f"net-{arms}-{lanes}"), spec)
    return spec, sumolib.net.readNet(str(path), withInternal=True)


def _normal_edges(net):
    return [e for e in net.getEdges() if e.getFunction() != "internal"]


def test_roads_lanes_and_widths(built):
    spec, net = built
    edges = _normal_edges(net)
    assert sorted(e.getID() for e in edges) == sorted(f"{a}_{d}" for a in spec.arms_present() for d in ("in", "out"))
    assert all(e.getLaneNumber() == spec.lanes_per_road for e in edges)
    assert all(ln.getWidth() == pytest.approx(spec.lane_width) for e in edges for ln in e.getLanes())
    centre = net.getNode("C")
    assert centre.getCoord() == pytest.approx((0.0, 0.0))
    outside = [e for e in centre.getIncoming() + centre.getOutgoing() if e.getFunction() != "internal"]
    assert len(outside) == 2 * spec.arms


def test_connections_by_direction_are_the_lane_use(built):
    spec, net = built
    index = spec.lane_index()
    found = {(c.getFromLane().getID(), c.getToLane().getID(), c.getDirection())
             for e in _normal_edges(net) for ln in e.getLanes() for c in ln.getOutgoing()}
    expected = {(f"{a}_in_{index[lane]}", f"{spec.exit_arm(a, mv)}_out_{index[exit_lane]}", DIRECTION[mv])
                for a in spec.arms_present() for lane, moves in spec.lane_use(a).items()
                for mv, exits in moves.items() for exit_lane in exits}
    assert found == expected
    # Every connection is a movement of the layout: counts per (approach, movement).
    counts = Counter((lane.split("_")[0], d) for lane, _, d in found)
    for a in spec.arms_present():
        for mv in ("left", "straight", "right"):
            n = sum(len(m.get(mv, ())) for m in spec.lane_use(a).values())
            assert counts[(a, DIRECTION[mv])] == n, (a, mv)


def test_lane_centres_follow_lane_offset(built):
    spec, net = built
    for arm in spec.arms_present():
        ax, ay = ARM_DIRECTION[arm]
        for lane, i in spec.lane_index().items():
            # Incoming lanes lie right of the driving direction (towards the centre), outgoing left of the arm axis.
            for edge, sign in (("in", 1), ("out", -1)):
                for x, y in net.getLane(f"{arm}_{edge}_{i}").getShape():
                    lateral = x * -ay + y * ax  # signed distance left of the outward arm axis
                    assert lateral == pytest.approx(sign * spec.lane_offset(lane), abs=0.05)


def test_t_junction_drops_the_north_arm_and_its_movements():
    spec = IntersectionSpec(arms=3)
    assert spec.arms_present() == ("east", "south", "west")
    assert spec.movements("south") == ("left", "right")  # the stem
    assert spec.movements("east") == ("left", "straight")
    assert spec.movements("west") == ("straight", "right")
    assert all("north" not in exits.values() for exits in spec.exit_arms().values())
    with pytest.raises(ValueError):
        spec.exit_arm("south", "straight")
    # Three lanes: the stem's middle lane only went straight, so it has no movement left.
    assert set(IntersectionSpec(arms=3, lanes_per_road=3).lane_use("south")) == {"inner", "outer"}


def test_t_junction_through_road_has_priority(tmp_path):
    spec = IntersectionSpec(arms=3, lanes_per_road=2)
    net = sumolib.net.readNet(str(build_network(tmp_path, spec)))
    state = {}
    for arm in spec.arms_present():
        for ln in net.getEdge(f"{arm}_in").getLanes():
            for c in ln.getOutgoing():
                state.setdefault((arm, c.getDirection()), set()).add(c.getState())
    assert state[("east", "s")] == state[("west", "s")] == state[("west", "r")] == {"M"}
    assert state[("south", "l")] == state[("south", "r")] == {"m"}


def test_lane_use_tables_per_lane_count():
    assert IntersectionSpec(lanes_per_road=1).lane_use() == {
        "single": {"left": ("single",), "straight": ("single",), "right": ("single",)}}
    assert IntersectionSpec(lanes_per_road=2).lane_use() == {
        "inner": {"left": ("inner",), "straight": ("inner",)},
        "outer": {"right": ("outer",), "straight": ("outer",)}}
    assert IntersectionSpec(lanes_per_road=1).lanes() == ("single",)
    assert IntersectionSpec(lanes_per_road=2).lane_index() == {"outer": 0, "inner": 1}
    assert IntersectionSpec(lanes_per_road=2).lane_name() == {0: "outer", 1: "inner"}
    assert [IntersectionSpec(lanes_per_road=2).lane_offset(n) for n in ("inner", "outer")] == [2.0, 6.0]


def test_default_spec_matches_the_module_constants():
    spec = IntersectionSpec()
    assert spec.arms == 4 and spec.lanes_per_road == 3
    assert spec.arms_present() == ARMS
    assert spec.exit_arms() == EXIT_ARM
    assert spec.lanes() == LANES and spec.lane_index() == LANE_INDEX and spec.lane_name() == LANE_NAME
    assert spec.lane_use() == LANE_USE
    assert all(spec.lane_use(a) == LANE_USE for a in ARMS)
    assert [spec.lane_offset(n) for n in ("inner", "middle", "outer")] == [2.0, 6.0, 10.0]


def test_default_files_are_byte_identical_to_the_committed_net(tmp_path):
    """The committed sumo_networks/ net was built by the generator before layouts existed."""
    fresh = build_network(tmp_path)
    for name in PLAIN_FILES:
        assert _sha256((tmp_path / name).read_bytes()) == _sha256((NETS / name).read_bytes()), name
    # Only netconvert's leading comment (its generation time) may differ.
    assert _sha256(net_body(fresh)) == _sha256(net_body(NETS / NET_FILE))


@pytest.mark.parametrize("folder, argv", [
    ("t_junction", ["--arms", "3", "--lanes", "2", "--junction-type", "priority"]),
    ("cross_2lane", ["--arms", "4", "--lanes", "2", "--junction-type", "priority"]),
])
def test_shipped_nets_regenerate_from_their_command(tmp_path, capsys, folder, argv):
    assert main(["net", *argv, "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().out.strip() == str(tmp_path / NET_FILE)
    for name in PLAIN_FILES:
        assert (tmp_path / name).read_bytes() == (NETS / folder / name).read_bytes(), name
    assert net_body(tmp_path / NET_FILE) == net_body(NETS / folder / NET_FILE)


def test_shipped_t_junction():
    net = sumolib.net.readNet(str(NETS / "t_junction" / NET_FILE))
    spec = IntersectionSpec(arms=3, lanes_per_road=2)
    assert sorted(n.getID() for n in net.getNodes()) == ["C", "east", "south", "west"]
    assert len(net.getNode("C").getIncoming()) == 3
    counts = Counter((c.getFrom().getID(), c.getDirection())
                     for e in net.getEdges() for ln in e.getLanes() for c in ln.getOutgoing())
    assert counts == {("south_in", "l"): 1, ("south_in", "r"): 1, ("east_in", "l"): 1, ("east_in", "s"): 2,
                      ("west_in", "s"): 2, ("west_in", "r"): 1}
    assert {ln.getWidth() for e in net.getEdges() for ln in e.getLanes()} == {spec.lane_width}


@pytest.mark.parametrize("field, value, flag", [("arms", 5, "--arms"), ("arms", 2, "--arms"),
                                                ("lanes_per_road", 4, "--lanes"),
                                                ("lanes_per_road", 0, "--lanes")])
def test_unsupported_layout_is_an_input_error(tmp_path, field, value, flag):
    with pytest.raises(InputError) as exc:
        build_network(tmp_path / "out", IntersectionSpec(**{field: value}))
    assert exc.value.source == flag
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("argv", [["--arms", "5"], ["--lanes", "4"], ["--lanes", "two"]])
def test_cli_refuses_bad_layout_in_one_line(tmp_path, capsys, argv):
    with pytest.raises(SystemExit) as exc:
        main(["net", *argv, "--out", str(tmp_path / "out")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and argv[0] in err
    assert not (tmp_path / "out").exists()


def test_cache_keeps_layouts_apart(tmp_path, monkeypatch):
    from intersection_cosim.network.cache import cached_net

    monkeypatch.setenv("INTERSECTION_COSIM_CACHE", str(tmp_path))
    t = cached_net(IntersectionSpec(arms=3, lanes_per_road=2))
    cross = cached_net(IntersectionSpec())
    assert t != cross
    assert sorted(n.getID() for n in sumolib.net.readNet(str(t)).getNodes()) == ["C", "east", "south", "west"]
    assert net_body(cross) == net_body(NETS / NET_FILE)
