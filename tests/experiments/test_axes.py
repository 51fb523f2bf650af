"""Scenario axes of sweep and compare (--latency, --loss, --av-share): parsing, the grid, run ids, bad values."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from intersection_cosim.cli import main
from intersection_cosim.errors import InputError
from intersection_cosim.experiments.axes import AXES, parse_axis
from intersection_cosim.experiments.executors import Job, job_scenario
from intersection_cosim.experiments.sweep import make_spec, sweep_jobs
from intersection_cosim.results.layout import SPEC_FILE
from intersection_cosim.results.sweep_folder import SweepSpec

from sweep_helpers import CASE1A


def test_every_axis_names_its_flag_and_field():
    assert {a.name: (a.flag, a.field) for a in AXES.values()} == {
        "latency": ("--latency", "v2x.latency"), "loss": ("--loss", "v2x.loss"),
        "av_share": ("--av-share", "flow.av_share")}


def test_av_share_axis_sets_every_flow_and_humans_appear_by_seed(tmp_path):
    from pathlib import Path

    from intersection_cosim.scenario.draws import draw_drivers, generate_flow_vehicles

    demand = Path(__file__).resolve().parents[2] / "scenarios" / "demand_balanced_medium.toml"
    spec = make_spec(demand, None, "nash", "1", axes={"av_share": "0,0.5,1"})
    jobs = sweep_jobs(spec, tmp_path, spec.scenario_text)
    assert [j.run_id for j in jobs] == ["nash-seed1-av_share_0.00", "nash-seed1-av_share_0.50", "nash-seed1-av_share_1.00"]
    humans = []
    for job in jobs:
        scn = job_scenario(Job.from_json(job.to_json()))
        assert len(scn.flows) == 12 and {f.av_share for f in scn.flows} == {job.axes[0][1]}
        import numpy as np
        drawn = draw_drivers(scn, generate_flow_vehicles(scn, np.random.default_rng(scn.scenario.seed)))
        humans.append(sum(v["driver"] == "human" for v in drawn) / len(drawn))
    assert humans[0] == 1.0 and humans[2] == 0.0 and 0.4 < humans[1] < 0.6


def test_axis_values_parse_in_order():
    assert parse_axis("latency", "0,0.1, 0.5") == (0.0, 0.1, 0.5)
    assert parse_axis("loss", "0.3,0") == (0.3, 0.0)


@pytest.mark.parametrize("name,text,problem", [
    ("latency", "-0.1", ">= 0"), ("loss", "0,1.5", "[0, 1]"), ("loss", "0.1,abc", "not a number"),
    ("latency", "0.1,0.1", "twice")])
def test_bad_axis_values(name, text, problem):
    with pytest.raises(InputError) as exc:
        parse_axis(name, text)
    assert exc.value.source == f"--{name}" and problem in exc.value.problem


def test_axes_multiply_the_grid_and_set_the_scenario_field(tmp_path):
    spec = make_spec(CASE1A, None, "nash,sumo", "1-2", axes={"latency": "0,0.2", "loss": "0.1"})
    assert spec.total == 2 * 2 * 2 * 1
    assert spec.axes == ["latency", "loss"]
    jobs = sweep_jobs(spec, tmp_path, spec.scenario_text)
    assert [j.run_id for j in jobs[:2]] == ["nash-seed1-latency_0.00-loss_0.10", "nash-seed1-latency_0.20-loss_0.10"]
    scn = job_scenario(Job.from_json(jobs[1].to_json()))
    assert (scn.v2x.latency, scn.v2x.loss, scn.v2x.enabled) == (0.2, 0.1, True)
    assert SweepSpec.from_dict(json.loads(json.dumps(spec.to_dict()))).identity() == spec.identity()
    plain = make_spec(CASE1A, None, "nash", "1")
    assert "axes" not in plain.to_dict() and plain.total == 1  # a sweep without axes is as before
    zero = job_scenario(sweep_jobs(make_spec(CASE1A, None, "nash", "1", axes={"loss": "0"}), tmp_path,
                                   plain.scenario_text)[0])
    assert not zero.v2x.enabled  # value 0 on every axis: today's perfect information


@pytest.mark.parametrize("command", ["sweep", "compare"])
def test_bad_axis_on_the_command_line_exits_2_with_nothing_on_disk(tmp_path, capsys, command):
    out = tmp_path / "out"
    assert main([command, str(CASE1A), "--loss", "0,2", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--loss" in err[0] and "'0,2'" in err[0]
    assert not out.exists()


@pytest.mark.slow
def test_compare_over_latency_writes_axis_columns_and_figures(tmp_path, capsys):
    out = tmp_path / "cmp"
    assert main(["compare", str(CASE1A), "--controllers", "nash", "--seeds", "1", "--latency", "0,0.3",
                 "--out", str(out), "--workers", "2", "--no-progress"]) == 0
    table = pd.read_csv(out / "comparison.csv")
    assert table["latency"].tolist() == [0.0, 0.3]
    assert (table["collisions"] == 0).all() and (table["arrived"] == table["vehicles"]).all()
    for metric in ("travel_time_mean", "ssm_share_under_thresholds", "collisions"):
        assert (out / "figures" / f"{metric}_vs_latency.png").stat().st_size > 10_000
    runs = sorted(p.name for p in (out / "case1_A" / "runs").iterdir())
    assert runs == ["nash-seed1-latency_0.00", "nash-seed1-latency_0.30"]
    summary = json.loads((out / "case1_A" / "runs" / runs[1] / "summary.json").read_text())
    assert summary["settings"]["v2x"]["latency"] == 0.3 and summary["v2x"]["messages_sent"] > 0
    assert json.loads((out / "case1_A" / SPEC_FILE).read_text())["axes"] == {"latency": [0.0, 0.3]}
    sweep = pd.read_csv(out / "case1_A" / "sweep.csv")
    assert sweep["v2x_messages_sent"].isna().tolist() == [True, False]  # latency 0: no link at all
