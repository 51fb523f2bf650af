"""[scenario] ssm: SUMO's SSM device on or off, a measurement only (real runs of Case 1 A)."""

import dataclasses
import json
from pathlib import Path

import pandas as pd
import pytest

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import load_scenario
from tests.results.test_units import assert_declared

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


def _run(tmp_path: Path, ssm: bool) -> Path:
    scn = load_scenario(SCENARIOS / "case1_A.toml")
    scn = dataclasses.replace(scn, scenario=dataclasses.replace(scn.scenario, ssm=ssm))
    out = tmp_path / f"ssm_{ssm}"
    run_scenario(scn, out)
    return out


def test_without_the_ssm_device_the_run_drives_the_same_and_records_no_ssm(tmp_path):
    """Case 1 A under nash with ssm = false: the same trajectories to the bit and the same own
    margins (pairs.csv min_ttc, pet) as with the device; no ssm.xml, SSM's pair columns empty,
    no SSM section in the exported config, and the setting in summary.json. With it, SSM
    recorded V1-V2, its min TTC taken at t = 0 s: the vehicles' speeds as inserted, before the
    first decision (pairs.csv time_min_ttc_ssm, summary.json time_min_ttc_ssm)."""
    on, off = _run(tmp_path, True), _run(tmp_path, False)
    assert (on / "ssm.xml").exists() and not (off / "ssm.xml").exists()
    pd.testing.assert_frame_equal(pd.read_csv(on / "trajectories.csv"), pd.read_csv(off / "trajectories.csv"))
    p_on, p_off = pd.read_csv(on / "pairs.csv"), pd.read_csv(off / "pairs.csv")
    pd.testing.assert_frame_equal(p_on[["vehicle_a", "vehicle_b", "min_ttc", "pet"]],
                                  p_off[["vehicle_a", "vehicle_b", "min_ttc", "pet"]])
    assert p_on["min_ttc_ssm"].notna().any() and p_off["min_ttc_ssm"].isna().all() and p_off["pet_ssm"].isna().all()
    v1v2 = p_on.set_index(["vehicle_a", "vehicle_b"]).loc[("V1", "V2")]
    assert v1v2["min_ttc_ssm"] == pytest.approx(4.23) and v1v2["time_min_ttc_ssm"] == 0.0  # [s]
    assert json.loads((on / "summary.json").read_text())["metrics"]["time_min_ttc_ssm"] == 0.0
    assert p_off["time_min_ttc_ssm"].isna().all()
    units = pd.read_csv(on / "units.csv", keep_default_na=False)  # a game controller's CSVs too
    assert {"convergence.csv", "games.csv", "pairs.csv"} <= set(units["file"])
    assert_declared(units)
    assert "device.ssm" in (on / "scenario.sumocfg").read_text()
    assert "device.ssm" not in (off / "scenario.sumocfg").read_text()
    summary = json.loads((off / "summary.json").read_text())
    assert summary["settings"]["scenario"]["ssm"] is False
    assert summary["counts"]["collisions"] == 0
