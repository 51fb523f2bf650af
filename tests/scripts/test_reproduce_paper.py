"""scripts/reproduce_paper.py: when a run folder may be reused, and a bad --out."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.scripts.script_module import load_script

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "reproduce_paper.py"


@pytest.fixture(scope="module")
def rp():
    return load_script("reproduce_paper")


VERSIONS = {"intersection_cosim": "1.2.3", "sumo": "1.20.0", "python": "3.11.9"}


def _folder(tmp_path: Path, settings: dict, versions: dict) -> Path:
    run = tmp_path / "case1_A-nash-etm"
    run.mkdir()
    (run / "summary.json").write_text(json.dumps({"settings": settings, "versions": versions, "counts": {}}))
    return run


def test_a_run_with_the_same_settings_and_versions_is_reused(rp, tmp_path):
    settings = rp.run_settings("case1_A", "nash", True, 2000.0)
    assert settings["controller"]["budget_ms"] == 2000.0 and settings["controller"]["kind"] == "nash"
    assert settings["controller"]["etm"] is True and settings["controller_settings"]["solver"]["nash_tol"] == 1e-2
    run = _folder(tmp_path, settings, VERSIONS)
    assert rp.rerun_reason(run, settings, VERSIONS) is None
    assert rp.rerun_reason(run, settings, {**VERSIONS, "python": "3.12.1"}) is None  # only the package and SUMO


def test_a_2000_ms_folder_is_rerun_for_a_100_ms_report(rp, tmp_path):
    run = _folder(tmp_path, rp.run_settings("case1_A", "nash", True, 2000.0), VERSIONS)
    reason = rp.rerun_reason(run, rp.run_settings("case1_A", "nash", True, 100.0), VERSIONS)
    assert reason == "settings differ: controller.budget_ms 2000.0 -> 100.0"


def test_other_trigger_model_or_versions_are_rerun(rp, tmp_path):
    settings = rp.run_settings("case1_A", "nash", True, 2000.0)
    run = _folder(tmp_path, settings, VERSIONS)
    assert rp.rerun_reason(run, rp.run_settings("case1_A", "nash", False, 2000.0), VERSIONS) == \
        "settings differ: controller.etm True -> False"
    assert rp.rerun_reason(run, rp.run_settings("case1_B", "nash", True, 2000.0), VERSIONS).startswith(
        "settings differ: scenario.name case1_A -> case1_B")
    assert rp.rerun_reason(run, settings, {**VERSIONS, "intersection_cosim": "1.2.4"}) == \
        "made by intersection_cosim 1.2.3, this is 1.2.4"
    old = json.loads((run / "summary.json").read_text())
    del old["settings"]["model"]["k_lat"]  # a folder of a version before the field existed
    (run / "summary.json").write_text(json.dumps(old))
    assert "model.k_lat (none) -> 5.0" in rp.rerun_reason(run, settings, VERSIONS)
    (run / "summary.json").write_text("{not json")
    assert rp.rerun_reason(run, settings, VERSIONS) == "unreadable summary.json"
    assert rp.rerun_reason(tmp_path / "absent", settings, VERSIONS) == "no finished run"


@pytest.mark.parametrize("where", ["file", "under a file"])
def test_bad_out_is_one_line_exit_2_and_writes_nothing(tmp_path, where):
    target = tmp_path / "notes.txt"
    target.write_text("mine")
    out = target if where == "file" else target / "report"
    proc = subprocess.run([sys.executable, str(SCRIPT), "--out", str(out)], capture_output=True, text=True,
                          cwd=tmp_path, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("reproduce_paper: --out: out = ")
    assert str(out) in proc.stderr and "is a file" in proc.stderr and "Traceback" not in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"] and target.read_text() == "mine"


def test_the_convergence_figure_reads_the_tolerance_from_the_run_else_the_defaults(rp, tmp_path):
    from intersection_cosim.games.settings import SolverSettings

    runs = rp.Runs(tmp_path)
    assert rp.stopping_rule(runs, "case1_A", "nash") == {"tol": SolverSettings().nash_tol, "guard": 0.3, "rtol": 1e-3}
    run = runs.dir("case1_A", "stackelberg")
    run.mkdir(parents=True)
    recorded = {"controller_settings": {"solver": {"stackelberg_tol": 0.005, "nash_cost_guard": 0.2}}}
    (run / "summary.json").write_text(json.dumps({"settings": recorded}))
    assert rp.stopping_rule(runs, "case1_A", "stackelberg") == {"tol": 0.005, "guard": 0.2, "rtol": 1e-3}


def _steps(runs, case: str, ctrl: str, etm: bool, compute_ms: list[float], games: list[int]) -> None:
    run = runs.dir(case, ctrl, etm)
    run.mkdir(parents=True)
    n = len(compute_ms)
    import pandas as pd

    pd.DataFrame({"time": [0.05 + 0.1 * i for i in range(n)], "compute_ms": compute_ms, "games": games,
                  "qp_solves": [2 * g + 1 for g in games]}).to_csv(run / "steps.csv", index=False)


def _etm_runs(rp, tmp_path):
    """case1_A: the trigger fires for every game; case2_A: it leaves half out, NE cuts 50 %, SE 20 %;
    every run's first step (the warm-up) takes 100 ms."""
    runs = rp.Runs(tmp_path)
    for ctrl in ("nash", "stackelberg"):
        _steps(runs, "case1_A", ctrl, True, [100.0, 2.0, 2.0, 2.0, 2.0], [1, 1, 1, 1, 1])
        _steps(runs, "case1_A", ctrl, False, [100.0, 2.0, 2.0, 2.0, 2.0], [1, 1, 1, 1, 1])
        _steps(runs, "case2_A", ctrl, False, [100.0, 4.0, 4.0, 4.0, 4.0], [2, 2, 2, 2, 2])
    _steps(runs, "case2_A", "nash", True, [100.0, 2.0, 2.0, 2.0, 2.0], [1, 1, 1, 1, 1])
    _steps(runs, "case2_A", "stackelberg", True, [100.0, 3.2, 3.2, 3.2, 3.2], [1, 1, 1, 1, 1])
    return runs


def test_check_9_is_measured_where_the_trigger_has_games_to_leave_out_else_not_applicable(rp, tmp_path):
    runs = _etm_runs(rp, tmp_path)
    nine = rp.orderings(runs, rp.QUICK, []).query("check == 9")
    nine = nine.set_index([nine["solver"], nine["description"].str[:7]])
    assert list(nine["holds"]) == ["n/a", "n/a", True, False]
    for (solver, case), row in nine.iterrows():
        if case == "case1_A":  # the trigger left nothing out: the reason, not a verdict
            assert row["values"].startswith("not applicable: the trigger fired for 4 of the 4 games")
        else:
            assert "games 4 vs 8 (left out 50%)" in row["values"]
    assert "cut 50.0%" in nine.loc[("NE", "case2_A"), "values"] and "cut 20.0%" in nine.loc[("SE", "case2_A"), "values"]


def test_the_checks_and_the_compute_time_figure_give_one_mean_without_the_warm_up(rp, tmp_path, monkeypatch):
    runs = _etm_runs(rp, tmp_path)
    drawn = {}

    def capture(ax, samples, styles=None, extra=None):
        drawn.update({(ax.get_title() or str(len(drawn)), k): float(v.mean()) for k, v in samples.items()})
        return {}

    monkeypatch.setattr(rp, "draw_ecdf", capture)
    rp.compute_time_figure(runs, rp.QUICK, tmp_path / "compute_time.png")
    assert sorted(set(drawn.values())) == [2.0, 3.2, 4.0]  # [ms] the 100 ms warm-up left out
    values = " ".join(rp.orderings(runs, rp.QUICK, []).query("check == 9")["values"])
    assert "compute per step 2.00 ms with the ETM, 4.00 ms without" in values
    assert "compute per step 3.20 ms with the ETM, 4.00 ms without" in values and "100" not in values


def test_the_runs_show_a_progress_bar_with_the_time_left(rp, tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(rp, "play", lambda out, case, ctrl, etm, *rest: (rp.run_name(case, ctrl, etm), "ran", None))
    assert rp.play_all(tmp_path, ["case1_A"], 1, 2000.0) == {}
    captured = capsys.readouterr()
    assert captured.out.count(": ran\n") == 4
    bar = captured.err.replace("\r", "\n").splitlines()[-1]
    assert "4/4" in bar and "<" in bar  # tqdm: done/total [elapsed<left]


def test_every_table_the_report_writes_declares_its_units(rp, tmp_path):
    from intersection_cosim.results.units import units_table
    from tests.results.test_units import assert_declared

    runs = _etm_runs(rp, tmp_path)
    tables = {"table_ii.csv": rp.ttc_table(runs, rp.SCENARIOS, "case1"), "table_iv.csv": rp.ttc_table(runs, rp.SCENARIOS, "case2"),
              "ratios.csv": rp.ratio_table(runs, rp.SCENARIOS), "travel_times.csv": rp.travel_times(runs, rp.SCENARIOS),
              "orderings.csv": rp.orderings(runs, rp.QUICK, [])}
    assert_declared(units_table({name: df.columns for name, df in tables.items()}))
