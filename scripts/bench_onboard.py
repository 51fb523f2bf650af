"""What the onboard guard costs per step at the 80-vehicle level of bench_scale.py, measured.

The guard (``[controller.onboard] enabled``, control/safety/onboard.py, sim/onboard.py) runs in
the simulator adapter's write, every SUMO step, once per commanded vehicle (SUMO's ``getLeader``
and Krauss' safe speed); the controller's step does not see it. This script runs the 80-vehicle
scenario of ``bench_scale.py`` (SSM off unless ``--ssm``) with the guard on and off, and, with
``--old DIR``, under the code checked out in ``DIR`` (a ``git worktree`` of a commit before the
guard), each run in a fresh process, alternating the variants ``--repeats`` times in one run of
the script. Per variant, over the steps after ``--warmup`` [s]: the medians of the controller's
step (steps.csv's ``compute_ms``) [ms], of SUMO's step (``advance``: simulationStep plus the
subscription read) [ms], of the write (the speed commands and the guard) [ms], and of the whole
control period (one control step plus its SUMO steps' writes and advances) [ms]; then the ratio
of each variant's period to the guard-off one's.

A table goes to stderr; the last line of stdout is one JSON object.

    python scripts/bench_onboard.py [--repeats 3] [--duration 50] [--warmup 30] [--old DIR] [--ssm]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
TARGET = 80  # [vehicles] bench_scale.py's top level


def one_run(guard: bool, duration: float, warmup: float, seed: int, ssm: bool) -> dict:
    """One run in this process with the guard on or off (ignored by code without it); medians [ms]."""
    sys.path.insert(0, str(HERE))
    from bench_scale import TOTAL_RATES, build_scenario

    from intersection_cosim.experiments.run import run_scenario
    from intersection_cosim.sim.sumo import SumoSimulation

    scn = build_scenario(TOTAL_RATES[TARGET], duration, seed, True, ssm)
    if hasattr(scn.controller, "onboard"):
        onboard = dataclasses.replace(scn.controller.onboard, enabled=guard)
        scn = dataclasses.replace(scn, controller=dataclasses.replace(scn.controller, onboard=onboard))
    samples: dict[str, list[tuple[float, float]]] = {"advance": [], "write": []}  # (sim time [s], [ms])
    for name in samples:
        original = getattr(SumoSimulation, name)

        def timed(self, _original=original, _name=name):
            t0 = time.perf_counter()
            _original(self)
            samples[_name].append((float(self.time), (time.perf_counter() - t0) * 1e3))

        setattr(SumoSimulation, name, timed)
    with tempfile.TemporaryDirectory(prefix="bench_onboard_") as tmp:
        run_scenario(scn, Path(tmp) / "run")
        steps = pd.read_csv(Path(tmp) / "run" / "steps.csv")
    steps = steps[steps["time"] >= warmup]
    period = _periods(steps, samples)
    return {"compute_ms": float(steps["compute_ms"].median()), "period_ms": float(np.median(period)),
            **{f"{k}_ms": float(np.median([ms for t, ms in v if t >= warmup])) for k, v in samples.items()}}


def _periods(steps: pd.DataFrame, samples: dict) -> np.ndarray:
    """[ms] per control step after the warmup: its compute plus the writes and advances of SUMO's
    steps until the next control step (write and advance at simulation times in [t, t_next))."""
    times = steps["time"].to_numpy(float)
    total = steps["compute_ms"].to_numpy(float).copy()
    for v in samples.values():
        t = np.array([x[0] for x in v])
        ms = np.array([x[1] for x in v])
        idx = np.searchsorted(times, t + 1e-9, side="right") - 1  # the control step each sample follows
        keep = idx >= 0
        np.add.at(total, idx[keep], ms[keep])
    return total


def _spawn(label: str, path: str, guard: bool, args) -> dict:
    env = {**os.environ, "PYTHONPATH": path}
    cmd = [sys.executable, __file__, "--one", "on" if guard else "off", "--duration", str(args.duration),
           "--warmup", str(args.warmup), "--seed", str(args.seed)] + (["--ssm"] if args.ssm else [])
    done = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if done.returncode != 0:
        sys.stderr.write(done.stderr[-4000:])
        raise SystemExit(f"bench_onboard: the {label} run failed")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> dict | None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeats", type=int, default=3, help="runs of each variant, alternated")
    ap.add_argument("--duration", type=float, default=50.0, help="[s] demand window of each run")
    ap.add_argument("--warmup", type=float, default=30.0, help="[s] steps before it are not measured")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--ssm", action="store_true", help="with SUMO's SSM device (default off)")
    ap.add_argument("--old", help="a checkout of older code to run as a third variant (its guard, if any, on)")
    ap.add_argument("--one", choices=("on", "off"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one is not None:
        print(json.dumps(one_run(args.one == "on", args.duration, args.warmup, args.seed, args.ssm)))
        return None
    here = os.environ.get("PYTHONPATH", str(HERE.parent))
    variants = [("guard on", here, True), ("guard off", here, False)]
    if args.old:
        variants.append((f"old {Path(args.old).name}", str(Path(args.old).resolve()), True))
    runs: dict[str, list[dict]] = {label: [] for label, _, _ in variants}
    for r in range(args.repeats):
        for label, path, guard in (variants if r % 2 == 0 else variants[::-1]):
            runs[label].append(_spawn(label, path, guard, args))
            print(f"  #{r} {label}: {runs[label][-1]}", file=sys.stderr, flush=True)
    keys = ("compute_ms", "advance_ms", "write_ms", "period_ms")
    med = {label: {k: float(np.median([x[k] for x in v])) for k in keys} for label, v in runs.items()}
    off = med["guard off"]["period_ms"]
    print(f"{'variant':>16} {'compute':>8} {'advance':>8} {'write':>8} {'period':>8} {'/ off':>6}", file=sys.stderr)
    for label, m in med.items():
        m["period_ratio_to_off"] = m["period_ms"] / off
        print(f"{label:>16} {m['compute_ms']:8.3f} {m['advance_ms']:8.3f} {m['write_ms']:8.3f} {m['period_ms']:8.3f} "
              f"{m['period_ratio_to_off']:6.3f}", file=sys.stderr)
    result = {"benchmark": "bench_onboard", "target": TARGET, "repeats": args.repeats, "ssm": args.ssm,
              "medians": med, "runs": runs}
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main()
