"""Benchmark of the decision models' per-step work for N vehicles (issue 3, item 9).

For N = 10, 50, 100 random vehicles on random movement paths it times, per control step:

- conflict_points: look-up of every vehicle pair's precomputed conflict point by path index;
- risk_trigger: Gamma_cp of every conflicting pair and the ETM decision (Eqs. 5-9, 39);
- total: the two in sequence (what the controller does each step; the prediction along the
  paths is the arc length s + v t inside them, see models/prediction.py).

Conflict points are computed once per net beforehand (not timed). Prints a table, then one JSON
object with the median times in milliseconds on its last line. Target: total < 2 ms for N = 100.

    python scripts/bench_models.py [--net path/to/intersection.net.xml] [--repeat 300]
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from intersection_cosim.models.prediction import conflict_lookup
from intersection_cosim.models.risk import event_trigger
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.build import build_network
from intersection_cosim.network.conflicts import load_conflict_table

SIZES = (10, 50, 100)
TARGET_MS = 2.0  # [ms] median total for 100 vehicles


def _median_ms(fn, repeat: int) -> float:
    for _ in range(10):  # warm-up
        fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


def bench(net_file: Path, repeat: int, seed: int = 0) -> dict:
    settings = ModelSettings()
    ctable = load_conflict_table(net_file, settings.vehicle_width)
    rng = np.random.default_rng(seed)
    out: dict = {"unit": "ms (median)", "repeat": repeat, "target_ms_total_100": TARGET_MS}
    for n in SIZES:
        idx = rng.integers(0, len(ctable.ids), n)
        s = rng.uniform(ctable.s_stop[idx] - 50.0, ctable.s_exit[idx] + 10.0)
        v = rng.uniform(0.0, 12.0, n)
        kappa = rng.uniform(0.0, 1.0, n)

        def lookup():
            return conflict_lookup(ctable, idx)

        pc = lookup()

        def risk():
            return event_trigger(ctable, idx, s, v, kappa, settings, conflicts=pc)

        def total():
            event_trigger(ctable, idx, s, v, kappa, settings, conflicts=conflict_lookup(ctable, idx))

        r = risk()
        out[str(n)] = {
            "pairs": n * (n - 1) // 2,
            "conflicting_pairs": int(len(r.i)),
            "triggered_pairs": int(r.trigger.sum()),
            "conflict_points": round(_median_ms(lookup, repeat), 4),
            "risk_trigger": round(_median_ms(risk, repeat), 4),
            "total": round(_median_ms(total, repeat), 4),
        }
    out["meets_target"] = out["100"]["total"] < TARGET_MS
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--net", type=Path, help="SUMO net (default: build one in a temp folder)")
    parser.add_argument("--repeat", type=int, default=300, help="timed repetitions per figure")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        net_file = args.net or build_network(Path(tmp))
        result = bench(net_file, args.repeat)
    print(f"{'N':>4} {'pairs':>6} {'confl.':>6} {'trig.':>6} {'lookup':>8} {'risk':>8} {'total':>8}  [ms]")
    for n in SIZES:
        r = result[str(n)]
        print(f"{n:>4} {r['pairs']:>6} {r['conflicting_pairs']:>6} {r['triggered_pairs']:>6} "
              f"{r['conflict_points']:>8.3f} {r['risk_trigger']:>8.3f} {r['total']:>8.3f}")
    print(json.dumps(result))


if __name__ == "__main__":
    main()
