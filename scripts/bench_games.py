"""Benchmark of the game solvers: one pairwise Nash and one Stackelberg solve, cold and warm.

Battery: seeded random two-player crossing and merging pairs (intersection_cosim.games.battery).
For each pair: a cold solve, then ``--steps`` receding-horizon steps in which every player has
followed its plan for one step and the next solve is warm-started from the previous plans shifted
by one step (what the closed-loop controller does). Reports the median and 95th percentile wall
time [ms] and the median OSQP solve count per solve. The last line of the output is one JSON
object. Targets on the development machine: warm Nash <= 1 ms median, warm Stackelberg <= 1.5 ms.
The machine is shared: absolute medians drift by 2x between runs, so the warm Stackelberg / Nash
ratio of the same run is printed too (with Nash at its quiet 0.75 ms, a ratio below 2 meets 1.5 ms).

    python scripts/bench_games.py [--count 40] [--steps 10] [--seed 7]
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import numpy as np

from intersection_cosim.games import (GameSettings, battery, nash_equilibrium, shift_plans,
                                      stackelberg_equilibrium)
from intersection_cosim.games.battery import advance
from intersection_cosim.models.settings import ModelSettings

TARGET_MS = {"nash_warm": 1.0, "stackelberg_warm": 1.5}


def _stats(times: list[float], qps: list[int]) -> dict:
    t = np.asarray(times) * 1e3
    return {"median_ms": round(float(np.median(t)), 3), "p95_ms": round(float(np.percentile(t, 95)), 3),
            "qp_median": float(np.median(qps)), "qp_p95": float(np.percentile(qps, 95)), "n": len(times)}


def run(count: int, steps: int, seed: int) -> dict:
    gs, ms = GameSettings(), ModelSettings()
    problems = battery(count, seed=seed)
    # warm-up: create the OSQP workspaces and caches outside the measurement
    for p in problems[:2]:
        stackelberg_equilibrium(p, gs, ms)
    samples = {k: ([], []) for k in ("nash_cold", "nash_warm", "stackelberg_cold", "stackelberg_warm")}
    statuses: dict[str, int] = {}
    iterations = []
    for solver, name in ((nash_equilibrium, "nash"), (stackelberg_equilibrium, "stackelberg")):
        for problem in problems:
            t0 = time.perf_counter()
            result = solver(problem, gs, ms)
            samples[f"{name}_cold"][0].append(time.perf_counter() - t0)
            samples[f"{name}_cold"][1].append(result.qp_count)
            statuses[result.status] = statuses.get(result.status, 0) + 1
            for _ in range(steps):
                problem = advance(problem, result.plans)
                warm = shift_plans(result)
                t0 = time.perf_counter()
                result = solver(problem, gs, ms, warm_start=warm)
                samples[f"{name}_warm"][0].append(time.perf_counter() - t0)
                samples[f"{name}_warm"][1].append(result.qp_count)
                statuses[result.status] = statuses.get(result.status, 0) + 1
                if name == "nash":
                    iterations.append(result.iterations)
    out = {key: _stats(*val) for key, val in samples.items()}
    out["nash_warm"]["iterations_median"] = float(np.median(iterations))
    for key, target in TARGET_MS.items():
        out[key]["target_median_ms"] = target
        out[key]["meets_target"] = out[key]["median_ms"] <= target
    # same-run ratio: on a shared machine the absolute medians drift between runs, this does not
    out["ratio_stackelberg_to_nash_warm"] = round(out["stackelberg_warm"]["median_ms"]
                                                  / out["nash_warm"]["median_ms"], 3)
    out["statuses"] = statuses
    out["battery"] = {"pairs": count, "steps_per_pair": steps, "seed": seed, "horizon_s": gs.problem.horizon,
                      "dt_s": gs.problem.dt}
    out["machine"] = {"python": platform.python_version(), "processor": platform.machine()}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=40, help="random pairs (default 40)")
    parser.add_argument("--steps", type=int, default=10, help="warm steps per pair (default 10)")
    parser.add_argument("--seed", type=int, default=7, help="battery seed (default 7)")
    args = parser.parse_args()
    out = run(args.count, args.steps, args.seed)
    for key in ("nash_cold", "nash_warm", "stackelberg_cold", "stackelberg_warm"):
        s = out[key]
        print(f"{key:18s} median {s['median_ms']:7.3f} ms  p95 {s['p95_ms']:7.3f} ms  "
              f"QPs/solve median {s['qp_median']:.0f}  (n = {s['n']})")
    print(f"warm Stackelberg / warm Nash (same run): {out['ratio_stackelberg_to_nash_warm']}")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
