"""report.md's tables (units in the headers, one rounding per quantity) and which sweeps get the
kappa trade-off figure."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from intersection_cosim.experiments.compare import markdown_table as compare_table
from intersection_cosim.experiments.sweep import make_spec
from intersection_cosim.report.reporting import markdown_table, tradeoff_vehicle

CASE1A = str(Path(__file__).resolve().parents[2] / "scenarios" / "case1_A.toml")


def test_sweep_table_has_units_and_rounds_each_quantity_alike():
    table = pd.DataFrame({"run_id": ["nash-seed1-V2_0.10"], "seed": [1], "kappa_V2": [0.1],
                          "travel_time_V2": [10.649999], "mean_travel_time": [11.116667], "min_ttc": [1.9012],
                          "min_ttc_ssm_V1_V2": [3.79], "pet_V1_V2": [1.0], "min_pet": [np.nan], "collisions": [0],
                          "compute_ms_median": [0.17128], "status": ["ok"]})
    lines = markdown_table(table).splitlines()
    assert lines[0] == ("| run | seed | κ V2 [-] | travel time V2 [s] | mean travel time [s] | min TTC, ours [s] | "
                        "min TTC V1-V2, SSM [s] | PET V1-V2, SSM [s] | min PET, SSM [s] | collisions [-] | "
                        "compute median [ms] | status |")
    assert lines[2] == "| nash-seed1-V2_0.10 | 1 | 0.10 | 10.65 | 11.12 | 1.90 | 3.79 | 1.00 |  | 0 | 0.17 | ok |"


def test_run_tables_name_their_units():
    pairs = pd.DataFrame({"vehicle_a": ["V1"], "vehicle_b": ["V2"], "conflict": ["cross"], "min_ttc": [2.1234],
                          "pet_ssm": [0.8666], "game_steps": [29]})
    assert markdown_table(pairs).splitlines()[::2] == [
        "| vehicle a | vehicle b | conflict | min TTC, ours [s] | PET, SSM [s] | game steps [-] |",
        "| V1 | V2 | cross | 2.12 | 0.87 | 29 |"]


def test_comparison_table_has_units():
    row = pd.DataFrame({"scenario": ["low"], "demand_veh_h": [600.0], "controller": ["fcfs"], "travel_time_mean": [20.934],
                        "throughput_veh_h": [1171.2], "ssm_share_under_thresholds": [0.48412],
                        "deadline_miss_share": [0.00012]})
    assert compare_table(row).splitlines()[::2] == [
        "| scenario | demand [veh/h] | controller | travel time, mean [s] | throughput [veh/h] | "
        "share of SSM encounters under thresholds [-] | share of steps missing the deadline [-] |",
        "| low | 600 | fcfs | 20.93 | 1171 | 0.484 | 0.0001 |"]


def test_the_tradeoff_figure_is_drawn_when_one_vehicle_s_kappa_varies():
    assert tradeoff_vehicle(make_spec(CASE1A, ["V2=0.1:0.9:0.2"], "nash", "1")) == "V2"
    assert tradeoff_vehicle(make_spec(CASE1A, ["V1=0.3", "V3=0.2,0.8"], "nash", "1")) == "V3"
    assert tradeoff_vehicle(make_spec(CASE1A, ["V1=0.3,0.7", "V2=0.2,0.5"], "nash", "1")) is None
    assert tradeoff_vehicle(make_spec(CASE1A, None, "nash", "1")) is None


def test_report_on_a_compare_folder_names_the_sweep_folders_it_takes(tmp_path):
    import pytest

    from intersection_cosim.errors import InputError
    from intersection_cosim.report.reporting import write_report

    (tmp_path / "comparison.csv").write_text("scenario,controller\n")
    (tmp_path / "cross_low").mkdir()
    (tmp_path / "cross_low" / "sweep.json").write_text("{}")
    with pytest.raises(InputError) as err:
        write_report(tmp_path)
    assert err.value.field == "folder" and "is a compare folder" in err.value.problem
    assert "(cross_low)" in err.value.problem and "same compare command" in err.value.problem
