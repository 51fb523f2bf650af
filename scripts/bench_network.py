"""Network benchmark (issue 17 item 4): compute per control step summed over the junctions'
controllers, per junction, against the number of vehicles in the network, and what running the
junctions' controllers in parallel on 2 cores would give.

Runs the shipped 3 x 3 grid (``scenarios/grid_{low,medium,high}.toml``, one controller per
junction, nine junctions) with ``--controller`` for ``--duration`` s of demand (no drain), or
reads finished run folders given with ``--runs``. From each run's steps.csv (one row per junction
and control step) and trajectories.csv (one row per vehicle on a managed path and step):

* ``levels``: per run, median and p95 of the step's compute summed over the junctions [ms], the
  median per junction [ms] (``per_junction_ms``), and the median number of vehicles in the World
  (on a managed junction's paths) per step;
* ``bins``: steps binned by vehicles in the World (bins of ``--bin`` vehicles): median summed
  compute [ms] and median per junction-step [ms];
* ``parallel``: the ideal 2-process step time, per step the larger of the two halves of a
  greedy split of the junctions' compute (largest first to the lighter worker, the split a
  scheduler could make with hindsight), plus the inter-process cost measured here: a round trip
  of one junction's pickled sub-World and Decisions through a ``multiprocessing.Pipe``
  (``ipc_roundtrip_ms``, median of 300), paid once per junction and step by the main process
  (the sub-Worlds go out and the Decisions come back through it). ``speedup`` = serial median /
  parallel median. A thread pool gives nothing: the controllers are Python-heavy (the GIL).

A table goes to stderr; the last line of stdout is one JSON object.

    python scripts/bench_network.py [--duration 300] [--controller nash] [--runs DIR ...]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import multiprocessing as mp
import pickle
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
LEVELS = ("low", "medium", "high")


def _run(level: str, controller: str, duration: float, out: Path) -> Path:
    from intersection_cosim.experiments.run import run_scenario
    from intersection_cosim.scenario import load_scenario, with_overrides

    scn = with_overrides(load_scenario(ROOT / "scenarios" / f"grid_{level}.toml"), controller=controller)
    scn = dataclasses.replace(scn, scenario=dataclasses.replace(scn.scenario, duration=duration, drain=0.0))
    run_scenario(scn, out / level)
    return out / level


def _tables(run: Path) -> tuple[pd.DataFrame, pd.Series]:
    steps = pd.read_csv(run / "steps.csv")
    traj = pd.read_csv(run / "trajectories.csv", usecols=["time", "vehicle"])
    vehicles = traj.groupby("time").size()
    return steps, vehicles


def _greedy_two(loads: np.ndarray) -> float:
    """[ms] the larger half of a largest-first split of ``loads`` over two workers."""
    a = b = 0.0
    for x in sorted(loads, reverse=True):
        if a <= b:
            a += x
        else:
            b += x
    return max(a, b)


def _ipc_roundtrip_ms(run: Path) -> float:
    """[ms] median round trip of a typical junction sub-World (as pickled arrays) and its
    Decisions through a Pipe to a child process."""
    traj = pd.read_csv(run / "trajectories.csv")
    per_step = traj.groupby("time").size()
    t = per_step.index[int(np.argmin(np.abs(per_step.to_numpy() - per_step.median())))]
    rows = traj[traj["time"] == t]
    n = max(1, len(rows) // 9)  # one junction's share
    sub = {c: rows[c].to_numpy()[:n] for c in ("x", "y", "speed", "accel", "heading", "s")}
    sub["ids"] = list(rows["vehicle"].astype(str))[:n]
    sub["paths"] = list(rows["path"].astype(str))[:n]
    reply = {"accel": {vid: 0.5 for vid in sub["ids"]}, "exit_lane": {}, "release": []}
    parent, child = mp.Pipe()
    proc = mp.Process(target=_echo, args=(child, pickle.dumps(reply)))
    proc.start()
    times = []
    for _ in range(300):
        t0 = time.perf_counter()
        parent.send_bytes(pickle.dumps(sub))
        pickle.loads(parent.recv_bytes())
        times.append(time.perf_counter() - t0)
    parent.send_bytes(b"")
    proc.join()
    return float(np.median(times) * 1e3)


def _echo(conn, reply: bytes) -> None:
    while True:
        msg = conn.recv_bytes()
        if not msg:
            return
        pickle.loads(msg)
        conn.send_bytes(reply)


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=300.0, help="[s] demand window of each grid run")
    ap.add_argument("--controller", default="nash")
    ap.add_argument("--runs", nargs="*", type=Path, help="finished run folders to read instead of running")
    ap.add_argument("--bin", type=int, default=20, help="[vehicles] width of the vehicle-count bins")
    args = ap.parse_args(argv)
    if args.runs:
        runs = {"/".join(p.parts[-3:]): p for p in args.runs}  # scenario/runs/run id of a sweep folder
    else:
        out = Path(tempfile.mkdtemp(prefix="bench_network-"))
        runs = {lv: _run(lv, args.controller, args.duration, out) for lv in LEVELS}
    levels, frames = {}, []
    for name, run in runs.items():
        steps, vehicles = _tables(run)
        summed = steps.groupby("time")["compute_ms"].sum()
        per_j = steps.groupby("junction")["compute_ms"].median()
        wide = steps.pivot_table(index="time", columns="junction", values="compute_ms", aggfunc="sum")
        parallel = wide.apply(lambda r: _greedy_two(r.to_numpy(float)), axis=1)
        levels[name] = {"steps": int(len(summed)), "junctions": int(steps["junction"].nunique()),
                        "vehicles_median": float(vehicles.reindex(summed.index).fillna(0).median()),
                        "summed_ms_median": float(summed.median()), "summed_ms_p95": float(summed.quantile(0.95)),
                        "per_junction_ms": {str(j): round(float(v), 4) for j, v in per_j.items()},
                        "two_process_ideal_ms_median": float(parallel.median())}
        frames.append(pd.DataFrame({"n": vehicles.reindex(summed.index).fillna(0).to_numpy(),
                                    "summed": summed.to_numpy(),
                                    "per_junction": summed.to_numpy() / steps["junction"].nunique()}))
    allsteps = pd.concat(frames)
    allsteps["bin"] = (allsteps["n"] // args.bin * args.bin).astype(int)
    bins = [{"vehicles": int(b), "steps": int(len(g)), "summed_ms_median": float(g["summed"].median()),
             "per_junction_ms_median": float(g["per_junction"].median())}
            for b, g in allsteps.groupby("bin")]
    ipc = _ipc_roundtrip_ms(next(iter(runs.values())))
    for lv in levels.values():
        par = lv["two_process_ideal_ms_median"] + ipc * lv["junctions"]
        lv["two_process_with_ipc_ms_median"] = par
        lv["speedup_two_processes"] = lv["summed_ms_median"] / par if par > 0 else None
    result = {"benchmark": "bench_network", "controller": args.controller, "ipc_roundtrip_ms": ipc,
              "levels": levels, "bins": bins}
    print(f"{'run':>36} {'veh':>5} {'sum ms':>8} {'p95 ms':>8} {'2-proc ms':>9} {'speedup':>7}", file=sys.stderr)
    for name, lv in levels.items():
        print(f"{name:>36} {lv['vehicles_median']:5.0f} {lv['summed_ms_median']:8.2f} {lv['summed_ms_p95']:8.2f} "
              f"{lv['two_process_with_ipc_ms_median']:9.2f} {lv['speedup_two_processes']:7.2f}", file=sys.stderr)
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main()
