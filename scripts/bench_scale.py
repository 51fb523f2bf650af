"""Scaling benchmark of the game controller (issue 7 item 4).

The controller's wall time per control step (``compute_ms`` of steps.csv) against the number of
vehicles in the control zone (role ``ready`` / ``passing`` in trajectories.csv: on an approach lane
or in the junction), for the Nash controller with and without the event-triggered mechanism (ETM),
next to SUMO's own step time in the same runs (``SumoSimulation.advance`` wrapped with a
perf_counter timer: one SUMO step plus the subscription read).

Scenarios are built in code: Poisson flows on all four approaches and all three movements at
increasing total rates, so that the zone holds about 10, 20, 40 and 80 vehicles. Only control steps
after ``--warmup`` seconds are measured. Steps are binned by vehicle count around the targets
([0.8, 1.2] x target); per bin the median compute_ms is reported and the growth exponent is the
least-squares slope of log(median compute_ms) on log(median n) (numpy.polyfit). With the trigger
the growth should stay near linear in the number of vehicles (exponent ~1), not quadratic in the
number of pairs (exponent ~2, the no-ETM behaviour).

Every run's line in the JSON (``runs``) has ``ratio_to_sumo``: the controller's median
compute_ms over SUMO's median step in that same run and the same window (the steps after the
warmup, with the same vehicles in the network; both timed on the same machine at the same time,
so the ratio is about independent of the load); each bin has the same ratio against the SUMO
steps after the warmup of its runs. ``sumo_ms_median_all`` is SUMO's median over the whole run,
warmup included (while the network fills: at the 80-vehicle level about half the window's), the
denominator this script used before December 2026. The no-ETM run of the 80-vehicle level always runs: if its predicted wall time (quadratic
growth from the previous no-ETM run) exceeds ``--max-noetm-s`` its measured window after the
warmup is shortened (never below ``--min-noetm-window`` s), which the JSON's ``note`` says.

A table goes to stderr; the last line of stdout is one JSON object; with ``--report DIR`` the
event-trigger table also goes to DIR/report.md (the results page "speed" embeds it) and the JSON
to DIR/bench_scale.json.

SUMO's step in a jam is mostly its SSM device, which every run records by default; with
``--no-ssm`` the runs go without it (the controller's steps are the same) and the ratio is
against SUMO's bare step.

    python scripts/bench_scale.py [--duration 50] [--warmup 30] [--max-noetm-s 180] [--no-ssm] [--report DIR]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import scenario_from_dict
from intersection_cosim.sim.timing import sumo_step_timer

TARGETS = (10, 20, 40, 80)
# total demand [veh/h] over the 12 flows (4 approaches x 3 movements) aimed at each target
TOTAL_RATES = {10: 2400.0, 20: 4200.0, 40: 6500.0, 80: 9000.0}  # congestion: n grows fast past ~6000
APPROACHES = ("north", "south", "east", "west")
MOVEMENTS = ("left", "straight", "right")

def build_scenario(total_rate: float, duration: float, seed: int, etm: bool, ssm: bool = True):
    per_flow = total_rate / (len(APPROACHES) * len(MOVEMENTS))
    data = {
        "scenario": {"name": f"scale_{int(total_rate)}", "duration": duration, "drain": 0.0,
                     "step_length": 0.05, "seed": seed, "ssm": ssm},
        "controller": {"kind": "nash", "period": 0.1, "budget_ms": 10000.0, "etm": True,
                       "realtime": False},
        "flow": [
            {"approach": a, "movement": m, "rate": per_flow,
             "kappa": {"dist": "uniform", "low": 0.2, "high": 0.8}, "begin": 0.0, "end": duration}
            for a in APPROACHES for m in MOVEMENTS
        ],
    }
    scn = scenario_from_dict(data, "bench")
    if not etm:
        scn = dataclasses.replace(scn, controller=dataclasses.replace(scn.controller, etm=False))
    return scn


def run_one(scn, warmup: float, sumo_ms: list[float], sumo_t: list[float]) -> dict:
    """One run: its control steps after ``warmup`` [s] with the zone's vehicle count, SUMO's step
    times [ms] after the warmup (``sumo_ms``) and over the whole run (``sumo_ms_all``), wall [s]."""
    sumo_ms.clear()  # SUMO steps of this run only
    sumo_t.clear()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="bench_scale_") as tmp:
        out = Path(tmp) / "run"
        run_scenario(scn, out)
        steps = pd.read_csv(out / "steps.csv")
        traj = pd.read_csv(out / "trajectories.csv", usecols=["time", "role"])
    wall = time.perf_counter() - t0
    inzone = traj[traj["role"] != "outside"].groupby(traj["time"].round(3)).size()
    steps["n"] = steps["time"].round(3).map(inzone).fillna(0).astype(int)
    steps = steps[steps["time"] >= warmup]
    window = [ms for t, ms in zip(sumo_t, sumo_ms) if t > warmup]  # the steps from the warmup on
    return {"steps": steps[["time", "n", "compute_ms", "games"]].copy(),
            "sumo_ms": window, "sumo_ms_all": list(sumo_ms), "wall_s": wall}


def _ratio(compute_ms_median: float, sumo_ms: list[float]) -> float | None:
    """[-] the controller's median step over SUMO's median step (same run or runs)."""
    if not sumo_ms:
        return None
    return round(float(compute_ms_median) / float(np.median(sumo_ms)), 2)


def _noetm_duration(target: int, prev_noetm: tuple[int, float], args, notes: list[str]) -> float | None:
    """[s] simulated duration of the no-ETM run for ``target``, or None to skip it.

    The wall time is predicted quadratic in n from the previous no-ETM run (``prev_noetm``:
    its target and wall time [s]). Below the last level a run predicted over ``max_noetm_s`` is
    skipped; the last level is always run, its measured window after the warmup shortened in
    proportion (at least ``min_noetm_window`` [s])."""
    predicted = prev_noetm[1] * (target / prev_noetm[0]) ** 2  # [s] wall
    if predicted <= args.max_noetm_s:
        return args.duration
    if target != TARGETS[-1]:
        notes.append(f"no-ETM run for target {target} skipped (predicted {predicted:.0f} s wall > "
                     f"{args.max_noetm_s:.0f} s)")
        return None
    window = args.duration - args.warmup  # [s] measured part
    short = max(args.min_noetm_window, window * args.max_noetm_s / predicted)
    if short >= window:
        return args.duration
    notes.append(f"no-ETM run for target {target} shortened to {args.warmup + short:.1f} s "
                 f"({short:.1f} s measured after the warmup; predicted {predicted:.0f} s wall "
                 f"for {args.duration:.0f} s)")
    return round(args.warmup + short, 1)


def run_levels(args, notes: list[str]):
    """Every level with and without the trigger: (runs, steps by etm, SUMO step times [ms] by
    etm, SUMO step times by run index)."""
    all_steps = {True: [], False: []}
    sumo_all = {True: [], False: []}
    sumo_runs: dict[int, list[float]] = {}  # run index -> its SUMO step times [ms]
    runs = []
    sumo_t: list[float] = []  # [s] simulation time after each SUMO step
    with sumo_step_timer(sumo_t) as sumo_ms:
        prev_noetm = None
        for target in TARGETS:
            for etm in (True, False):
                duration = args.duration
                if not etm and prev_noetm is not None:
                    duration = _noetm_duration(target, prev_noetm, args, notes)
                    if duration is None:
                        continue
                scn = build_scenario(TOTAL_RATES[target], duration, args.seed, etm, not args.no_ssm)
                r = run_one(scn, args.warmup, sumo_ms, sumo_t)
                st = r["steps"]
                print(f"  target {target:3d} etm={etm!s:5}: wall {r['wall_s']:6.1f} s, n median "
                      f"{st['n'].median():.0f} [{st['n'].min()}-{st['n'].max()}], compute median "
                      f"{st['compute_ms'].median():.2f} ms, ratio to SUMO "
                      f"{_ratio(st['compute_ms'].median(), r['sumo_ms'])}", file=sys.stderr, flush=True)
                runs.append({"target": target, "etm": etm, "total_rate_veh_h": TOTAL_RATES[target],
                             "wall_s": round(r["wall_s"], 1), "n_median": float(st["n"].median()),
                             "n_max": int(st["n"].max()),
                             "duration_s": duration,
                             "compute_ms_median": round(float(st["compute_ms"].median()), 3),
                             "sumo_ms_median": round(float(np.median(r["sumo_ms"])), 4),
                             "sumo_ms_median_all": round(float(np.median(r["sumo_ms_all"])), 4),
                             "ratio_to_sumo": _ratio(st["compute_ms"].median(), r["sumo_ms"])})
                all_steps[etm].append(st.assign(run=len(runs) - 1))
                sumo_all[etm].extend(r["sumo_ms"])
                sumo_runs[len(runs) - 1] = r["sumo_ms"]
                if not etm:
                    prev_noetm = (target, r["wall_s"])
    return runs, all_steps, sumo_all, sumo_runs


def bin_steps(steps: pd.DataFrame, sumo_runs: dict[int, list[float]]) -> list[dict]:
    """Per target, the steps with n in [0.8, 1.2] x target: medians, p95 and the ratio of the
    controller's median to SUMO's median over the runs those steps come from."""
    rows = []
    for target in TARGETS:
        sel = steps[(steps["n"] >= 0.8 * target) & (steps["n"] <= 1.2 * target)]
        if len(sel) == 0:
            rows.append({"target": target, "steps": 0})
            continue
        rows.append({"target": target, "lo": int(np.floor(0.8 * target)),
                     "hi": int(np.ceil(1.2 * target)), "steps": int(len(sel)),
                     "n_median": float(sel["n"].median()),
                     "compute_ms_median": round(float(sel["compute_ms"].median()), 3),
                     "compute_ms_p95": round(float(sel["compute_ms"].quantile(0.95)), 3),
                     "games_median": float(sel["games"].median()),
                     "ratio_to_sumo": _ratio(sel["compute_ms"].median(), [
                         t for run in sorted(set(sel["run"])) for t in sumo_runs[run]])})
    return rows


def growth_exponent(rows: list[dict]) -> float | None:
    """[-] least-squares slope of log(median compute_ms) on log(median n) over the bins with at
    least 5 steps; None with fewer than two."""
    pts = [(r["n_median"], r["compute_ms_median"]) for r in rows
           if r["steps"] >= 5 and r["compute_ms_median"] > 0]
    if len(pts) < 2:
        return None
    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    return round(float(np.polyfit(x, y, 1)[0]), 3)


def print_table(bins: dict, sumo_med: dict, exponents: dict) -> None:
    print("\n  target | ETM: steps  n_med  ms_med  ms_p95 | no-ETM: steps  n_med  ms_med  ms_p95",
          file=sys.stderr)

    def cell(r):
        if r["steps"] == 0:
            return f"{0:11d}      -       -       -"
        return f"{r['steps']:11d} {r['n_median']:6.0f} {r['compute_ms_median']:7.2f} {r['compute_ms_p95']:7.2f}"

    for a, b in zip(bins["etm"], bins["noetm"]):
        print(f"  {a['target']:6d} | {cell(a)} | {cell(b)}", file=sys.stderr)
    print("  controller median / SUMO median (same runs): ETM "
          f"{[r.get('ratio_to_sumo') for r in bins['etm']]}, no-ETM "
          f"{[r.get('ratio_to_sumo') for r in bins['noetm']]}", file=sys.stderr)
    print(f"  SUMO step (advance) median after the warmup: ETM runs {sumo_med['etm']} ms, no-ETM runs "
          f"{sumo_med['noetm']} ms", file=sys.stderr)
    print(f"  growth exponent (compute_ms ~ n^k): ETM k={exponents['etm']}, "
          f"no-ETM k={exponents['noetm']}", file=sys.stderr)


def write_report(folder: Path, result: dict) -> Path:
    """``folder``/report.md: the ETM bins as a table (the results page embeds it) and the JSON."""
    folder.mkdir(parents=True, exist_ok=True)
    sumo = result["sumo_step_ms_median"]["etm"]
    lines = ["# The single junction's step against its vehicle count", "",
             f"The game controller (`nash`, event trigger on) on the generated four-arm "
             f"intersection at four demand levels, SUMO's SSM device {'on' if result['ssm'] else 'off'}. Per "
             "level the control steps after the warmup: the vehicles in the World (median), the controller's "
             "step (median and p95) and its ratio to SUMO's own step in the same runs (median).", "",
             "| level | steps | vehicles | step median [ms] | step p95 [ms] | x SUMO step |", "|---|---|---|---|---|---|"]
    for r in result["bins"]["etm"]:
        if r["steps"]:
            lines.append(f"| {r['target']} | {r['steps']} | {r['n_median']:.0f} | {r['compute_ms_median']:.2f} | "
                         f"{r['compute_ms_p95']:.2f} | {r['ratio_to_sumo']} |")
    lines += ["", f"SUMO's step (median after the warmup, event-trigger runs): {sumo} ms. Growth exponent of "
              f"the step with the vehicle count (compute ~ n^k): k = {result['exponent_etm']} with the event "
              f"trigger, {result['exponent_noetm']} without it.", ""]
    if result.get("note"):
        lines += [f"Note: {result['note']}.", ""]
    path = folder / "report.md"
    path.write_text("\n".join(lines))
    (folder / "bench_scale.json").write_text(json.dumps(result))
    return path


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--duration", type=float, default=50.0, help="[s] simulated time per run")
    ap.add_argument("--warmup", type=float, default=30.0, help="[s] control steps before are dropped")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--no-ssm", action="store_true",
                    help="run without SUMO's SSM device ([scenario] ssm = false): the same control "
                         "steps, SUMO's bare step as the ratio's denominator")
    ap.add_argument("--max-noetm-s", type=float, default=180.0,
                    help="[s] skip a no-ETM run (below the last level: shorten it) whose "
                         "predicted wall time exceeds this")
    ap.add_argument("--min-noetm-window", type=float, default=2.0,
                    help="[s] shortest measured window after the warmup of the last no-ETM run")
    ap.add_argument("--report", type=Path, help="folder to write report.md and bench_scale.json into")
    args = ap.parse_args()

    notes: list[str] = []
    t_start = time.perf_counter()
    runs, all_steps, sumo_all, sumo_runs = run_levels(args, notes)
    bins, exponents = {}, {}
    for etm in (True, False):
        steps = pd.concat(all_steps[etm]) if all_steps[etm] else pd.DataFrame(
            columns=["time", "n", "compute_ms", "games", "run"])
        key = "etm" if etm else "noetm"
        bins[key] = rows = bin_steps(steps, sumo_runs)
        exponents[key] = growth_exponent(rows)
        if exponents[key] is None:
            notes.append(f"{key}: fewer than 2 populated bins, no exponent")
        missing = [r["target"] for r in rows if r["steps"] < 5]
        if missing:
            notes.append(f"{key}: bins for targets {missing} have < 5 steps (not reached/skipped)")
    sumo_med = {k: (round(float(np.median(v)), 4) if v else None) for k, v in
                (("etm", sumo_all[True]), ("noetm", sumo_all[False]))}
    print_table(bins, sumo_med, exponents)
    result = {
        "benchmark": "bench_scale", "controller": "nash", "budget_ms": 10000.0,
        "duration_s": args.duration, "warmup_s": args.warmup, "seed": args.seed, "ssm": not args.no_ssm,
        "exponent_etm": exponents["etm"], "exponent_noetm": exponents["noetm"],
        "bins": bins, "sumo_step_ms_median": sumo_med, "runs": runs,
        "wall_s": round(time.perf_counter() - t_start, 1),
        "note": "; ".join(notes) if notes else None,
    }
    print(json.dumps(result))
    if args.report is not None:
        write_report(args.report, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
