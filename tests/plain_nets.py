"""Small SUMO nets for closed-loop tests, built by netconvert from plain node, edge and connection
lists (SUMO's plain XML formats)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import sumolib


def plain_net(folder: Path, name: str, nodes, edges, connections=(), speed: float = 13.89) -> Path:
    """``folder/<name>.net.xml`` built by netconvert (no U-turns) from ``nodes`` (id, x [m], y [m],
    type or None), ``edges`` (id, from node, to node, number of lanes), all with ``speed`` [m/s],
    and ``connections`` (from edge, to edge, from lane, to lane)."""
    (folder / f"{name}.nod.xml").write_text("<nodes>" + "".join(
        f'<node id="{n}" x="{x}" y="{y}"' + (f' type="{kind}"' if kind else "") + "/>"
        for n, x, y, kind in nodes) + "</nodes>")
    (folder / f"{name}.edg.xml").write_text("<edges>" + "".join(
        f'<edge id="{e}" from="{a}" to="{b}" numLanes="{lanes}" speed="{speed}"/>'
        for e, a, b, lanes in edges) + "</edges>")
    (folder / f"{name}.con.xml").write_text("<connections>" + "".join(
        f'<connection from="{a}" to="{b}" fromLane="{i}" toLane="{j}"/>'
        for a, b, i, j in connections) + "</connections>")
    net = folder / f"{name}.net.xml"
    subprocess.run([sumolib.checkBinary("netconvert"), "-n", f"{name}.nod.xml", "-e", f"{name}.edg.xml",
                    "-x", f"{name}.con.xml", "--no-turnarounds", "-o", net.name], cwd=folder, check=True,
                   capture_output=True)
    return net
