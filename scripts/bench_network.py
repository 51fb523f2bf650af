"""Network benchmark: a whole net under a game controller against SUMO alone, measured.

For each scenario (default: the shipped ``grid_high``, nine junctions, and ``corridor_medium``,
three; any scenario file given instead, e.g. a RESCO cut) it runs the scenario under
``--controller`` (default ``nash``) and under ``sumo-priority`` (SUMO drives, signals as the
scenario says), each run in a fresh process of its own, SUMO's SSM device off (``[scenario]
ssm = false``: an output device, not the simulation), alternating controller and SUMO
``--repeats`` times, so the machine's load falls on both alike. Per scenario it prints:

* ``wall_ratio``: median wall time of the controller's whole runs (setup, closed loop, outputs)
  over the median of SUMO's; the closed loop's ratio alone (``loop_ratio``: the runs' wall time
  less setup and outputs); and ``cpu_ratio`` and ``loop_cpu_ratio``, the same for the process's
  CPU time (on a machine others load too, less noisy than the wall time);
* the controller's step: median and p95 over the control steps of the compute summed over the
  junctions [ms] (steps.csv's ``compute_ms``);
* ``skipped_share``: the share of junction-steps whose controller had nothing to decide and was
  not called (steps.csv's ``skipped``);
* ``parallel_ideal``: the speed-up of the summed compute that ``--workers`` workers would give
  with no overhead, per step the largest load of a largest-first split of the junctions'
  compute (a bound from the measured per-junction times: the junctions run one after another);
* collisions and arrivals of both runs (summary.json's counts), to see that the controller's
  run is the one a change must not alter. The step budget is a wall-clock one: where it binds
  (the anytime schedule cuts a step's iterations), the decisions depend on the machine's load;
  ``--budget-ms 2000`` makes them the same run to run (behaviour_fingerprint.py's budget).

A table goes to stderr; the last line of stdout is one JSON object; with ``--report DIR`` the table
also goes to DIR/report.md (the results page "speed" embeds it) and the JSON to DIR/bench_network.json.

    python scripts/bench_network.py [SCENARIO.toml ...] [--controller nash] [--repeats 1]
        [--duration S] [--drain S] [--workers 2] [--budget-ms MS] [--report DIR]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
DEFAULTS = (ROOT / "scenarios" / "grid_high.toml", ROOT / "scenarios" / "corridor_medium.toml")
BASELINE = "sumo-priority"


def one_run(scenario: Path, controller: str, out: Path, duration: float | None, drain: float | None,
            budget_ms: float | None = None) -> dict:
    """Run ``scenario`` under ``controller`` into ``out`` (SSM off); its wall times [s] and counts."""
    from intersection_cosim.experiments import closed_loop
    from intersection_cosim.experiments.run import run_scenario
    from intersection_cosim.scenario import load_scenario, with_overrides

    scn = with_overrides(load_scenario(scenario), controller=controller, budget_ms=budget_ms)
    s = scn.scenario
    scn = dataclasses.replace(scn, scenario=dataclasses.replace(
        s, ssm=False, duration=s.duration if duration is None else duration, drain=s.drain if drain is None else drain))
    loop = []
    inner = closed_loop._closed_loop

    def timed(*args, **kwargs):
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            return inner(*args, **kwargs)
        finally:
            loop.extend((time.perf_counter() - t0, time.process_time() - c0))

    closed_loop._closed_loop = timed
    t0, c0 = time.perf_counter(), time.process_time()
    summary = run_scenario(scn, out)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    counts = summary.get("counts", {})
    return {"wall_s": wall, "cpu_s": cpu, "loop_s": loop[0], "loop_cpu_s": loop[1], "collisions": counts.get("collisions"), "arrived": counts.get("arrived")}


def _spawn(scenario: Path, controller: str, out: Path, args) -> dict:
    """:func:`one_run` in a fresh process (libsumo runs one simulation per process)."""
    cmd = [sys.executable, __file__, "--one", str(scenario), "--controller", controller, "--out", str(out)]
    for name in ("duration", "drain", "budget_ms"):
        if getattr(args, name) is not None:
            cmd += [f"--{name.replace('_', '-')}", str(getattr(args, name))]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        sys.stderr.write(done.stderr[-4000:])
        raise SystemExit(f"bench_network: the {controller} run of {scenario} failed")
    return json.loads(done.stdout.strip().splitlines()[-1])


def largest_first(loads: np.ndarray, workers: int) -> float:
    """[ms] the largest worker's load of a largest-first split of ``loads`` [ms] over ``workers``."""
    bins = [0.0] * workers
    for x in sorted(loads, reverse=True):
        bins[bins.index(min(bins))] += x
    return max(bins)


def step_stats(run: Path, workers: int) -> dict:
    """The controller's steps of ``run``: summed compute median / p95 [ms], skipped share,
    and the ideal parallel speed-up over ``workers``."""
    steps = pd.read_csv(run / "steps.csv")
    summed = steps.groupby("time", sort=False)["compute_ms"].sum()
    wide = steps.pivot_table(index="time", columns="junction", values="compute_ms", aggfunc="sum").fillna(0.0)
    parallel = np.array([largest_first(row, workers) for row in wide.to_numpy(float)])
    total = float(wide.to_numpy().sum())
    return {"steps": int(len(summed)), "junctions": int(steps["junction"].nunique()),
            "step_ms_median": float(summed.median()), "step_ms_p95": float(summed.quantile(0.95)),
            "skipped_share": float(steps["skipped"].mean()) if "skipped" in steps else 0.0,
            "parallel_ideal": total / float(parallel.sum()) if parallel.sum() > 0 else 1.0}


def bench(scenario: Path, args, tmp: Path) -> dict:
    """Alternate controller and SUMO runs of ``scenario``; the measured ratios and step stats."""
    runs: dict[str, list[dict]] = {args.controller: [], BASELINE: []}
    for r in range(args.repeats):
        order = (args.controller, BASELINE) if r % 2 == 0 else (BASELINE, args.controller)
        for kind in order:
            out = tmp / f"{scenario.stem}-{kind}-{r}"
            runs[kind].append({**_spawn(scenario, kind, out, args), "out": str(out)})
            print(f"  {scenario.stem} {kind} #{r}: {runs[kind][-1]['wall_s']:.1f} s", file=sys.stderr)
    ctrl, base = runs[args.controller], runs[BASELINE]
    med = {k: {f: float(np.median([x[f] for x in v])) for f in ("wall_s", "cpu_s", "loop_s", "loop_cpu_s")}
           for k, v in runs.items()}
    return {"scenario": str(scenario), "runs": runs,
            "wall_ratio": med[args.controller]["wall_s"] / med[BASELINE]["wall_s"],
            "cpu_ratio": med[args.controller]["cpu_s"] / med[BASELINE]["cpu_s"],
            "loop_ratio": med[args.controller]["loop_s"] / med[BASELINE]["loop_s"],
            "loop_cpu_ratio": med[args.controller]["loop_cpu_s"] / med[BASELINE]["loop_cpu_s"],
            "controller_wall_s": med[args.controller]["wall_s"], "sumo_wall_s": med[BASELINE]["wall_s"],
            **step_stats(Path(ctrl[-1]["out"]), args.workers),
            "collisions": [ctrl[-1]["collisions"], base[-1]["collisions"]],
            "arrived": [ctrl[-1]["arrived"], base[-1]["arrived"]]}


def write_report(folder: Path, result: dict) -> Path:
    """``folder``/report.md: one row per scenario (the results page embeds it) and the JSON."""
    folder.mkdir(parents=True, exist_ok=True)
    ctrl, w = result["controller"], result["workers"]
    lines = ["# A network under the game controller against SUMO alone", "",
             f"Each scenario under `{ctrl}` and under `{BASELINE}`, each run in a fresh process, SUMO's SSM device "
             f"off, alternated ({result['repeats']} run(s) each). Ratios are medians of the controller's runs over "
             "SUMO's: the whole run's wall time, its CPU time, and the closed loop's wall time alone. The "
             "controller's step is its compute summed over the junctions; skipped: the share of junction-steps "
             f"with nothing to decide; parallel: the ideal speed-up of the junctions' compute over {w} workers "
             "(a bound from the measured per-junction times; the junctions run one after another).", "",
             "| scenario | junctions | controller [s] | SUMO [s] | wall ratio | CPU ratio | loop ratio | "
             "step median [ms] | step p95 [ms] | skipped | parallel | collisions (ctrl / SUMO) | arrived (ctrl / SUMO) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in result["results"]:
        lines.append(f"| {Path(r['scenario']).stem} | {r['junctions']} | {r['controller_wall_s']:.1f} | "
                     f"{r['sumo_wall_s']:.1f} | {r['wall_ratio']:.2f} | {r['cpu_ratio']:.2f} | {r['loop_ratio']:.2f} | "
                     f"{r['step_ms_median']:.2f} | {r['step_ms_p95']:.2f} | {r['skipped_share']:.1%} | "
                     f"{r['parallel_ideal']:.2f} | {r['collisions'][0]} / {r['collisions'][1]} | "
                     f"{r['arrived'][0]} / {r['arrived'][1]} |")
    path = folder / "report.md"
    path.write_text("\n".join(lines) + "\n")
    (folder / "bench_network.json").write_text(json.dumps(result))
    return path


def main(argv: list[str] | None = None) -> dict | None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenarios", nargs="*", type=Path, help="scenario files (default: grid_high, corridor_medium)")
    ap.add_argument("--controller", default="nash")
    ap.add_argument("--repeats", type=int, default=1, help="runs of each controller, alternated")
    ap.add_argument("--duration", type=float, help="[s] demand window (default: the scenario's)")
    ap.add_argument("--drain", type=float, help="[s] drain after it (default: the scenario's)")
    ap.add_argument("--workers", type=int, default=2, help="workers of the ideal parallel split")
    ap.add_argument("--budget-ms", type=float, help="[ms] step budget per junction (default: the scenario's; "
                    "a wall-clock budget that binds makes the decisions depend on the machine's load)")
    ap.add_argument("--report", type=Path, help="folder to write report.md and bench_network.json into")
    ap.add_argument("--one", type=Path, help=argparse.SUPPRESS)
    ap.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one is not None:
        print(json.dumps(one_run(args.one, args.controller, args.out, args.duration, args.drain, args.budget_ms)))
        return None
    tmp = Path(tempfile.mkdtemp(prefix="bench_network-"))
    results = [bench(sc.resolve(), args, tmp) for sc in (args.scenarios or DEFAULTS)]
    print(f"{'scenario':>18} {'junc':>4} {'ctrl s':>8} {'sumo s':>8} {'ratio':>6} {'cpu':>6} {'loop':>6} {'med ms':>7} "
          f"{'p95 ms':>7} {'skipped':>7} {'par':>5} {'coll c/s':>9} {'arr c/s':>11}", file=sys.stderr)
    for r in results:
        print(f"{Path(r['scenario']).stem:>18} {r['junctions']:4d} {r['controller_wall_s']:8.1f} "
              f"{r['sumo_wall_s']:8.1f} {r['wall_ratio']:6.2f} {r['cpu_ratio']:6.2f} {r['loop_ratio']:6.2f} {r['step_ms_median']:7.2f} "
              f"{r['step_ms_p95']:7.2f} {r['skipped_share']:7.1%} {r['parallel_ideal']:5.2f} "
              f"{r['collisions'][0]!s:>4}/{r['collisions'][1]!s:<4} {r['arrived'][0]:>5}/{r['arrived'][1]:<5}",
              file=sys.stderr)
    result = {"benchmark": "bench_network", "controller": args.controller, "repeats": args.repeats,
              "workers": args.workers, "results": results}
    print(json.dumps(result))
    if args.report is not None:
        write_report(args.report, result)
    return result


if __name__ == "__main__":
    main()
