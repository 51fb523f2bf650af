"""The demand window of a user's route file: a copy in the run folder holding only the demand that
departs within [begin, begin + duration) [s], so that SUMO inserts nothing after the window while
the run drains; and the counts of the file's demand for the run's summary."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import sumolib

from intersection_cosim.network.xml_files import xml_root
from intersection_cosim.scenario.model import Scenario
from intersection_cosim.scenario.sumocfg import DEMAND_TAGS, VEHICLE_TAGS, in_window, route_departs

WINDOW_FILE = "demand.rou.xml"  # the windowed copy of the user's route file, in the run folder


def _time(text: str | None) -> float | None:
    """[s] a SUMO time attribute, None if absent or not a number ("triggered")."""
    try:
        return float(sumolib.miscutils.parseTime(text))
    except (TypeError, ValueError):
        return None


def _kept(el: ET.Element, begin: float, end: float) -> bool:
    """Whether demand element ``el`` departs within [begin, end) [s]; a flow is kept (and cut to
    the window) if its interval overlaps it; an element without a numeric time is kept."""
    if el.tag.endswith("Flow") or el.tag == "flow":
        start, stop = _time(el.get("begin", "0")), _time(el.get("end"))
        if start is None:
            return True
        if start >= end or (stop is not None and stop <= begin):
            return False
        if stop is None or stop > end:
            if el.get("number") is None:
                el.set("end", f"{end:g}")
        return True
    depart = _time(el.get("depart"))
    return depart is None or in_window(depart, begin, end)


def write_window(scn: Scenario, folder: Path) -> str | None:
    """Write the windowed copy of ``scn``'s route file into ``folder``; return its name (relative to
    ``folder``), or None when the run reads the user's file itself (no route file, or
    ``keep_all_demand``)."""
    s, routes = scn.scenario, scn.network.routes
    if routes is None or s.keep_all_demand:
        return None
    root = xml_root(routes)
    begin, end = s.begin, s.begin + s.duration  # [s]
    for el in [el for el in root if el.tag in DEMAND_TAGS and not _kept(el, begin, end)]:
        root.remove(el)
    ET.ElementTree(root).write(folder / WINDOW_FILE, encoding="UTF-8", xml_declaration=True)
    return WINDOW_FILE


def file_counts(scn: Scenario) -> dict:
    """The vehicles of ``scn``'s route file: ``in_files`` (every vehicle, trip or flow in it; persons
    are not counted) and ``in_window`` (those departing within [begin, begin + duration) [s]);
    zeros without one."""
    s, routes = scn.scenario, scn.network.routes
    if routes is None:
        return {"in_files": 0, "in_window": 0}
    departs = route_departs(routes, VEHICLE_TAGS)
    return {"in_files": len(departs),
            "in_window": sum(in_window(t, s.begin, s.begin + s.duration) for t in departs)}
