"""scripts/bench_solo_batch.py: both ways solve the same problems, and it reports every size."""

from __future__ import annotations

import json

import numpy as np

from intersection_cosim.games.nash import solo_response, warm_list
from intersection_cosim.games.qp import reset_workspaces
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.games.solo_batch import SoloBatch
from intersection_cosim.models.settings import ModelSettings

from tests.scripts.script_module import load_script


def test_the_two_ways_it_times_give_the_same_plans():
    """The timed stacked batch and the one-by-one solves answer the same problems alike (to
    OSQP's tolerance: 1e-3 m/s^2), so the script compares like with like."""
    bench = load_script("bench_solo_batch")
    gs, ms = GameSettings(), ModelSettings()
    probs, warms = bench.problems(10, gs, seed=4)
    reset_workspaces()
    stacked = SoloBatch([p.players[0] for p in probs], gs, ms).solve([warm_list(w, 1)[0] for w in warms])
    reset_workspaces()
    single = [solo_response(p, gs, ms, warm_start=w, own_hessian=True) for p, w in zip(probs, warms)]
    for (plan, _cost, _res, _qps, failure), one in zip(stacked, single):
        assert failure is None
        np.testing.assert_allclose(plan.accelerations, one.plans[0].accelerations, atol=1e-3)


def test_it_prints_a_median_and_ratio_per_size(capsys):
    bench = load_script("bench_solo_batch")
    assert bench.main(["--rounds", "1", "--problems", "40"]) == 0
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert [r["size"] for r in out["rows"]] == list(bench.SIZES)
    for r in out["rows"]:
        assert r["batch_ms"] > 0 and r["one_by_one_ms"] > 0
        # the ratio of the unrounded times, which the printed ones (to 1 us) bound
        q = r["batch_ms"] / r["one_by_one_ms"]
        assert abs(r["ratio"] - q) <= q * (0.0005 / r["batch_ms"] + 0.0005 / r["one_by_one_ms"]) + 0.005
