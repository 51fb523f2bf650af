"""A run past scenario.memory_limit ends early, with its outputs, and says so (experiments.memory_guard)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from intersection_cosim.experiments.memory_guard import MemoryGuard, peak_memory_gb
from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


def test_peak_memory_is_this_process_size_and_grows_with_what_it_holds():
    before = peak_memory_gb()
    assert 0.01 < before < 64.0  # [GB] a Python process with numpy and SUMO loaded
    size = before + 0.2  # [GB] more than the peak so far: the peak must grow past it
    block = np.ones(int(size * 1024 ** 3 // 8))  # touched
    assert peak_memory_gb() >= size
    del block


def test_the_guard_fires_only_past_its_limit_and_never_at_zero():
    peak = peak_memory_gb()
    assert MemoryGuard(peak + 10.0).check(1.0, None) is None
    assert MemoryGuard(0.0).check(1.0, None) is None
    end = MemoryGuard(peak / 2).check(3.5, None)
    assert end is not None and end.reason == "memory" and end.time == 3.5 and end.peak_gb > end.limit_gb


def test_the_guard_reads_the_peak_once_per_interval_of_simulated_time(monkeypatch):
    from intersection_cosim.experiments import memory_guard
    peaks = iter([1.0, 1.0, 3.0, 3.0])  # [GB] successive reads: the process grows past 2 GB
    reads = []

    def fake_peak():
        reads.append(1)
        return next(peaks)

    monkeypatch.setattr(memory_guard, "peak_memory_gb", fake_peak)
    guard = MemoryGuard(2.0, interval=1.0)
    ends = {round(0.1 * k, 1): guard.check(0.1 * k, None) for k in range(25)}  # 0.0 .. 2.4 s
    assert len(reads) == 3  # at 0.0, 1.0 and 2.0 s: not at every control step
    assert [t for t, end in ends.items() if end is not None] == [2.0]  # seen at the next read
    assert ends[2.0].peak_gb == 3.0


def test_a_run_over_its_memory_limit_ends_with_its_outputs_written(tmp_path):
    scn = load_scenario(SCENARIOS / "case1_A.toml")
    scn = dataclasses.replace(scn, scenario=dataclasses.replace(scn.scenario, memory_limit=0.001))
    summary = run_scenario(scn, tmp_path / "run")
    end = summary["ended_early"]
    assert end["reason"] == "memory" and end["limit_gb"] == 0.001 and end["time"] == pytest.approx(0.05)
    steps = pd.read_csv(tmp_path / "run" / "steps.csv")
    assert len(steps) == 1  # the first control step, then the end
    assert summary["counts"]["arrived"] == 0 and summary["counts"]["departed"] == 3
    assert json.loads((tmp_path / "run" / "summary.json").read_text())["ended_early"] == end
