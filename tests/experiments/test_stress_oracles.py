"""The braking oracles of a stress run: braking harder than emergencyDecel is a ``hard_braking``
failure; braking between decel and emergencyDecel (what the safety rules command on purpose) is an
``emergency_braking`` near miss that counts as a failure only with ``emergency_braking_fails``."""

from __future__ import annotations

import json
import math

import pandas as pd
import pytest

from intersection_cosim.errors import InputError
from intersection_cosim.experiments.stress.oracles import Verdict, judge
from intersection_cosim.scenario.stress_settings import stress_settings

ROUTES = """<routes>
  <vType id="av" decel="4" emergencyDecel="9.0"/>
  <vType id="human" decel="4.5"/>
  <vehicle id="a.0" type="av" depart="0"/>
  <vehicle id="h.0" type="human" depart="0"/>
</routes>
"""


def _run(folder, brakes: dict[str, tuple[float, float]]):
    """A minimal finished run folder: two vehicles driving 10 m/s apart on two lanes, each with
    one row braking at ``brakes[vehicle]`` = (realised accel, commanded accel (NaN: none)) [m/s^2]."""
    folder.mkdir()
    rows = []
    for k, vid in enumerate(("a.0", "h.0")):
        for step in range(3):
            accel, cmd = brakes.get(vid, (0.0, math.nan)) if step == 1 else (0.0, math.nan)
            rows.append((0.1 * step, vid, 10.0 * step, 5.0 * k, 10.0, accel, 0.0, f"e{k}_0", cmd))
    pd.DataFrame(rows, columns=["time", "vehicle", "x", "y", "speed", "accel", "heading", "lane", "accel_cmd"]) \
        .to_csv(folder / "trajectories.csv", index=False)
    (folder / "scenario.rou.xml").write_text(ROUTES)
    pd.DataFrame(columns=["time", "collider", "victim", "type", "lane"]).to_csv(folder / "collisions.csv", index=False)
    pd.DataFrame(columns=["time", "vehicle_a", "vehicle_b", "lane_a"]).to_csv(folder / "overlaps.csv", index=False)
    pd.DataFrame({"vehicle": ["a.0", "h.0"], "depart": [0.0, 0.0], "arrival": [0.2, 0.2]}) \
        .to_csv(folder / "vehicles.csv", index=False)
    pd.DataFrame(columns=["pet"]).to_csv(folder / "pairs.csv", index=False)
    (folder / "summary.json").write_text(json.dumps({
        "settings": {"model": {"vehicle_length": 4.5}}, "counts": {"vehicles": 2, "arrived": 2},
        "metrics": {"compute_ms_median": 1.0}}))
    return folder


def test_commanded_braking_at_emergency_decel_is_a_near_miss_not_a_failure(tmp_path):
    run = _run(tmp_path / "run", {"a.0": (-9.0, -9.0), "h.0": (-7.0, math.nan)})
    v = judge(run)
    assert v.failures == ()
    (near,) = v.near_misses
    assert (near.kind, near.vehicles, near.time) == ("emergency_braking", ("a.0",), 0.1)
    assert "harder than its decel 4 m/s^2" in near.why and "the controller commanded it" in near.why
    assert v.margin == 99.0  # nothing came close: a near miss does not move the margin
    assert Verdict.from_dict(json.loads(json.dumps(v.to_dict()))).near_misses == v.near_misses


def test_near_misses_count_as_failures_when_configured(tmp_path):
    run = _run(tmp_path / "run", {"h.0": (-7.0, math.nan)})
    v = judge(run, near_misses_fail=True)
    assert [f.kind for f in v.failures] == ["emergency_braking"] and v.near_misses == ()
    assert "SUMO's driver model braked" in v.failures[0].why
    assert stress_settings("s.toml", {"emergency_braking_fails": True}).emergency_braking_fails is True
    with pytest.raises(InputError, match="must be true or false"):
        stress_settings("s.toml", {"emergency_braking_fails": 1})


def test_braking_beyond_emergency_decel_is_a_hard_braking_failure(tmp_path):
    # 9.4 m/s^2 is within the 0.5 m/s^2 tolerance of the av's emergencyDecel (a near miss only);
    # the human's vType sets no emergencyDecel: SUMO's 9 m/s^2, so 9.6 is beyond it
    run = _run(tmp_path / "run", {"a.0": (-9.4, -9.4), "h.0": (-9.6, math.nan)})
    v = judge(run)
    assert [(f.kind, f.vehicles) for f in v.failures] == [("hard_braking", ("h.0",))]
    assert "harder than its emergencyDecel 9 m/s^2" in v.failures[0].why
    assert [(f.kind, f.vehicles) for f in v.near_misses] == [("emergency_braking", ("a.0",))]


def test_an_old_verdict_without_near_misses_still_reads():
    d = {"margin": 1.0, "min_pet": 1.0, "min_time_gap": 2.0, "failures": [], "vehicles": 1, "arrived": 1,
         "compute_ms_median": 1.0}
    assert Verdict.from_dict(d).near_misses == ()
