"""`report` on a sweep and on a run folder: every figure, report.md, best and worst runs."""

from __future__ import annotations

import shutil

import numpy as np
import pandas as pd
import pytest

from intersection_cosim.cli import main
from intersection_cosim.report import solver_figures, sweep_figures
from intersection_cosim.report.reporting import best_and_worst
from sweep_helpers import read_table

PNG = b"\x89PNG\r\n\x1a\n"
METRICS = ("mean_travel_time", "min_ttc", "min_ttc_ssm", "collisions")


def _is_png(path) -> bool:
    return path.is_file() and path.stat().st_size > 2000 and path.read_bytes()[:8] == PNG


@pytest.mark.slow
def test_sweep_report(reference_sweep, tmp_path, capsys):
    folder = tmp_path / "sweep"
    shutil.copytree(reference_sweep, folder)
    assert main(["report", str(folder)]) == 0
    assert capsys.readouterr().out.strip() == str(folder / "report.md")
    figs = folder / "figures"
    expected = ([f"heatmap_{m}_kappa_V1_kappa_V2.png" for m in METRICS]
                + [f"lines_{m}_vs_kappa_{v}.png" for m in METRICS for v in ("V1", "V2")]
                + ["compute_time_hist.png"])
    assert sorted(p.name for p in figs.iterdir()) == sorted(expected)
    assert all(_is_png(figs / name) for name in expected)
    report = (folder / "report.md").read_text()
    for name in expected:
        assert f"(figures/{name})" in report
    # Best and worst by mean travel time and by min TTC, named as the table says.
    table = read_table(folder)
    best_tt = table.loc[table["mean_travel_time"].idxmin(), "run_id"]
    worst_tt = table.loc[table["mean_travel_time"].idxmax(), "run_id"]
    best_ttc = table.loc[table["min_ttc"].idxmax(), "run_id"]
    worst_ttc = table.loc[table["min_ttc"].idxmin(), "run_id"]
    tt_line = next(line for line in report.splitlines() if line.startswith("| mean travel time"))
    ttc_line = next(line for line in report.splitlines() if line.startswith("| min TTC (ours)"))
    assert f"`{best_tt}`" in tt_line and f"`{worst_tt}`" in tt_line
    assert f"`{best_ttc}`" in ttc_line and f"`{worst_ttc}`" in ttc_line
    # The summary table lists every run.
    for run_id in table["run_id"]:
        assert f"| {run_id} |" in report


@pytest.mark.slow
def test_run_report(reference_sweep, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(next((reference_sweep / "runs").iterdir()), run)
    assert main(["report", str(run)]) == 0
    for name in ("trajectory.png", "velocity.png", "compute_time_hist.png"):
        assert _is_png(run / "figures" / name)
        assert f"(figures/{name})" in (run / "report.md").read_text()
    report = (run / "report.md").read_text()
    assert "| V1 |" in report and "| min TTC, ours [s] |" in report


def test_report_of_a_folder_that_is_neither_run_nor_sweep(tmp_path, capsys):
    assert main(["report", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "neither a run folder" in err
    assert list(tmp_path.iterdir()) == []


def _synthetic_table() -> pd.DataFrame:
    rows = []
    for c, bias in (("nash", 0.0), ("sumo", 2.0)):
        for seed in (1, 2):
            for k1 in (0.2, 0.5, 0.8):
                for k2 in (0.3, 0.6):
                    rows.append({"run_id": f"{c}-seed{seed}-V1_{k1:.2f}-V2_{k2:.2f}", "controller": c, "seed": seed,
                                 "kappa_V1": k1, "kappa_V2": k2, "mean_travel_time": 10 + bias + 3 * k1 - k2 + seed,
                                 "min_ttc": 1 + k2 - k1 / 2 + bias / 10, "status": "ok"})
    rows.append({"run_id": "nash-seed3-V1_0.20-V2_0.30", "controller": "nash", "seed": 3, "kappa_V1": 0.2,
                 "kappa_V2": 0.3, "mean_travel_time": np.nan, "min_ttc": np.nan, "status": "failed"})
    return pd.DataFrame(rows)


def test_best_and_worst():
    table = _synthetic_table()
    best, worst = best_and_worst(table, "mean_travel_time", higher_is_better=False)
    assert best["run_id"] == "nash-seed1-V1_0.20-V2_0.60" and best["mean_travel_time"] == pytest.approx(11.0)
    assert worst["run_id"] == "sumo-seed2-V1_0.80-V2_0.30"
    best, worst = best_and_worst(table, "min_ttc", higher_is_better=True)
    assert best["run_id"] == "sumo-seed1-V1_0.20-V2_0.60"
    assert worst["run_id"] == "nash-seed1-V1_0.80-V2_0.30"
    assert best_and_worst(table[table["status"] == "failed"], "min_ttc", True) is None


def test_sweep_figures_with_two_controllers(tmp_path):
    table = _synthetic_table()
    sweep_figures.kappa_heatmap(table, "mean_travel_time", "kappa_V1", "kappa_V2", tmp_path / "h.png")
    sweep_figures.kappa_lines(table, "min_ttc", "kappa_V1", tmp_path / "l.png")
    solver_figures.compute_time_histogram({"nash": np.array([1.0, 2.0, 50.0]), "sumo": np.array([0.001, 0.002])},
                                   tmp_path / "c.png", budget_ms=100.0)
    solver_figures.compute_time_histogram({}, tmp_path / "empty.png")
    assert all(_is_png(tmp_path / n) for n in ("h.png", "l.png", "c.png", "empty.png"))
