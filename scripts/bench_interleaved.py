"""Interleaved benchmark of two source trees: bench_controller.py and bench_games.py, old next to new.

For ``--rounds`` rounds, runs each tree's own ``scripts/bench_controller.py --repeat R`` and
``scripts/bench_games.py --count C`` as subprocesses (``PYTHONPATH=<tree>``, cwd ``<tree>``, so each
imports its own ``intersection_cosim``). Within a round the old and the new tree run the same script
back to back; the old tree goes first in even rounds and the new tree first in odd rounds, so drift
on a shared machine hits both equally. Each script's last line of stdout is parsed as JSON.

Figures compared (times in [ms], QP counts in QP solves):
  bench_controller, per case/solver/etm: the controller's median_ms and mean_ms per control step
      [ms] and qp_solves_per_step [QP solves / control step];
  bench_games: nash_cold, nash_warm, stackelberg_cold, stackelberg_warm median_ms per solve [ms]
      and qp_median [QP solves / solve].
For each timing figure: the median over rounds for old and new [ms], the ratio new/old of those
medians, and the min and max of the per-round ratios new/old as the noise. For each configuration:
``qp_identical``, whether the QP figure is equal between old and new in every round. A summary gives
the median ratio over all timing figures and the timing figure with the largest |ratio - 1| next to
its own per-round noise. A table goes to stderr; stdout is ONE JSON line. A failing subprocess is
one line on stderr (tree, script, return code) and exit status 2.

    python scripts/bench_interleaved.py --old /tmp/base_wt [--new .] [--rounds 3] \\
        [--controller-repeat 1] [--games-count 20]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

GAMES_KEYS = ("nash_cold", "nash_warm", "stackelberg_cold", "stackelberg_warm")
CTRL_TIMES = ("median_ms", "mean_ms")  # [ms] per control step, of results[cfg]["controller"]


class BenchFailure(Exception):
    """A benchmark subprocess failed; the message is the one stderr line."""


def _env(tree: Path) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(tree)  # the tree's package takes precedence over the editable install
    return env


def check_import(tree: Path) -> None:
    """Fail unless ``import intersection_cosim`` resolves into ``tree``."""
    code = "import intersection_cosim as m; print(m.__file__)"
    p = subprocess.run([sys.executable, "-c", code], cwd=tree, env=_env(tree),
                       capture_output=True, text=True)
    where = p.stdout.strip()
    if p.returncode != 0 or not Path(where).resolve().is_relative_to(tree):
        raise BenchFailure(f"{tree}: intersection_cosim imports from {where or '?'} "
                           f"(return code {p.returncode}), not from the tree")


def run_script(tree: Path, script: str, args: list[str]) -> dict:
    """Run ``tree/scripts/script`` in ``tree``; return its last stdout line as JSON."""
    cmd = [sys.executable, str(tree / "scripts" / script), *args]
    p = subprocess.run(cmd, cwd=tree, env=_env(tree), capture_output=True, text=True)
    if p.returncode != 0:
        tail = (p.stderr.strip().splitlines() or [""])[-1]
        raise BenchFailure(f"{tree} scripts/{script}: return code {p.returncode}" + (f": {tail}" if tail else ""))
    lines = p.stdout.strip().splitlines()
    try:
        return json.loads(lines[-1])
    except (IndexError, json.JSONDecodeError):
        raise BenchFailure(f"{tree} scripts/{script}: return code 0 but no JSON last line") from None


def extract(script: str, res: dict) -> dict:
    """Figures of one run: {config: {"times": {name: [ms]}, "qp": QP figure}}."""
    out = {}
    if script == "bench_controller.py":
        for cfg, r in res["results"].items():
            times = {k: r["controller"][k] for k in CTRL_TIMES}  # [ms] per control step
            out[f"controller/{cfg}"] = {"times": times, "qp": r["qp_solves_per_step"]}
    else:
        for key in GAMES_KEYS:
            out[f"games/{key}"] = {"times": {"median_ms": res[key]["median_ms"]},  # [ms] per solve
                                   "qp": res[key]["qp_median"]}
    return out


def run_rounds(old: Path, new: Path, rounds: int, scripts: dict) -> dict:
    """{"old"/"new": [per-round {config: figures}]}, the order of the trees alternating per round."""
    runs = {"old": [], "new": []}
    for r in range(rounds):
        order = (("old", old), ("new", new)) if r % 2 == 0 else (("new", new), ("old", old))
        figures = {"old": {}, "new": {}}
        for script, args in scripts.items():  # same script back to back in both trees
            for label, tree in order:
                print(f"round {r + 1}/{rounds}: {label} {script}", file=sys.stderr, flush=True)
                figures[label].update(extract(script, run_script(tree, script, args)))
        runs["old"].append(figures["old"])
        runs["new"].append(figures["new"])
    return runs


def _ratio(a: float | None, b: float | None) -> float | None:
    return None if a is None or b is None or a == 0 else b / a


def _r(x: float | None, nd: int = 4) -> float | None:
    return None if x is None else round(x, nd)


def compare_timing(old: list[float], new: list[float]) -> dict:
    """Medians over rounds [ms], ratio new/old of the medians, per-round ratio spread (the noise)."""
    med_old, med_new = statistics.median(old), statistics.median(new)  # [ms]
    per_round = [x for x in (_ratio(o, n) for o, n in zip(old, new)) if x is not None]
    return {"old_ms": _r(med_old), "new_ms": _r(med_new), "ratio": _r(_ratio(med_old, med_new)),
            "noise_min": _r(min(per_round)) if per_round else None,
            "noise_max": _r(max(per_round)) if per_round else None,
            "per_round_ratio": [_r(x) for x in per_round]}


def compare(runs: dict) -> dict:
    """Per configuration: each timing figure compared, the QP figures and ``qp_identical``."""
    out = {}
    for cfg in runs["old"][0]:
        old = [rnd[cfg] for rnd in runs["old"]]
        new = [rnd[cfg] for rnd in runs["new"] if cfg in rnd]
        if len(new) != len(old):
            out[cfg] = {"missing_in_new": True, "qp_identical": False}
            continue
        entry = {name: compare_timing([o["times"][name] for o in old], [n["times"][name] for n in new])
                 for name in old[0]["times"]}
        entry["qp_old"] = [o["qp"] for o in old]  # QP solves per control step / per solve, per round
        entry["qp_new"] = [n["qp"] for n in new]
        entry["qp_identical"] = entry["qp_old"] == entry["qp_new"]
        out[cfg] = entry
    for cfg in runs["new"][0]:
        out.setdefault(cfg, {"missing_in_old": True, "qp_identical": False})
    return out


def summarize(cmp: dict) -> dict:
    """Median ratio over all timing figures; the largest |ratio - 1| next to its own noise."""
    figs = [(f"{cfg}/{name}", v) for cfg, e in cmp.items() for name, v in e.items()
            if isinstance(v, dict) and v.get("ratio") is not None]
    ratios = [v["ratio"] for _, v in figs]
    worst_name, worst = max(figs, key=lambda f: abs(f[1]["ratio"] - 1.0)) if figs else (None, {})
    inside = [n for n, v in figs if v["noise_min"] <= 1.0 <= v["noise_max"]]
    return {"timing_figures": len(figs), "median_ratio": _r(statistics.median(ratios)) if ratios else None,
            "min_ratio": _r(min(ratios)) if ratios else None, "max_ratio": _r(max(ratios)) if ratios else None,
            "largest_deviation": {"figure": worst_name, "ratio": worst.get("ratio"),
                                  "abs_ratio_minus_1": _r(abs(worst["ratio"] - 1.0)) if figs else None,
                                  "noise_min": worst.get("noise_min"), "noise_max": worst.get("noise_max")},
            "figures_with_1_inside_round_spread": len(inside),
            "qp_identical_all": all(e.get("qp_identical", False) for e in cmp.values())}


def table(cmp: dict, summary: dict) -> str:
    """Human-readable table: one line per timing figure [ms]."""
    lines = [f"{'figure':48s} {'old':>8s} {'new':>8s} {'new/old':>8s} {'noise min':>9s} {'noise max':>9s}"
             f"  qp identical   [ms]"]
    for cfg, e in cmp.items():
        for name, v in e.items():
            if isinstance(v, dict):
                lines.append(f"{cfg + '/' + name:48s} {v['old_ms']:8.3f} {v['new_ms']:8.3f} "
                             f"{v['ratio']:8.3f} {v['noise_min']:9.3f} {v['noise_max']:9.3f}  {e['qp_identical']}")
        if "qp_old" not in e:
            lines.append(f"{cfg:48s} missing in one tree")
    d = summary["largest_deviation"]
    lines.append(f"median ratio new/old over {summary['timing_figures']} timing figures: {summary['median_ratio']}"
                 f" (min {summary['min_ratio']}, max {summary['max_ratio']})")
    lines.append(f"largest |ratio - 1|: {d['figure']} ratio {d['ratio']}, per-round noise "
                 f"[{d['noise_min']}, {d['noise_max']}]; QPs identical everywhere: {summary['qp_identical_all']}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", type=Path, required=True, help="old source tree (e.g. a git worktree)")
    ap.add_argument("--new", type=Path, default=Path("."), help="new source tree (default .)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--controller-repeat", type=int, default=1, help="bench_controller.py --repeat")
    ap.add_argument("--games-count", type=int, default=20, help="bench_games.py --count")
    args = ap.parse_args(argv)
    if args.rounds < 1 or args.controller_repeat < 1 or args.games_count < 1:
        ap.error("--rounds, --controller-repeat and --games-count must be >= 1")
    old, new = args.old.resolve(), args.new.resolve()
    scripts = {"bench_controller.py": ["--repeat", str(args.controller_repeat)],
               "bench_games.py": ["--count", str(args.games_count)]}
    try:
        check_import(old)
        check_import(new)
        runs = run_rounds(old, new, args.rounds, scripts)
    except BenchFailure as exc:
        print(exc, file=sys.stderr)
        return 2
    cmp = compare(runs)
    summary = summarize(cmp)
    print(table(cmp, summary), file=sys.stderr)
    print(json.dumps({"benchmark": "interleaved", "old": str(old), "new": str(new), "rounds": args.rounds,
                      "controller_repeat": args.controller_repeat, "games_count": args.games_count,
                      "results": cmp, "summary": summary}, separators=(",", ":")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
