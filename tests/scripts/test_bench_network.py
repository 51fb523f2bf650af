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
