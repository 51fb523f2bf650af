"""How strongly kappa moves the paper cases' margins, for one or more candidate calibrations.

Plays Case 1 A-D and Case 2 A-B (scenarios/case*.toml) under nash and stackelberg in this one
process, each candidate a set of overrides of the scenario files' tables, and prints per run the
pairs' min TTC and PET [s], the safety filter's interventions, and then the issue-20 ratios
(B/A, C/A, D/A of Case 1's V1-V2 and V1-V3; B/A of Case 2's V1-V2) and V3's exit lane.

    python scripts/calibrate_kappa.py [--set model.k_lat=5 controller.game.w_accel=0.1 ...]...
        [--controllers nash,stackelberg] [--cases case1_A,...] [--out /tmp/cal]

Each ``--set`` is one candidate (its overrides separated by spaces); none: today's defaults.
"""

from __future__ import annotations

import argparse
import copy
import shlex
import tempfile
import tomllib
from pathlib import Path

import pandas as pd

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario.load import scenario_from_dict, with_overrides

ROOT = Path(__file__).resolve().parents[1]
CASES = ["case1_A", "case1_B", "case1_C", "case1_D", "case2_A", "case2_B"]
RATIOS = [("case1", "V1-V2", "B"), ("case1", "V1-V3", "B"), ("case1", "V1-V2", "C"),
          ("case1", "V1-V3", "C"), ("case1", "V1-V2", "D"), ("case2", "V1-V2", "B")]
GOAL = {"B": ">= 2.0", "C": ">= 1.1", "D": "<= 0.6"}


def parse_overrides(text: str) -> dict[tuple[str, ...], object]:
    """``table.key=value`` pairs (value parsed as TOML) -> {(table, ..., key): value}."""
    out = {}
    for item in shlex.split(text):
        key, value = item.split("=", 1)
        out[tuple(key.split("."))] = tomllib.loads(f"v = {value}")["v"]
    return out


def scenario(case: str, controller: str, overrides: dict):
    """The case's scenario file with ``controller`` and the overrides applied."""
    path = ROOT / "scenarios" / f"{case}.toml"
    data = copy.deepcopy(tomllib.loads(path.read_text()))
    data.setdefault("controller", {})["kind"] = controller
    for keys, value in overrides.items():
        table = data
        for k in keys[:-1]:
            table = table.setdefault(k, {})
        table[keys[-1]] = value
    # the report's 2000 ms step budget (scripts/reproduce_paper.py): no step comes near it, so the
    # runs do not depend on the machine's load
    return with_overrides(scenario_from_dict(data, str(path)), budget_ms=2000.0)


def play(case: str, controller: str, overrides: dict, out: Path) -> dict:
    """One run's margins, interventions, travel times and exit lanes."""
    folder = out / f"{case}-{controller}"
    summary = run_scenario(scenario(case, controller, overrides), folder, force=True)
    pairs = pd.read_csv(folder / "pairs.csv")
    vehicles = pd.read_csv(folder / "vehicles.csv").set_index("vehicle")
    row = {"case": case, "ctrl": controller,
           "interventions": summary["counts"]["safety_interventions"],
           "box": summary["counts"]["box_rule_clearances"],
           "collisions": summary["counts"]["collisions"],
           "V3_exit": vehicles["exit_lane"].get("V3", "")}
    for _, p in pairs.iterrows():
        name = f"{p['vehicle_a']}-{p['vehicle_b']}"
        row[f"ttc {name}"], row[f"pet {name}"] = p["min_ttc"], p["pet"]
    for vid, t in vehicles["travel_time"].items():
        row[f"tt {vid}"] = t
    return row


def ratios(table: pd.DataFrame) -> pd.DataFrame:
    """The issue's ratios per controller and metric."""
    idx = table.set_index(["case", "ctrl"])
    rows = []
    for ctrl in table["ctrl"].unique():
        for fam, pair, scen in RATIOS:
            for metric in ("ttc", "pet"):
                col = f"{metric} {pair}"
                try:
                    r = idx.loc[(f"{fam}_{scen}", ctrl), col] / idx.loc[(f"{fam}_A", ctrl), col]
                except KeyError:
                    r = float("nan")
                rows.append({"ctrl": ctrl, "ratio": f"{fam} {pair} {scen}/A {metric}", "value": round(r, 2),
                             "goal": GOAL[scen] if fam == "case1" else ">= 1.5"})
    return pd.DataFrame(rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--set", action="append", default=None, help="one candidate: 'table.key=value ...'")
    ap.add_argument("--controllers", default="nash,stackelberg")
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--out", default=None, help="folder for the runs (default: a temporary one)")
    args = ap.parse_args(argv)
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="calibrate_kappa-"))
    pd.set_option("display.width", 250)
    pd.set_option("display.max_columns", 40)
    for text in args.set or [""]:
        overrides = parse_overrides(text)
        rows = [play(c, ctrl, overrides, out) for ctrl in args.controllers.split(",") for c in args.cases.split(",")]
        table = pd.DataFrame(rows)
        print(f"=== candidate: {text or '(defaults)'}")
        print(table.round(2).to_string(index=False))
        r = ratios(table)
        print(r.pivot(index="ratio", columns="ctrl", values="value").assign(goal=r.groupby("ratio")["goal"].first()).to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
