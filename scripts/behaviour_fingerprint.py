"""Fingerprint of the game controller's closed-loop behaviour, to show a refactor changed nothing.

Runs Case 1 A-D and Case 2 A-B under ``nash`` and ``stackelberg``, each with and without the
event trigger, and a 120 s demand window of ``demand_balanced_high.toml`` under both equilibria,
and a 120 s demand window of the shipped networks ``grid_high`` (nine junctions) and
``corridor_medium`` (three) under ``nash``, one controller per junction (``--set network`` runs
only these, ``--set paper`` only the others), all at a 2000 ms step budget (which no step comes near, so the anytime schedule never cuts work
and the runs do not depend on the machine's load). Each run's ``trajectories.csv`` and
``vehicles.csv`` and the ``games``, ``iterations`` and ``qp_solves`` columns of ``steps.csv`` are
hashed (SHA-256) into ``fingerprint.json`` in the output folder.

    python scripts/behaviour_fingerprint.py --out /tmp/fp_new          # run and fingerprint
    python scripts/behaviour_fingerprint.py --out /tmp/fp_net --set network
    python scripts/behaviour_fingerprint.py --compare /tmp/fp_old /tmp/fp_new

``--compare`` prints one line per run that differs and exits 1 if any does (0 when all agree).
Run the first form once on the commit before a change (for example from a ``git worktree``) and
once after it.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import io
import json
import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
PAPER_CASES = ("case1_A", "case1_B", "case1_C", "case1_D", "case2_A", "case2_B")
EQUILIBRIA = ("nash", "stackelberg")
DEMAND = "demand_balanced_high"
NETWORKS = ("grid_high", "corridor_medium")
DEMAND_DURATION = 120.0  # [s] demand window of the demand and network runs
BUDGET_MS = 2000.0  # [ms] never binds
STEP_COLUMNS = ("time", "games", "iterations", "qp_solves")


def _configs(which: str = "all"):
    if which in ("all", "network"):
        for net in NETWORKS:
            yield f"{net}-nash-etm", net, "nash", True
    if which == "network":
        return
    for case in PAPER_CASES:
        for eq in EQUILIBRIA:
            for etm in (True, False):
                yield f"{case}-{eq}-{'etm' if etm else 'noetm'}", case, eq, etm
    for eq in EQUILIBRIA:
        yield f"{DEMAND}-{eq}-etm", DEMAND, eq, True


def _digest(run: Path) -> dict[str, str]:
    out = {name: hashlib.sha256((run / name).read_bytes()).hexdigest()
           for name in ("trajectories.csv", "vehicles.csv")}
    steps = pd.read_csv(run / "steps.csv")[list(STEP_COLUMNS)]
    buf = io.StringIO()
    steps.to_csv(buf, index=False)
    out["steps.csv[games,iterations,qp_solves]"] = hashlib.sha256(buf.getvalue().encode()).hexdigest()
    return out


def fingerprint(out: Path, which: str = "all") -> dict:
    from intersection_cosim.experiments.run import run_scenario
    from intersection_cosim.scenario import load_scenario, with_overrides

    out.mkdir(parents=True, exist_ok=True)
    result = {}
    for name, case, eq, etm in _configs(which):
        scn = with_overrides(load_scenario(ROOT / "scenarios" / f"{case}.toml"), controller=eq, etm=etm,
                             budget_ms=BUDGET_MS)
        if case == DEMAND or case in NETWORKS:
            scn = dataclasses.replace(scn, scenario=dataclasses.replace(scn.scenario, duration=DEMAND_DURATION))
        run_scenario(scn, out / name)
        result[name] = _digest(out / name)
        print(f"{name}: {result[name]['trajectories.csv'][:12]}", file=sys.stderr)
    (out / "fingerprint.json").write_text(json.dumps(result, indent=1, sort_keys=True) + "\n")
    return result


def compare(a: Path, b: Path) -> int:
    fa = json.loads((a / "fingerprint.json").read_text())
    fb = json.loads((b / "fingerprint.json").read_text())
    differ = 0
    for name in sorted(set(fa) ^ set(fb)):
        print(f"{name}: only in {a if name in fa else b} (not compared)")
    for name in sorted(set(fa) & set(fb)):
        if fa.get(name) != fb.get(name):
            files = sorted(k for k in set(fa.get(name, {})) | set(fb.get(name, {}))
                           if fa.get(name, {}).get(k) != fb.get(name, {}).get(k))
            print(f"{name}: differs in {', '.join(files)}")
            differ += 1
    print(f"{len(set(fa) & set(fb)) - differ} identical, {differ} different")
    return 1 if differ else 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    group = ap.add_mutually_exclusive_group(required=True)
    group.add_argument("--out", type=Path, help="folder for the runs and fingerprint.json")
    group.add_argument("--compare", type=Path, nargs=2, metavar=("OLD", "NEW"), help="two fingerprint folders")
    ap.add_argument("--set", choices=("all", "paper", "network"), default="all",
                    help="which runs: all, the single-junction ones (paper) or the networks (network)")
    args = ap.parse_args(argv)
    if args.compare:
        return compare(*args.compare)
    fingerprint(args.out, args.set)
    return 0


if __name__ == "__main__":
    sys.exit(main())
