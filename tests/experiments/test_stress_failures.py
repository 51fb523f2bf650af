"""Failures of a stress search: de-duplication by kind and place, the files' names, shrink
candidates, the time-gap margin and the --set option."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from intersection_cosim.errors import InputError
from intersection_cosim.experiments.stress.failures import dedup, file_name, shrink_candidates, size
from intersection_cosim.experiments.stress.oracles import Failure, Verdict, min_time_gap
from intersection_cosim.scenario.set_option import apply_sets, parse_set


def _verdict(*failures: Failure) -> Verdict:
    return Verdict(margin=-1.0, min_pet=0.0, min_time_gap=1.0, failures=failures, vehicles=2, arrived=2,
                   compute_ms_median=1.0)


def test_a_failure_is_placed_by_the_edge_or_the_junction_of_its_lane():
    assert Failure("collision", 1.0, ":C_23_2", (), "").site == "C"
    assert Failure("collision", 1.0, ":cluster_1_2_3_0", (), "").site == "cluster_1_2"
    assert Failure("hard_braking", 1.0, "north_out_1", (), "").site == "north_out"


def test_dedup_keeps_the_first_run_per_kind_and_place_and_counts_the_others():
    crash = Failure("collision", 5.0, ":C_1_0", ("a.0", "b.0"), "x")
    results = [("run-00000", _verdict(), {"n": 0}),
               ("run-00001", _verdict(crash, Failure("overlap", 4.9, ":C_2_0", ("a.0", "b.0"), "y")), {"n": 1}),
               ("run-00002", _verdict(Failure("collision", 2.0, ":C_7_1", ("c.0", "d.0"), "z")), {"n": 2}),
               ("run-00003", _verdict(Failure("collision", 3.0, "west_in_0", ("e.0", "f.0"), "w")), {"n": 3})]
    found = dedup(results)
    assert [(f.key, f.run_id, f.runs) for f in found] == [
        (("collision", "west_in"), "run-00003", 1), (("overlap", "C"), "run-00001", 1),
        (("collision", "C"), "run-00001", 2)]
    assert file_name(("collision", ":C/1")) == "collision-_C_1.toml"


def test_shrink_candidates_are_smaller_in_window_flows_or_both():
    data = {"scenario": {"duration": 120.0}, "flow": [{"id": "a"}, {"id": "a_burst"}, {"id": "b"}, {"id": "c"}]}
    cands = shrink_candidates(data, Failure("collision", 30.2, "x_0", ("a.3", "b.1"), ""), pad=10.0, attempts=3)
    assert [size(c) for c in cands] == [(3, 41.0), (4, 41.0), (3, 120.0)]
    assert [f["id"] for f in cands[0]["flow"]] == ["a", "a_burst", "b"]
    late = shrink_candidates(data, Failure("lock", 115.0, "x_0", ("zz.1",), ""), pad=10.0, attempts=3)
    assert late == []  # neither shorter nor fewer flows


def test_the_time_gap_is_to_the_nearest_vehicle_ahead_on_the_lane():
    traj = pd.DataFrame({"time": [1.0] * 4, "vehicle": ["f", "l", "far", "other"],
                         "x": [0.0, 10.0, 40.0, 5.0], "y": [0.0] * 4, "heading": [0.0] * 4,
                         "speed": [5.0, 5.0, 5.0, 5.0], "lane": ["e_0", "e_0", "e_0", "e_1"]})
    assert min_time_gap(traj, length=5.0, floor=1.0) == pytest.approx((10.0 - 5.0) / 5.0)
    assert math.isnan(min_time_gap(traj[traj["vehicle"] == "f"], 5.0, 1.0))


def test_set_writes_nested_keys_and_reads_toml_values():
    assert parse_set("controller.safety.enabled=false") == (("controller", "safety", "enabled"), False)
    assert parse_set("controller.kind=nash") == (("controller", "kind"), "nash")
    data = apply_sets({"controller": {"kind": "nash"}}, ["controller.safety.time_gap=0.3", "stress.loss=[0, 0.1]"])
    assert data == {"controller": {"kind": "nash", "safety": {"time_gap": 0.3}}, "stress": {"loss": [0, 0.1]}}
    with pytest.raises(InputError, match="unknown table 'flow'"):
        parse_set("flow.rate=3")
    with pytest.raises(InputError, match="bad syntax"):
        parse_set("controller=3")
