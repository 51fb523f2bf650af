"""Solo best responses: the stacked batch against one vehicle at a time, by batch size.

``games.solo_batch`` solves the solo vehicles of a control step as stacked arrays, except that a
batch of fewer than ``SMALL_BATCH`` problems goes to ``solo_response`` one by one (with the
batch's own-Hessian rule). This script times both ways on the same random solo problems (a
vehicle at a random state, most behind a leader at constant speed, most warm-started), for
several batch sizes, in alternating rounds of the same run, and prints per size the median wall
time per batch of each way and their ratio (batch / one by one: above 1, one by one is faster).

    python scripts/bench_solo_batch.py [--rounds 7] [--problems 300]

At 1800 veh/h (demand_balanced_high, Nash, seed 1) 96 % of the solo batches have at most five problems.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time

import numpy as np

from intersection_cosim.games.nash import solo_response, warm_list
from intersection_cosim.games.problem import Plan, Player, Problem
from intersection_cosim.games.qp import reset_workspaces
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.games.solo_batch import SMALL_BATCH, SoloBatch
from intersection_cosim.models.settings import ModelSettings

SIZES = (1, 2, 3, 4, 5, 6, 8, 12, 20)


def problems(count: int, gs: GameSettings, seed: int = 3):
    """Random solo problems and warm starts (80 % warm, 70 % behind a leader)."""
    n, dt = gs.problem.steps, gs.problem.dt
    rng = np.random.default_rng(seed)
    out, warms = [], []
    for i in range(count):
        s0, v0, kappa = rng.uniform(-60.0, 0.0), rng.uniform(0.0, 12.0), rng.uniform(0.1, 0.9)  # [m], [m/s], [-]
        leader = None
        if rng.random() < 0.7:
            v_l = np.full(n, rng.uniform(0.0, 10.0))  # [m/s]
            leader = (s0 + rng.uniform(3.0, 40.0) + np.cumsum(v_l) * dt, v_l)  # [m] its front, 3-40 m ahead
        out.append(Problem((Player(s0, v0, kappa, leader=leader, name=f"v{i}"),)))
        warm = Plan.from_accelerations(s0, v0, rng.uniform(-2.0, 2.0, n), dt)
        warms.append(None if rng.random() < 0.2 else (warm,))
    return out, warms


def time_batches(size: int, probs, warms, gs, ms, stacked: bool) -> float:
    """[s] median wall time per batch of ``size`` problems over the problem list."""
    times = []
    for i in range(0, len(probs) - size + 1, size):
        chunk, w = probs[i:i + size], warms[i:i + size]
        t0 = time.perf_counter()
        if stacked:
            SoloBatch([p.players[0] for p in chunk], gs, ms).solve([warm_list(x, 1)[0] for x in w])
        else:
            for p, x in zip(chunk, w):
                solo_response(p, gs, ms, warm_start=x, own_hessian=True)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7, help="alternating rounds of both ways")
    ap.add_argument("--problems", type=int, default=300, help="random solo problems per round")
    args = ap.parse_args(argv)
    gs, ms = GameSettings(), ModelSettings()
    gs = dataclasses.replace(gs, solver=dataclasses.replace(gs.solver, nash_max_iter=1))  # solo_max_iter's default
    probs, warms = problems(args.problems, gs)
    rows = []
    for size in SIZES:
        batch, single = [], []
        for r in range(args.rounds):
            for stacked in ((True, False) if r % 2 == 0 else (False, True)):
                reset_workspaces()
                (batch if stacked else single).append(time_batches(size, probs, warms, gs, ms, stacked))
        b, s = float(np.median(batch)) * 1e3, float(np.median(single)) * 1e3
        rows.append({"size": size, "batch_ms": round(b, 3), "one_by_one_ms": round(s, 3), "ratio": round(b / s, 2)})
        print(f"  {size:3d} problems: batch {b:7.3f} ms, one by one {s:7.3f} ms, batch / one by one {b / s:5.2f}")
    print(json.dumps({"small_batch": SMALL_BATCH, "rows": rows}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
