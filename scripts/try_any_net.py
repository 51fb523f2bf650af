"""Try the game controller on junctions of any SUMO net, with demand made up on the spot.

For each chosen junction (default: every one that ``intersection-cosim junctions NET`` lists as
manageable, up to ``--max-junctions``), builds a scenario with one Poisson flow for every
(incoming edge, outgoing edge) pair the junction connects for passenger cars, ``--rate`` veh/h in
all, runs it for ``--duration`` s with the controller, and prints one line per junction: vehicles
departed / arrived, SUMO's collision count and the share of control steps that
missed the step budget. The last line of stdout is one JSON object with every junction's figures.

``--people RATE`` [persons/h] also has people walk round each junction that has pedestrian
crossings: one person flow from every road in with a sidewalk to every road out with one on
another arm (a walk SUMO's pedestrian router can route), each starting 30 m before the junction
and ending 30 m past it, so that each walk crosses the crossings between the two arms; the
lines then also give the people, the collisions with them and the vehicles held back for them.

    python scripts/try_any_net.py '$SUMO_HOME/tools/game/grid6/grid6.net.xml' --max-junctions 3
    python scripts/try_any_net.py my_osm.net.xml --junction cluster_123_456 --controller stackelberg
    python scripts/try_any_net.py '$SUMO_HOME/tools/game/DRT/osm.net.xml' --people 240 --rate 480
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
import tempfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

import sumolib

from intersection_cosim.errors import InputError
from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.network.crossings import junction_crossings
from intersection_cosim.network.junction_net import drivable_connections, junction_table
from intersection_cosim.scenario import scenario_from_dict
from intersection_cosim.scenario.network import read_net, resolve_path, sumo_refusal


def od_pairs(net, junction: str) -> list[tuple[str, str]]:
    """(incoming edge, outgoing edge) of every connection of ``junction`` a passenger car may use."""
    node = net.getNode(junction)
    pairs = {(c.getFrom().getID(), c.getTo().getID()) for c in drivable_connections(node)}
    return sorted(pairs)


WALK_REACH = 30.0  # [m] a walk starts this far before the junction and ends this far past it
SAME_ARM = math.radians(30.0)  # [rad] roads leaving the junction this close in heading are one arm


def _heading_out(edge, junction) -> float:
    """[rad] the heading, away from ``junction``, of the road's end at it."""
    shape = edge.getShape()
    (x0, y0), (x1, y1) = (shape[-1], shape[-2]) if edge.getToNode() is junction else (shape[0], shape[1])
    return math.atan2(y1 - y0, x1 - x0)


def _walkable(edge) -> bool:
    return any(lane.allows("pedestrian") for lane in edge.getLanes())


def walk_pairs(net_file: str, junction: str) -> list[tuple[str, str, float, float]]:
    """(road in, road out, departPos [m], arrivalPos [m]) of the walks round ``junction``: every
    road in and road out with a sidewalk, on different arms, with a pedestrian route; none if the
    junction has no crossing."""
    if not junction_crossings(net_file, (junction,)):
        return []
    net = sumolib.net.readNet(net_file, withPedestrianConnections=True)
    node = net.getNode(junction)
    ins = [e for e in node.getIncoming() if not e.isSpecial() and _walkable(e)]
    outs = [e for e in node.getOutgoing() if not e.isSpecial() and _walkable(e)]
    walks = []
    for a in ins:
        for b in outs:
            turn = abs((_heading_out(a, node) - _heading_out(b, node) + math.pi) % (2 * math.pi) - math.pi)
            if turn < SAME_ARM or net.getShortestPath(a, b, vClass="pedestrian", ignoreDirection=True)[0] is None:
                continue
            walks.append((a.getID(), b.getID(), max(a.getLength() - WALK_REACH, 0.0), min(WALK_REACH, b.getLength())))
    return walks


def _walk(a: str, b: str, depart_pos: float, arrival_pos: float) -> str:
    """The departPos attribute [m] and the walk element of a person or personFlow."""
    return (f'departPos="{depart_pos:.2f}"><walk from={quoteattr(a)} to={quoteattr(b)} '
            f'arrivalPos="{arrival_pos:.2f}"/>')


def routable_walks(net_file: str, walks: list, folder: Path) -> list:
    """The walks SUMO's own pedestrian router can route (sumolib's may find a way SUMO does not):
    one person per walk departs at 0; each that SUMO refuses is dropped and the rest tried again."""
    walks = list(walks)
    probe = folder / "walk_probe.rou.xml"
    while walks:
        probe.write_text("\n".join(["<routes>"] + [f'    <person id="w{i}" depart="0" {_walk(*w)}</person>'
                                                    for i, w in enumerate(walks)] + ["</routes>", ""]))
        refused = re.search(r"for person 'w(\d+)'", sumo_refusal(net_file, (str(probe),)) or "")
        if refused is None:
            return walks
        del walks[int(refused.group(1))]
    return walks


def people_routes(walks, rate: float, duration: float, out: Path) -> Path:
    """A SUMO route file with one personFlow per walk, ``rate`` [persons/h] in all (Poisson)."""
    lines = ["<routes>"]
    for i, (a, b, depart_pos, arrival_pos) in enumerate(walks):
        lines.append(f'    <personFlow id="p{i}" begin="0" end="{duration}" probability="{rate / len(walks) / 3600.0:.6f}" '
                     f'{_walk(a, b, depart_pos, arrival_pos)}</personFlow>')
    out.write_text("\n".join(lines + ["</routes>", ""]))
    return out


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
        walks = routable_walks(net_file, walk_pairs(net_file, junction), Path(tmp)) if args.people > 0 else []
        if walks:
            data["network"]["routes"] = str(people_routes(walks, args.people, args.duration, Path(tmp) / "people.rou.xml"))
        summary = run_scenario(scenario_from_dict(data, f"<{junction}>"), Path(tmp) / "run")
    c = summary["counts"]
    row = {"junction": junction, "pairs": len(pairs), "departed": c["departed"], "arrived": c["arrived"],
           "collisions": c["collisions"], "deadline_misses": c["deadline_misses"],
           "control_steps": c["control_steps"],
           "miss_share": round(c["deadline_misses"] / max(c["control_steps"], 1), 4)}
    if args.people > 0:
        row.update(walks=len(walks), pedestrian_collisions=c.get("pedestrian_collisions", 0),
                   pedestrian_holds=c.get("pedestrian_holds", 0))
    return row


def _line(row: dict) -> str:
    text = (f"{row['junction']}: {row['pairs']} od pairs, {row['arrived']}/{row['departed']} arrived, "
            f"{row['collisions']} collisions, {row['miss_share']:.2%} of steps over budget")
    if "walks" in row:
        text += (f"; {row['walks']} walks, {row['pedestrian_collisions']} with a person, "
                 f"{row['pedestrian_holds']} vehicle-steps held for people")
    return text


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
    ap.add_argument("--people", type=float, default=0.0,
                    help="[persons/h] walking round each junction with crossings (default 0: none)")
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
            print(_line(row), file=sys.stderr)
    except InputError as exc:
        print(f"try_any_net: error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps({"net": net_file, "controller": args.controller, "junctions": rows}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
