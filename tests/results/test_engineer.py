"""Traffic-engineer metrics: HCM level of service, per-approach control delay from SUMO's time
loss, fuel and CO2 of SUMO's emissions device."""

import dataclasses
import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from intersection_cosim.results.engineer import approach_table, delay_summary, level_of_service, run_energy

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


@pytest.mark.parametrize("delay, table, letter", [
    (10.0, "HCM signalized", "A"), (10.1, "HCM signalized", "B"), (55.0, "HCM signalized", "D"),
    (80.1, "HCM signalized", "F"), (15.0, "HCM unsignalized", "B"), (15.1, "HCM unsignalized", "C"),
    (50.1, "HCM unsignalized", "F"), (np.nan, "HCM unsignalized", ""),
])
def test_hcm_bands(delay, table, letter):
    assert level_of_service(delay, table) == letter


def _vehicles() -> pd.DataFrame:
    return pd.DataFrame({"vehicle": ["a", "b", "c", "d"], "approach": ["n", "n", "n", "e"],
                         "movement": ["left", "left", "straight", "left"],
                         "arrival": [10.0, 12.0, np.nan, 20.0], "time_loss": [4.0, 8.0, np.nan, 30.0]})


def test_approach_table_averages_arrived_time_loss_per_movement():
    queues = pd.DataFrame({"edge": ["n_in"], "p95_m": [11.0], "max_m": [15.0]})

    class P:  # a path of the generated net
        def __init__(self, approach):
            self.junction, self.approach, self.stop_index, self.lanes = "", approach, 1, [f"{approach}_in_0", ":C_0"]

    table = approach_table(_vehicles(), {v: "C" for v in "abcd"}, {"p1": P("n"), "p2": P("e")}, queues, 1800.0,
                           "HCM unsignalized")
    row = table.set_index(["approach", "movement"])
    assert row.loc[("n", "left"), "control_delay"] == 6.0 and row.loc[("n", "left"), "los"] == "A"
    assert (row.loc[("n", "all"), "vehicles"], row.loc[("n", "all"), "arrived"]) == (3, 2)
    assert row.loc[("n", "all"), "throughput"] == 4.0  # 2 arrived in half an hour
    assert (row.loc[("n", "all"), "queue_p95"], row.loc[("e", "all"), "queue_max"]) == (11.0, 0.0)
    assert row.loc[("e", "left"), "los"] == "D"  # 30 s: (25, 35]
    summary = delay_summary(table)
    assert summary["control_delay"] == pytest.approx((4 + 8 + 30) / 3)
    assert (summary["los"], summary["worst_los"]) == ("B", "D")  # 14 s: (10, 15]


def test_energy_sums_the_emissions_device():
    trips = pd.DataFrame({"arrival": [1.0, 2.0], "fuel_mg": [1000.0, 3000.0], "co2_mg": [2e6, 4e6]})
    assert run_energy(trips) == {"fuel_g": 4.0, "co2_kg": 6.0, "fuel_g_per_trip": 2.0, "co2_g_per_trip": 3000.0}


@pytest.mark.slow
def test_all_way_stop_control_delay_is_sumos_time_loss(tmp_path):
    from intersection_cosim.experiments.run import run_scenario
    from intersection_cosim.scenario import load_scenario, with_overrides

    scn = with_overrides(load_scenario(SCENARIOS / "demand_balanced_low.toml"), controller="sumo-allway-stop")
    scn = dataclasses.replace(scn, scenario=dataclasses.replace(scn.scenario, duration=120.0, ssm=False))
    summary = run_scenario(scn, tmp_path / "run")
    trips = [el for el in ET.parse(tmp_path / "run" / "tripinfo.xml").getroot() if el.tag == "tripinfo"]
    arrived = [float(el.get("timeLoss")) for el in trips if float(el.get("arrival")) >= 0]
    assert len(arrived) > 10
    assert summary["engineer"]["control_delay"] == pytest.approx(np.mean(arrived), rel=1e-9)
    assert summary["engineer"]["los_table"] == "HCM unsignalized"
    assert summary["engineer"]["fuel_g"] > 0 and summary["engineer"]["co2_kg"] > 0
    table = pd.read_csv(tmp_path / "run" / "approaches.csv")
    assert set(table["approach"]) == {"north", "east", "south", "west"}
    assert json.loads((tmp_path / "run" / "summary.json").read_text())["engineer"]["emission_classes"]
