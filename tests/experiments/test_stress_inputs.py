"""Bad input to ``intersection-cosim stress``: one line, exit 2, nothing on disk; and the report's
bins of a parameter range."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from intersection_cosim.cli import main
from intersection_cosim.report.stress_figures import bin_counts

SCENARIO = str(Path(__file__).resolve().parents[2] / "scenarios" / "demand_balanced_high.toml")


@pytest.mark.parametrize("args, says", [
    (["--runs", "2", "--set", "controller.safety.nope=1"], "--set: controller.safety.nope = 1: unknown key"),
    (["--runs", "2", "--set", "stress.loss=[0.3, 0.1]"], "low 0.3 is above high 0.1"),
    (["--runs", "2", "--set", "stress.burst_scale=3"], "must be [low, high]"),
])
def test_bad_input_is_one_line_exit_2_and_nothing_on_disk(tmp_path, capsys, args, says):
    out = tmp_path / "D"
    assert main(["stress", SCENARIO, "--out", str(out), *args]) == 2
    err = capsys.readouterr().err
    assert says in err and err.count("\n") == 1
    assert not out.exists()


@pytest.mark.parametrize("args", [["--runs", "0"], ["--runs", "2", "--search", "bayes"]])
def test_bad_options_exit_2_before_anything_is_written(tmp_path, args):
    with pytest.raises(SystemExit) as exc:
        main(["stress", SCENARIO, "--out", str(tmp_path / "D"), *args])
    assert exc.value.code == 2
    assert not (tmp_path / "D").exists()


def test_bins_count_runs_and_failures_over_the_range():
    values = pd.Series([0.0, 0.1, 0.5, 0.99, 1.0])
    failed = pd.Series([True, False, True, False, True])
    runs, fails = bin_counts(values, failed, 0.0, 1.0, bins=2)
    assert runs.tolist() == [2, 3] and fails.tolist() == [1, 2]
    runs, fails = bin_counts(values, failed, 0.5, 0.5, bins=5)  # a range of zero width: one bin
    assert np.array_equal(runs, [5]) and fails.tolist() == [3]
