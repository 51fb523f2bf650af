"""The demand window of a user's route file: a copy in the run folder holding only the demand that
departs within [begin, begin + duration) [s], so that SUMO inserts nothing after the window while
the run drains; and the counts of the file's demand for the run's summary."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

from intersection_cosim.network.xml_files import xml_root
from intersection_cosim.scenario.model import Scenario
from intersection_cosim.scenario.sumocfg import DEMAND_TAGS, VEHICLE_TAGS, in_window, route_demand, sumo_number

WINDOW_FILE = "demand.rou.xml"  # the windowed copy of the user's (first) route file, in the run folder


def window_name(n: int) -> str:
    """The run folder's windowed copy of the user's ``n``-th route file (from 0)."""
    return WINDOW_FILE if n == 0 else WINDOW_FILE.replace(".rou.xml", f"-{n + 1}.rou.xml")


def _kept(el: ET.Element, begin: float, end: float) -> bool:
    """Whether demand element ``el`` departs within [begin, end) [s]; a flow is kept (and cut to
    the window) if its interval overlaps it; an element without a numeric time is kept."""
    if el.tag.endswith("Flow") or el.tag == "flow":
        start, stop = sumo_number(el.get("begin", "0")), sumo_number(el.get("end"))
        if start is None:
            return True
        if start >= end or (stop is not None and stop <= begin):
            return False
        if stop is None or stop > end:
            if el.get("number") is None:
                el.set("end", f"{end:g}")
        return True
    depart = sumo_number(el.get("depart"))
    return depart is None or in_window(depart, begin, end)


def write_window(scn: Scenario, folder: Path) -> tuple[str, ...] | None:
    """Write the windowed copy of each of ``scn``'s route files into ``folder`` (one per file, so
    each stays sorted by departure as SUMO reads it); return their names (relative to ``folder``),
    or None when the run reads the user's files themselves (none, or ``keep_all_demand``)."""
    s, routes = scn.scenario, scn.network.routes
    if not routes or s.keep_all_demand:
        return None
    begin, end = s.begin, s.begin + s.duration  # [s]
    names = []
    for n, path in enumerate(routes):
        root = xml_root(path)
        for el in [el for el in root if el.tag in DEMAND_TAGS and not _kept(el, begin, end)]:
            root.remove(el)
        ET.ElementTree(root).write(folder / window_name(n), encoding="UTF-8", xml_declaration=True)
        names.append(window_name(n))
    return tuple(names)


def file_counts(scn: Scenario) -> dict:
    """The vehicles of ``scn``'s route files: ``in_files`` (every vehicle and trip in them, and
    every vehicle of their flows; persons are not counted) and ``in_window`` (those departing
    within [begin, begin + duration) [s]); a random flow counts its expected number; zeros
    without any."""
    s = scn.scenario
    demand = [d for path in scn.network.routes for d in route_demand(path, VEHICLE_TAGS)]
    return {"in_files": round(sum(d.count(-math.inf, math.inf) for d in demand)),
            "in_window": round(sum(d.count(s.begin, s.begin + s.duration) for d in demand))}
