"""Generate the intersection net: plain XML (nodes, edges, connections) -> netconvert.

netconvert is called with an argument list (never through a shell). Its output keeps the paper's
frame: the centre node at the origin and ``--offset.disable-normalization`` so nothing is shifted.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import sumolib

from intersection_cosim.errors import InputError
from intersection_cosim.network.spec import (
    ARM_COUNTS,
    ARM_DIRECTION,
    JUNCTION_TYPES,
    LANE_COUNTS,
    IntersectionSpec,
)

NET_FILE = "intersection.net.xml"
PLAIN_FILES = ("intersection.nod.xml", "intersection.edg.xml", "intersection.con.xml")


def _write_xml(root: ET.Element, path: Path) -> None:
    ET.indent(root)
    ET.ElementTree(root).write(path, encoding="UTF-8", xml_declaration=True)


def plain_xml(spec: IntersectionSpec) -> dict[str, ET.Element]:
    """The three plain-XML documents that describe the intersection.

    Only the arms of ``spec.arms_present()`` are written, and from each approach lane exactly the
    connections of ``spec.lane_use(approach)`` (so netconvert guesses none).
    """
    arms = spec.arms_present()
    lane_index = spec.lane_index()
    nodes = ET.Element("nodes")
    ET.SubElement(nodes, "node", id="C", x="0.00", y="0.00", type=spec.junction_type,
                  radius="0.00")
    for arm in arms:
        dx, dy = ARM_DIRECTION[arm]
        ET.SubElement(nodes, "node", id=arm, x=f"{dx * spec.approach_length:.2f}",
                      y=f"{dy * spec.approach_length:.2f}", type="dead_end")

    edges = ET.Element("edges")
    for arm in arms:
        for direction, (src, dst) in (("in", (arm, "C")), ("out", ("C", arm))):
            ET.SubElement(edges, "edge", id=f"{arm}_{direction}", attrib={"from": src, "to": dst},
                          numLanes=str(spec.lanes_per_road), speed=f"{spec.speed_limit:.2f}",
                          width=f"{spec.lane_width:.2f}", priority="1")

    connections = ET.Element("connections")
    for arm in arms:
        for lane, moves in spec.lane_use(arm).items():
            for movement, exit_lanes in moves.items():
                for exit_lane in exit_lanes:
                    ET.SubElement(connections, "connection", attrib={
                        "from": f"{arm}_in", "to": f"{spec.exit_arm(arm, movement)}_out",
                        "fromLane": str(lane_index[lane]), "toLane": str(lane_index[exit_lane])})
    return {"intersection.nod.xml": nodes, "intersection.edg.xml": edges,
            "intersection.con.xml": connections}


def netconvert_args() -> list[str]:
    """netconvert's argument list, run inside the folder of the plain files.

    Relative file names keep temporary folder names out of the net's header, so the same spec
    always gives the same net apart from the generation time stamp.
    """
    return [
        sumolib.checkBinary("netconvert"),
        "--node-files", PLAIN_FILES[0],
        "--edge-files", PLAIN_FILES[1],
        "--connection-files", PLAIN_FILES[2],
        "--output-file", NET_FILE,
        "--offset.disable-normalization", "true",
        "--no-turnarounds", "true",
        "--junctions.corner-detail", "8",
        "--junctions.internal-link-detail", "20",
        "--output.street-names", "false",
        "--no-warnings", "true",
        "--write-license", "false",
    ]


def build_network(out_dir: str | Path, spec: IntersectionSpec | None = None) -> Path:
    """Write the plain XML and the SUMO net into ``out_dir``; return the net file.

    The files are built in a temporary folder next to ``out_dir`` and moved in only when
    netconvert succeeds, so a failure leaves nothing half-written.
    """
    spec = spec or IntersectionSpec()
    if spec.arms not in ARM_COUNTS:
        raise InputError("--arms", "arms", spec.arms, f"must be one of {', '.join(map(str, ARM_COUNTS))}")
    if spec.lanes_per_road not in LANE_COUNTS:
        raise InputError("--lanes", "lanes_per_road", spec.lanes_per_road,
                         f"must be one of {', '.join(map(str, LANE_COUNTS))}")
    if spec.junction_type not in JUNCTION_TYPES:
        raise InputError("--junction-type", "junction_type", spec.junction_type,
                         f"must be one of {', '.join(JUNCTION_TYPES)}")
    if not spec.approach_length > 3 * spec.half_width:
        raise InputError("--approach-length", "approach_length", spec.approach_length,
                         f"must be more than {3 * spec.half_width:g} m")
    out_dir = Path(out_dir)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=".net-", dir=out_dir))
    except OSError as exc:
        raise InputError("--out", "out", str(out_dir), f"cannot write there ({exc.strerror})") from None
    try:
        for name, root in plain_xml(spec).items():
            _write_xml(root, tmp / name)
        proc = subprocess.run(netconvert_args(), cwd=tmp, capture_output=True, text=True, check=False)
        if proc.returncode != 0:
            raise RuntimeError(f"netconvert failed: {proc.stderr.strip()}")
        for name in (*PLAIN_FILES, NET_FILE):
            (tmp / name).replace(out_dir / name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out_dir / NET_FILE


def net_body(net_file: str | Path) -> str:
    """The net's XML without netconvert's leading comment (which holds the generation time)."""
    text = Path(net_file).read_text(encoding="utf-8")
    start = text.find("<!--")
    end = text.find("-->", start)
    return text[:start] + text[end + 3:] if start != -1 and end != -1 else text
