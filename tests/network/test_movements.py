"""The generated paper net through the Movements interface: same paths and conflicts as before."""

from __future__ import annotations

import dataclasses

import numpy as np

from intersection_cosim.network.conflicts import (
    conflict_points,
    load_conflict_table,
    load_conflicts,
    movement_conflict_table,
    movement_conflicts,
)
from intersection_cosim.network.junction_net import load_movements
from intersection_cosim.network.movements import PASSING, READY, paper_movements
from intersection_cosim.network.spec import LANE_INDEX

TABLE_ARRAYS = ("kind", "s_a", "s_b", "x", "y", "zone_in", "zone_out", "s_stop", "s_exit", "length")


def _assert_same_path(a, b) -> None:
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y)
        else:
            assert x == y, f.name


def test_paper_movements_hold_the_loaded_paths(net_file, paths):
    m = paper_movements(net_file)
    assert list(m.paths) == list(paths) and m.foes == frozenset() and m.junctions == ("C",)
    for pid, p in paths.items():
        _assert_same_path(m.paths[pid], p)
        assert p.stop_index == 1 and p.approach_lane == p.lanes[0] and p.junction_lanes == p.lanes[1:-1]
        assert p.s_stop == p.lane_starts[1]
        assert m.role(p.lanes[0]) == READY and all(m.role(ln) == PASSING for ln in p.lanes[1:-1])


def test_paper_conflicts_through_movements_equal_the_net_loaders(net_file):
    m = paper_movements(net_file)
    assert movement_conflicts(m) == load_conflicts(net_file)
    assert movement_conflicts(m, 2.2) == load_conflicts(net_file, 2.2)
    got, want = movement_conflict_table(m), load_conflict_table(net_file)
    assert got.ids == want.ids and got.index == want.index
    for name in TABLE_ARRAYS:
        a, b = getattr(got, name), getattr(want, name)
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)  # NaN in the same places counts as equal
        if a.dtype.kind == "f":
            assert (np.isnan(a) == np.isnan(b)).all()
    assert movement_conflict_table(m) is got  # cached on movements.key and sizes


def test_any_net_loader_on_the_generated_net_gives_the_same_geometry(net_file, paths):
    m = load_movements(net_file, ("C",))
    by_lanes = {p.lanes: p for p in m.paths.values()}
    assert len(m.paths) == len(paths) == 28 and set(by_lanes) == {p.lanes for p in paths.values()}
    for p in paths.values():
        q = by_lanes[p.lanes]
        assert q.id == f"{p.lanes[0]}>{p.lanes[-1]}" and q.junction == "C" and q.stop_index == 1
        assert (q.movement, q.exit_lane) == (p.movement, str(LANE_INDEX[p.exit_lane]))
        assert (q.lane_starts, q.s_stop, q.s_exit, q.length) == (p.lane_starts, p.s_stop, p.s_exit, p.length)
        for name in ("s", "xy", "heading", "curvature"):
            np.testing.assert_array_equal(getattr(q, name), getattr(p, name))
        # the paper's lane use, in SUMO lane indices, preferred first
        paper = paper_movements(net_file)
        assert m.options(q.id) == tuple(str(LANE_INDEX[e]) for e in paper.options(p.id))


def test_sumo_foes_on_the_generated_net_add_only_cross_guards(net_file):
    # SUMO calls links that enter the same road side by side foes; the body-overlap geometry does
    # not (their centre lines stay a lane apart): those pairs are the only additions.
    m = load_movements(net_file, ("C",))
    plain = conflict_points(dict(m.paths))
    guarded = movement_conflicts(m)
    added = set(guarded) - set(plain)
    assert added and added <= m.foes
    assert all(guarded[k] == plain[k] for k in plain)
    assert all(guarded[k].kind == "cross" and m.paths[k[0]].exit_arm == m.paths[k[1]].exit_arm for k in added)
