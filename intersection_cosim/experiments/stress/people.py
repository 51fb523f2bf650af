"""The pedestrian axis of a stress run: people walking over the crossings of the managed junctions.

With ``pedestrian_rate`` drawn (persons/h per kerb-to-kerb crossing, network/kerb_walks.py), every
kerb-to-kerb crossing of a managed junction gets two ``personFlow`` elements, one each way at half
the rate, over the demand window. The run's routes file is the scenario's own (its vehicles and
people kept) with these flows first (a scenario with several route files keeps them and gets the
flows in a file of their own after them); it is written into the stress folder as
``people/<run id>.rou.xml`` and named by the run's scenario file as ``[network] routes``, so the
run's failure file replays it while the stress folder exists. The axis is drawn only where a
managed junction has crossings and the controller yields to pedestrians (the others refuse a
routes file with people: experiments/run_inputs.py).
"""

from __future__ import annotations

import copy
import xml.etree.ElementTree as ET
from pathlib import Path

from intersection_cosim.control import registry
from intersection_cosim.experiments.stress.runs import write_atomic
from intersection_cosim.network.kerb_walks import KerbWalk, kerb_walks
from intersection_cosim.scenario.model import Scenario

AXIS = "pedestrian_rate"
PEOPLE_DIR = "people"  # in the stress folder (and its shrink folder): the runs' routes files with people
ID_PREFIX = "stress_ped"  # ids of the drawn person flows: stress_ped<k>_<a|b>


def walks(scn: Scenario) -> tuple[KerbWalk, ...]:
    """The kerb-to-kerb walks over the managed junctions' crossings (none on the generated net,
    without crossings, or for a controller that does not yield to pedestrians)."""
    if scn.network.file is None:
        return ()
    found = kerb_walks(str(scn.network.file), tuple(scn.network.junctions))
    if not found:
        return ()
    controller = registry.create(scn.controller.kind, scn.controller_settings, scn.scenario.junction_type)
    return found if controller.yields_to_pedestrians else ()


def routes_text(scn: Scenario, rate: float, duration: float) -> str | None:
    """The routes XML of a run with ``rate`` [persons/h] over each kerb-to-kerb crossing for
    ``duration`` [s] and the scenario's own routes file; None: no one is drawn (rate 0, no walks)."""
    found = walks(scn)
    if rate <= 0 or not found:
        return None
    own = scn.network.routes
    root = ET.parse(own[0]).getroot() if len(own) == 1 else ET.Element("routes")
    root = copy.deepcopy(root)
    for k, walk in enumerate(found):
        for n, (a, pa, b, pb) in enumerate(((walk.start, walk.depart_pos, walk.end, walk.arrival_pos),
                                            (walk.end, walk.arrival_pos, walk.start, walk.depart_pos))):
            flow = ET.Element("personFlow", id=f"{ID_PREFIX}{k}_{'ab'[n]}", begin="0", end=f"{duration:g}",
                              perHour=f"{rate / 2:g}", departPos=f"{pa:g}")
            ET.SubElement(flow, "walk", attrib={"from": a, "to": b, "arrivalPos": f"{pb:g}"})
            root.insert(2 * k + n, flow)
    ET.indent(root)
    return ET.tostring(root, encoding="unicode") + "\n"


def with_people(data: dict, scn: Scenario, draw: dict[str, float], duration: float, path: Path) -> dict:
    """``data`` (a run's scenario dict) with the drawn people: their routes file written to ``path``
    (only if it changed) and named as ``[network] routes``; ``data`` itself without a draw."""
    text = routes_text(scn, draw.get(AXIS, 0.0), duration)
    if text is None:
        return data
    if not path.is_file() or path.read_text() != text:
        write_atomic(path, text)
    own = scn.network.routes
    routes = str(path.resolve()) if len(own) <= 1 else [*own, str(path.resolve())]
    return {**data, "network": {**data.get("network", {}), "routes": routes}}
