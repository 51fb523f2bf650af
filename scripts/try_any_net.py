"""Try the game controller on junctions of any SUMO net, with demand made up on the spot.

For each chosen junction (default: every one that ``intersection-cosim junctions NET`` lists as
manageable, up to ``--max-junctions``), builds a scenario with one Poisson flow for every
(incoming edge, outgoing edge) pair the junction connects for passenger cars, ``--rate`` veh/h in
all, runs it for ``--duration`` s with the controller, and prints one line per junction: vehicles
departed / arrived, SUMO's collision count and the share of control steps that
missed the step budget. The last line of stdout is one JSON object with every junction's figures.

    python scripts/try_any_net.py '$SUMO_HOME/tools/game/grid6/grid6.net.xml' --max-junctions 3
    python scripts/try_any_net.py my_osm.net.xml --junction cluster_123_456 --controller stackelberg
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

from intersection_cosim.errors import InputError
from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.network.junction_net import drivable_connections, junction_table
from intersection_cosim.scenario import scenario_from_dict
from intersection_cosim.scenario.network import read_net, resolve_path


def od_pairs(net, junction: str) -> list[tuple[str, str]]:
    """(incoming edge, outgoing edge) of every connection of ``junction`` a passenger car may use."""
    node = net.getNode(junction)
    pairs = {(c.getFrom().getID(), c.getTo().getID()) for c in drivable_connections(node)}
    return sorted(pairs)


def scenario(net_file: str, junction: str, pairs, rate: float, duration: float, controller: str,
             seed: int, budget_ms: float) -> dict:
    """The scenario of one junction: [network] on it and one flow per pair, ``rate`` [veh/h] in all."""
    flows = [{"from": a, "to": b, "rate": rate / len(pairs), "kappa": {"dist": "uniform", "low": 0.2, "high": 0.8},
              "begin": 0.0, "end": duration, "id": f"f{i}"} for i, (a, b) in enumerate(pairs)]
    return {"scenario": {"name": f"try_{junction}", "duration": duration, "drain": 120.0, "step_length": 0.05,
                         "seed": seed},
            "controller": {"kind": controller, "budget_ms": budget_ms},
            "network": {"file": net_file, "junctions": [junction]},
            "flow": flows}


def try_junction(net_file: str, junction: str, args) -> dict:
    net = read_net(net_file)
    pairs = od_pairs(net, junction)
    data = scenario(net_file, junction, pairs, args.rate, args.duration, args.controller, args.seed, args.budget_ms)
    with tempfile.TemporaryDirectory(prefix="try_any_net_") as tmp:
        summary = run_scenario(scenario_from_dict(data, f"<{junction}>"), Path(tmp) / "run")
    c = summary["counts"]
    return {"junction": junction, "pairs": len(pairs), "departed": c["departed"], "arrived": c["arrived"],
            "collisions": c["collisions"], "deadline_misses": c["deadline_misses"],
            "control_steps": c["control_steps"],
            "miss_share": round(c["deadline_misses"] / max(c["control_steps"], 1), 4)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("net", help="a SUMO .net.xml ($SUMO_HOME expanded)")
    ap.add_argument("--junction", action="append", help="junction id (repeatable; default: the manageable ones)")
    ap.add_argument("--max-junctions", type=int, default=5)
    ap.add_argument("--controller", default="nash")
    ap.add_argument("--rate", type=float, default=600.0, help="[veh/h] over the junction (default 600)")
    ap.add_argument("--duration", type=float, default=120.0, help="[s] demand window (default 120)")
    ap.add_argument("--budget-ms", type=float, default=20.0, help="[ms] step budget (default 20)")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    try:
        net_file = resolve_path("--net", "net", args.net, Path.cwd())
        table = junction_table(net_file)
        chosen = args.junction or list(table.loc[table["manageable"].astype(bool), "id"])[:args.max_junctions]
        if not chosen:
            raise InputError(net_file, "junctions", "", "no manageable junction in the net "
                             "(intersection-cosim junctions NET --all says why for each)")
        rows = []
        for junction in chosen:
            row = try_junction(net_file, junction, args)
            rows.append(row)
            print(f"{junction}: {row['pairs']} od pairs, {row['arrived']}/{row['departed']} arrived, "
                  f"{row['collisions']} collisions, {row['miss_share']:.2%} of steps over budget", file=sys.stderr)
    except InputError as exc:
        print(f"try_any_net: error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps({"net": net_file, "controller": args.controller, "junctions": rows}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
