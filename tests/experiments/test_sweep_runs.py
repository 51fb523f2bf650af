"""Sweeps of real SUMO runs: the table, reruns, SIGKILL + rerun, failed runs, a crashed run process."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pandas as pd
import pytest

from intersection_cosim.cli import main
from intersection_cosim.experiments.executors import execute_job
from intersection_cosim.experiments.sweep import make_spec, sweep_jobs
from intersection_cosim.results.layout import FAILED_DIR, RUNS_DIR, SPEC_FILE
from sweep_helpers import (CASE1A, GRID_RUNS, comparable, group_alive, read_table, run_children, sweep_args,
                           wait_for_a_finished_run)

pytestmark = pytest.mark.slow

RUN_IDS = ["sumo-seed1-V1_0.30-V2_0.20", "sumo-seed1-V1_0.30-V2_0.50",
           "sumo-seed1-V1_0.70-V2_0.20", "sumo-seed1-V1_0.70-V2_0.50"]


def test_sweep_table(reference_sweep):
    table = read_table(reference_sweep)
    assert list(table["run_id"]) == RUN_IDS  # grid order
    assert list(table.columns[:5]) == ["run_id", "controller", "seed", "kappa_V1", "kappa_V2"]
    assert list(table.columns[-2:]) == ["status", "error"]
    for col in ["travel_time_V1", "travel_time_V2", "travel_time_V3", "mean_travel_time",
                "min_ttc_V1_V2", "min_ttc_ssm_V1_V2", "pet_V1_V2", "min_ttc_V1_V3", "min_ttc_ssm_V1_V3",
                "pet_V1_V3", "min_ttc", "min_ttc_ssm", "min_pet", "collisions", "compute_ms_median",
                "compute_ms_p95", "deadline_misses"]:
        assert col in table, col
    assert (table["status"] == "ok").all()
    for run_id in RUN_IDS:  # a sweep's trajectories gzip-compressed: most of a run folder's bytes
        files = {p.name for p in (reference_sweep / RUNS_DIR / run_id).iterdir()}
        assert "trajectories.csv.gz" in files and "trajectories.csv" not in files
    assert list(table["kappa_V1"]) == [0.3, 0.3, 0.7, 0.7]
    assert list(table["kappa_V2"]) == [0.2, 0.5, 0.2, 0.5]
    # The values are the run folders' own.
    run = reference_sweep / RUNS_DIR / RUN_IDS[2]
    vehicles = pd.read_csv(run / "vehicles.csv").set_index("vehicle")
    summary = json.loads((run / "summary.json").read_text())
    row = table.iloc[2]
    assert row["travel_time_V2"] == pytest.approx(vehicles.loc["V2", "travel_time"])
    assert row["mean_travel_time"] == pytest.approx(summary["metrics"]["mean_travel_time"], rel=1e-5)
    assert row["min_ttc"] == pytest.approx(summary["metrics"]["min_ttc"], rel=1e-5)
    assert vehicles.loc["V1", "kappa"] == 0.7 and vehicles.loc["V2", "kappa"] == 0.2  # the override reached the run
    assert vehicles.loc["V3", "kappa"] == 0.5  # not swept: the scenario's
    assert summary["seed"] == 1 and summary["controller"] == "sumo"
    assert not [p for p in (reference_sweep / RUNS_DIR).iterdir() if p.name.startswith(".")]


def test_rerun_skips_finished_runs(reference_sweep, tmp_path, capsys):
    before = {p.name: (p / "summary.json").stat().st_mtime_ns for p in (reference_sweep / RUNS_DIR).iterdir()}
    t0 = time.monotonic()
    assert main(sweep_args(reference_sweep, "--workers", "2")) == 0
    assert time.monotonic() - t0 < 10
    assert f"{GRID_RUNS}/{GRID_RUNS} runs finished ({GRID_RUNS} already before)" in capsys.readouterr().out
    after = {p.name: (p / "summary.json").stat().st_mtime_ns for p in (reference_sweep / RUNS_DIR).iterdir()}
    assert after == before


def test_sigkill_then_rerun_equals_uninterrupted(reference_sweep, tmp_path):
    out = tmp_path / "sweep"
    cmd = [sys.executable, "-m", "intersection_cosim", *sweep_args(out, "--workers", "2")]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        wait_for_a_finished_run(out, proc)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    deadline = time.monotonic() + 10
    while group_alive(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert group_alive(proc.pid) == []  # the runs died with the sweep
    finished = len([p for p in out.glob(f"{RUNS_DIR}/*/summary.json") if not p.parent.name.startswith(".")])
    assert 1 <= finished < GRID_RUNS  # killed part-way

    assert main(sweep_args(out, "--workers", "2")) == 0
    table = read_table(out)
    assert sorted(table["run_id"]) == sorted(RUN_IDS) and table["run_id"].is_unique
    pd.testing.assert_frame_equal(comparable(table), comparable(read_table(reference_sweep)))
    assert not [p for p in (out / RUNS_DIR).iterdir() if p.name.startswith(".")]  # killed runs' temp folders gone
    assert sorted(p.name for p in (out / RUNS_DIR).iterdir()) == RUN_IDS


def test_failed_run_is_recorded_and_does_not_stop_the_sweep(tmp_path, capsys):
    out = tmp_path / "sweep"
    spec = make_spec(CASE1A, ["V1=0.3,0.7"], "sumo", "1")
    out.mkdir()
    (out / SPEC_FILE).write_text(json.dumps(spec.to_dict()))
    blocked = out / RUNS_DIR / "sumo-seed1-V1_0.30"  # a folder that is not a run: that run cannot write
    blocked.mkdir(parents=True)
    (blocked / "notes.txt").write_text("not a run")
    args = ["sweep", CASE1A, "--kappa", "V1=0.3,0.7", "--seeds", "1", "--controllers", "sumo", "--out", str(out),
            "--no-progress", "--workers", "2"]
    assert main(args) == 1  # finished, with a failure
    captured = capsys.readouterr()
    assert "run sumo-seed1-V1_0.30 failed:" in captured.err and "not overwriting" in captured.err
    assert "1/2 runs finished, 1 failed" in captured.out
    table = read_table(out)
    assert list(table["status"]) == ["failed", "ok"]
    assert "not overwriting" in table.loc[0, "error"] and pd.isna(table.loc[0, "mean_travel_time"])
    record = json.loads((out / FAILED_DIR / "sumo-seed1-V1_0.30.json").read_text())
    assert "not overwriting" in record["error"] and "Traceback" in record["detail"]

    (blocked / "notes.txt").unlink()  # fixed: the rerun retries the failed run only
    assert main(args) == 0
    assert list(read_table(out)["status"]) == ["ok", "ok"]
    assert not (out / FAILED_DIR / "sumo-seed1-V1_0.30.json").exists()


def test_a_crashed_run_process_fails_only_its_run(tmp_path):
    spec = make_spec(CASE1A, ["V1=0.4"], "sumo", "1")
    (job,) = sweep_jobs(spec, tmp_path, spec.scenario_text)
    (tmp_path / RUNS_DIR).mkdir()
    result = {}
    thread = threading.Thread(target=lambda: result.update(execute_job(job)))
    thread.start()
    deadline = time.monotonic() + 30
    while not run_children() and time.monotonic() < deadline:
        time.sleep(0.02)
    time.sleep(0.3)
    for child in run_children():
        child.send_signal(signal.SIGKILL)  # as a segfault in SUMO would
    thread.join(30)
    assert result["status"] == "failed" and "SIGKILL" in result["error"]
    record = json.loads(Path(job.failed_file).read_text())
    assert "SIGKILL" in record["error"]
    assert not job.finished
    assert run_children() == []


def test_ctrl_c_stops_cleanly_and_keeps_finished_runs(tmp_path):
    out = tmp_path / "sweep"
    # 17 game runs of about a second each: the sweep is still running when Ctrl-C comes (with 9
    # runs of SUMO's fast baseline it could finish first)
    cmd = [sys.executable, "-m", "intersection_cosim", "sweep", CASE1A, "--kappa", "V1=0.1:0.9:0.05", "--seeds", "1",
           "--controllers", "nash", "--out", str(out), "--workers", "2"]
    # Ctrl-C as in a terminal: a test run started in the background of a non-interactive shell
    # inherits SIGINT ignored, and Python then installs no KeyboardInterrupt handler
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        wait_for_a_finished_run(out, proc)
        os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C in a terminal does
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130
    last = err.replace("\r", "\n").strip().splitlines()[-1]
    assert last.startswith("intersection-cosim: interrupted:") and "runs finished and kept" in last
    assert "Traceback" not in err
    assert group_alive(proc.pid) == []
    finished = sorted(p.parent.name for p in out.glob(f"{RUNS_DIR}/*/summary.json"))
    assert 1 <= len(finished) < 17
    table = read_table(out)
    assert sorted(table["run_id"]) == finished and (table["status"] == "ok").all()
    assert not [p for p in (out / RUNS_DIR).iterdir() if p.name.startswith(".")]  # interrupted runs cleaned up
