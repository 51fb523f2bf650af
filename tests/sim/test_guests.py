"""Which other managed junctions see a vehicle as a guest (sim/snapshot.py, guests_of)."""

from types import SimpleNamespace

import libsumo

from intersection_cosim.network.movements import OUTSIDE, READY
from intersection_cosim.sim.snapshot import guests_of


def _path(junction: str, lanes: tuple[str, ...], starts: tuple[float, ...], s_stop: float):
    return SimpleNamespace(junction=junction, lanes=lanes, lane_starts=starts, s_stop=s_stop)


def _chain(control_range: float, lane: str = "a_0", pos: float = 10.0):
    """Junctions A, B, C one after another, joined by 0.2 m links: the vehicle is on A's path
    (approach a_0, 60 m; A's box; link ab_0), whose exit lane is B's approach, whose exit lane
    (bc_0) is C's approach."""
    paths = {"A": _path("A", ("a_0", ":A_0", "ab_0"), (0.0, 60.0, 70.0), 60.0),
             "B": _path("B", ("ab_0", ":B_0", "bc_0"), (0.0, 0.2, 10.2), 0.2),
             "C": _path("C", ("bc_0", ":C_0", "cd_0"), (0.0, 0.2, 12.2), 0.2)}
    nxt = {"ab_0": "B", "bc_0": "C"}
    return SimpleNamespace(paths=paths, current_path={"v": "A"}, previous_path={}, control_range=control_range,
                           states={"v": {libsumo.VAR_LANE_ID: lane, libsumo.VAR_LANEPOSITION: pos}},
                           movements=SimpleNamespace(junctions=("A", "B", "C"), paths=paths),
                           approach_path=lambda link, vid: nxt.get(link))


def test_every_junction_ahead_over_short_links_within_range_sees_the_vehicle():
    # at s = 10 m on A's path: B's stop line is 70 - 10 + 0.2 = 60.2 m ahead, C's 70.4 m
    guests = guests_of(_chain(100.0), "v", 10.0)
    assert [(g.path, g.role) for g in guests] == [("B", READY), ("C", READY)]
    assert [round(g.offset, 6) for g in guests] == [-70.0, -80.2]  # s on B = s - 70, on C = s - 80.2
    assert [g.path for g in guests_of(_chain(65.0), "v", 10.0)] == ["B"]  # C's line out of range
    assert guests_of(_chain(50.0), "v", 10.0) == []


def test_on_the_link_the_vehicle_is_the_next_junctions_and_the_previous_one_sees_it_leave():
    sim = _chain(100.0, lane="ab_0", pos=0.1)
    sim.current_path, sim.previous_path = {"v": "B"}, {"v": "A"}
    guests = guests_of(sim, "v", 0.1)
    assert [(g.path, g.role) for g in guests] == [("A", OUTSIDE), ("C", READY)]
