#!/usr/bin/env python
"""Benchmark: sweep throughput (runs per minute) with 1 and 2 local workers, and the scaling efficiency.

Runs a small sweep of Case 1 A with the sumo controller (one kappa axis, ``--runs`` values) into a
temporary folder once per worker count, so every run really executes. Human-readable lines first;
the last line is one JSON object:

    {"benchmark": "sweep", "scenario": ..., "controller": ..., "runs": N, "cpus": C,
     "results": [{"workers": 1, "seconds": s, "runs_per_minute": r}, ...],
     "scaling_efficiency": r(max workers) / (max workers * r(1))}

Usage: python scripts/bench_sweep.py [--runs 6] [--workers 1,2] [--scenario scenarios/case1_A.toml]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from intersection_cosim.experiments.executors import default_workers
from intersection_cosim.experiments.sweep import make_spec, run_sweep

ROOT = Path(__file__).resolve().parents[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default=str(ROOT / "scenarios" / "case1_A.toml"))
    parser.add_argument("--controller", default="sumo")
    parser.add_argument("--vehicle", default="V1", help="the swept vehicle")
    parser.add_argument("--runs", type=int, default=6, help="runs per sweep (kappa values of --vehicle)")
    parser.add_argument("--workers", default="1,2", help="worker counts, comma-separated")
    args = parser.parse_args(argv)

    values = ",".join(f"{v:.4f}" for v in np.linspace(0.1, 0.9, args.runs))
    spec = make_spec(args.scenario, [f"{args.vehicle}={values}"], args.controller, None)  # also warms the net cache
    counts = [int(w) for w in args.workers.split(",")]
    results = []
    for workers in counts:
        with tempfile.TemporaryDirectory(prefix="bench-sweep-") as tmp:
            t0 = time.perf_counter()
            outcome = run_sweep(spec, Path(tmp) / "sweep", workers=workers, progress=False)
            seconds = time.perf_counter() - t0
        if outcome.ok != spec.total:
            print(f"bench_sweep: {spec.total - outcome.ok} of {spec.total} runs did not finish", file=sys.stderr)
            return 1
        rpm = spec.total / seconds * 60.0
        results.append({"workers": workers, "seconds": round(seconds, 3), "runs_per_minute": round(rpm, 2)})
        print(f"{workers} worker(s): {spec.total} runs in {seconds:.2f} s = {rpm:.1f} runs/min")
    base = results[0]["runs_per_minute"] / counts[0]
    top = results[-1]
    efficiency = top["runs_per_minute"] / (top["workers"] * base)
    print(f"scaling efficiency {counts[0]} -> {top['workers']} workers: {efficiency:.2f} "
          f"({default_workers()} CPUs available)")
    print(json.dumps({"benchmark": "sweep", "scenario": Path(args.scenario).stem, "controller": args.controller,
                      "runs": spec.total, "cpus": default_workers(), "results": results,
                      "scaling_efficiency": round(efficiency, 3)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
