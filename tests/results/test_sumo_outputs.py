"""Reading SUMO's SSM output: when a min TTC was taken, and SSM's own collision class kept apart."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from intersection_cosim.report.reporting import _ssm_before_control
from intersection_cosim.results.sumo_outputs import read_ssm

SSM = """<SSMLog>
  <conflict begin="0.00" end="9.35" ego="V1" foe="V2">
    <minTTC time="0.00" position="-0.02,-2.52" type="10" value="4.23" speed="5.50"/>
    <PET time="4.24" position="0.70,-2.43" type="17" value="0.86" speed="10.00"/>
  </conflict>
  <conflict begin="29.45" end="41.10" ego="n.1" foe="w.11">
    <minTTC time="36.20" position="-10.00,-8.00" type="111" value="0.00" speed="10.00"/>
    <PET time="NA" position="NA" type="NA" value="NA" speed="NA"/>
  </conflict>
</SSMLog>"""


def test_ssm_min_ttc_carries_its_time_and_a_collision_class_ttc_is_left_out(tmp_path):
    (tmp_path / "ssm.xml").write_text(SSM)
    ssm = read_ssm(tmp_path / "ssm.xml").set_index("ego")
    assert ssm.loc["V1", "min_ttc"] == 4.23 and ssm.loc["V1", "min_ttc_time"] == 0.0  # [s]
    assert not ssm.loc["V1", "ssm_collision"] and ssm.loc["V1", "pet"] == 0.86
    # SSM's "collision" (type 111, TTC 0) of a merge SUMO's collision check did not confirm
    assert ssm.loc["n.1", "ssm_collision"] and math.isnan(ssm.loc["n.1", "min_ttc"])


@pytest.mark.parametrize("at, first_step, expected", [(0.0, 0.05, True), (0.05, 0.05, True), (1.3, 0.05, False)])
def test_a_sweep_whose_ssm_min_ttc_precedes_every_decision_is_labelled(tmp_path, at, first_step, expected):
    table = pd.DataFrame({"run_id": ["a", "b"], "status": ["ok", "ok"], "min_ttc_ssm": [4.23, 4.23],
                          "time_min_ttc_ssm": [0.0, at]})
    for run_id in table["run_id"]:
        (tmp_path / "runs" / run_id).mkdir(parents=True)
        pd.DataFrame({"time": [first_step, first_step + 0.1], "compute_ms": [1.0, 1.0]}).to_csv(
            tmp_path / "runs" / run_id / "steps.csv", index=False)
    assert _ssm_before_control(tmp_path, table) is expected
