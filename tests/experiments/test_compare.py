"""`intersection-cosim compare`: controllers x seeds on demand scenarios, the comparison table and figures."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from intersection_cosim.cli import main
from intersection_cosim.experiments.compare import AXIS_FIGURE_METRICS, COLUMNS, FIGURE_METRICS, make_specs, markdown_table
from intersection_cosim.experiments.sweep import sweep_jobs

ROOT = Path(__file__).resolve().parents[2]
LOW = str(ROOT / "scenarios" / "demand_balanced_low.toml")


def test_unknown_controller_is_one_line_before_any_run(tmp_path, capsys):
    out = tmp_path / "cmp"
    assert main(["compare", LOW, "--controllers", "fcfs,nope", "--seeds", "1", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--controllers" in err and "'nope'" in err
    assert not out.exists()


@pytest.mark.parametrize("argv", [["--seeds", "3-1"], ["--duration", "0"], ["--duration", "x"]])
def test_bad_seeds_or_duration_exit_2(tmp_path, capsys, argv):
    out = tmp_path / "cmp"
    with pytest.raises(SystemExit) as exc_info:
        code = main(["compare", LOW, "--controllers", "fcfs", "--out", str(out), *argv])
        raise SystemExit(code)
    assert exc_info.value.code == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert not out.exists()


def test_duration_override_is_part_of_the_spec():
    a, = make_specs([LOW], "fcfs", "1", 60.0)
    b, = make_specs([LOW], "fcfs", "1", None)
    assert a.overrides == (("duration", 60.0),) and b.overrides == ()
    assert a.identity() != b.identity()
    assert all(j.overrides == (("duration", 60.0),) for j in sweep_jobs(a, Path("/tmp/x"), a.scenario_text))


def test_markdown_table():
    text = markdown_table(pd.DataFrame({"a": ["x"], "b": [1.23456], "c": [float("nan")]}))
    assert text.splitlines() == ["| a | b | c |", "|---|---|---|", "| x | 1.23 |  |"]


@pytest.mark.slow
def test_compare_low_demand_and_rerun(tmp_path, capsys):
    out = tmp_path / "cmp"
    argv = ["compare", LOW, "--duration", "60", "--budget-ms", "20", "--work-clock", "0.5", "--controllers", "fcfs,sumo-priority",
            "--seeds", "1", "--out", str(out), "--workers", "2", "--no-progress"]
    assert main(argv) == 0
    table = pd.read_csv(out / "comparison.csv")
    assert list(table.columns) == COLUMNS
    assert list(table["controller"]) == ["fcfs", "sumo-priority"]
    assert (table["runs_ok"] == 1).all()
    assert (table["throughput_veh_h"] > 0).all()
    assert (table["collisions"] == 0).all() and (table["late_or_stuck"] == 0).all()
    assert (table["ended_early"] == 0).all()
    assert table["demand_veh_h"].tolist() == pytest.approx([600.0, 600.0])
    assert table["travel_time_mean"].notna().all() and table["compute_ms_median"].notna().all()
    assert sorted(p.name for p in (out / "figures").iterdir()) == ["overview.png"]  # one demand level
    report = (out / "report.md").read_text()
    assert "| demand_balanced_low | 600 | fcfs |" in report
    summary = out / "demand_balanced_low" / "runs" / "fcfs-seed1" / "summary.json"
    mtime = summary.stat().st_mtime_ns
    settings = json.loads(summary.read_text())["settings"]
    assert settings["controller"]["budget_ms"] == 20.0 and settings["scenario"]["duration"] == 60.0
    assert settings["controller"]["work_clock_ms"] == 0.5
    capsys.readouterr()

    assert main(argv) == 0  # rerun: both runs skipped, table rebuilt
    assert "(2 already before)" in capsys.readouterr().out
    assert summary.stat().st_mtime_ns == mtime
    pd.testing.assert_frame_equal(pd.read_csv(out / "comparison.csv"), table)

    # another duration into the same folder is refused, one line, exit 2
    assert main([*argv[:3], "30", *argv[4:]]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "overrides" in err


def test_controller_is_accepted_as_the_old_spelling_of_controllers(tmp_path, capsys):
    out = tmp_path / "cmp"
    assert main(["compare", LOW, "--controller", "fcfs,nope", "--seeds", "1", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "unknown controller 'nope'" in err
    assert not out.exists()


def test_runs_without_the_ssm_device_leave_the_ssm_columns_empty_not_zero(tmp_path):
    """demand_balanced_low with [scenario] ssm = false, 30 s: no ssm.xml in the run, and the
    comparison's SSM columns are empty (not measured), not 0 encounters."""
    text = Path(LOW).read_text().replace("[scenario]\n", "[scenario]\nssm = false\n", 1)
    assert "ssm = false" in text
    scenario = tmp_path / "demand_balanced_low.toml"
    scenario.write_text(text)
    out = tmp_path / "cmp"
    assert main(["compare", str(scenario), "--duration", "30", "--controllers", "sumo-priority", "--seeds", "1",
                 "--out", str(out), "--workers", "1", "--no-progress"]) == 0
    table = pd.read_csv(out / "comparison.csv")
    assert table["vehicles"].iloc[0] > 0 and table["collisions"].iloc[0] == 0
    assert table[["ssm_encounters", "ssm_min_ttc", "ssm_min_pet", "ssm_share_under_thresholds"]].isna().all().all()
    assert not list(out.rglob("ssm.xml"))


def test_a_negative_time_loss_is_explained_under_the_table(tmp_path):
    """SUMO's time loss counts against the lanes' limits: below zero, the vehicles were too fast."""
    from intersection_cosim.experiments.compare import write_report

    row = {c: 0.0 for c in COLUMNS}
    rows = [dict(row, scenario="fokr38", controller="nash", time_loss_mean=-2.0),
            dict(row, scenario="fokr38", controller="sumo-priority", time_loss_mean=0.8)]
    text = write_report(tmp_path, pd.DataFrame(rows, columns=COLUMNS), []).read_text()
    assert "Negative mean time loss (nash (fokr38))" in text and "lane_speed_limits = true" in text
    rows[0]["time_loss_mean"] = 0.1
    assert "Negative mean time loss" not in write_report(tmp_path, pd.DataFrame(rows, columns=COLUMNS), []).read_text()


def _table(demands: list[float], latencies: list[float]) -> pd.DataFrame:
    rows = [{**{c: 1.0 for c in COLUMNS}, "scenario": f"s{d:g}", "demand_veh_h": d, "controller": k, "latency": lat,
             "travel_time_mean": 10.0 + d / 100 + lat}
            for d in demands for k in ("nash", "sumo-priority") for lat in latencies]
    return pd.DataFrame(rows)


@pytest.mark.parametrize("demands, latencies, expected", [
    ([600.0], [0.0], ["overview.png"]),
    ([600.0, 1200.0], [0.0], ["overview.png", *(f"{m}_vs_demand.png" for m in FIGURE_METRICS)]),
    ([600.0], [0.0, 0.2], ["overview.png", *(f"{m}_vs_latency.png" for m in AXIS_FIGURE_METRICS)]),
])
def test_compare_draws_an_overview_and_only_the_figures_with_an_axis_to_show(tmp_path, demands, latencies, expected):
    from intersection_cosim.experiments.compare import draw_figures

    (tmp_path / "figures").mkdir()
    (tmp_path / "figures" / "travel_time_mean_vs_demand.png").write_bytes(b"an earlier call's")
    axes = ["latency"] if len(latencies) > 1 else []
    table = _table(demands, latencies).drop(columns=[] if axes else ["latency"])
    drawn = draw_figures(tmp_path, table, axes)
    assert sorted(p.name for p in drawn) == sorted(expected)
    assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == sorted(expected)
