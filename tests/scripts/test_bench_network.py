"""scripts/bench_network.py: the ideal parallel split, and one short measured run of the corridor."""

from __future__ import annotations

import numpy as np
import pytest

from tests.scripts.script_module import load_script


def test_largest_first_split_puts_the_biggest_loads_on_different_workers():
    bn = load_script("bench_network")
    assert bn.largest_first(np.array([5.0, 4.0, 3.0, 3.0]), 2) == 8.0  # (5 + 3, 4 + 3)
    assert bn.largest_first(np.array([5.0, 4.0, 3.0, 3.0]), 1) == 15.0
    assert bn.largest_first(np.array([9.0, 1.0, 1.0]), 2) == 9.0


@pytest.mark.slow
def test_corridor_runs_both_controllers_and_counts_skipped_junction_steps(tmp_path, capsys):
    """5 s of the corridor: both controllers ran, the corridor's three junctions had steps with
    nothing to decide at the start (skipped)."""
    bn = load_script("bench_network")
    result = bn.main([str(bn.DEFAULTS[1]), "--duration", "5", "--drain", "0", "--budget-ms", "2000"])
    (r,) = result["results"]
    assert r["junctions"] == 3 and r["steps"] == 50
    assert 0.0 < r["skipped_share"] < 1.0
    assert r["wall_ratio"] > 0 and r["cpu_ratio"] > 0
    assert [len(v) for v in r["runs"].values()] == [1, 1]


def test_the_report_has_one_row_per_scenario_with_its_ratios_and_counts(tmp_path):
    bn = load_script("bench_network")
    row = {"scenario": "/x/grid_high.toml", "junctions": 9, "controller_wall_s": 200.0, "sumo_wall_s": 80.0,
           "wall_ratio": 2.5, "cpu_ratio": 2.4, "loop_ratio": 2.8, "step_ms_median": 20.0, "step_ms_p95": 30.0,
           "skipped_share": 0.05, "parallel_ideal": 1.9, "collisions": [0, 14], "arrived": [983, 929]}
    result = {"controller": "nash", "workers": 2, "repeats": 1,
              "results": [row, {**row, "scenario": "/x/corridor_medium.toml", "junctions": 3, "wall_ratio": 3.2}]}
    text = bn.write_report(tmp_path / "r", result).read_text()
    rows = [line for line in text.splitlines() if line.startswith("| grid_high") or line.startswith("| corridor")]
    assert [r.split(" | ")[0] for r in rows] == ["| grid_high", "| corridor_medium"]
    assert "| 2.50 |" in rows[0] and "| 3.20 |" in rows[1] and "5.0%" in rows[0] and "0 / 14" in rows[0]
    assert (tmp_path / "r" / "bench_network.json").is_file()
