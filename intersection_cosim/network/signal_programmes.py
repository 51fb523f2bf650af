"""The traffic-light programmes of a SUMO net read with sumolib: which links each signal of a
junction controls and its green phases (for max-pressure), and SUMO's actuated programme built
from the net's own phases (for the actuated-signal baseline).
"""

from __future__ import annotations

import functools
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import sumolib

ACTUATED_PROGRAMME = "actuated"  # [-] programID of the actuated programmes a run loads


@dataclass(frozen=True)
class SignalPlan:
    """One traffic light of a junction: its links and the net's green phases."""

    tls: str  # [-] SUMO traffic-light id
    links: tuple[tuple[str, str], ...]  # [-] (incoming lane, outgoing lane) per link index
    greens: tuple[str, ...]  # [-] the state strings of the net programme's green phases (no 'y')


@functools.lru_cache(maxsize=8)
def _net_with_programmes(path: str, mtime_ns: int) -> sumolib.net.Net:
    return sumolib.net.readNet(path, withPrograms=True)


def net_with_programmes(path: str) -> sumolib.net.Net:
    """The sumolib net of ``path`` with its traffic-light programmes, read once per file version."""
    return _net_with_programmes(str(path), os.stat(path).st_mtime_ns)


def _is_green(state: str) -> bool:
    """A green phase: some link has green ('G' or 'g') and none yellow."""
    return "y" not in state.lower() and ("G" in state or "g" in state)


def _touches(tls, junctions: set[str]) -> bool:
    return any(conn[0].getEdge().getToNode().getID() in junctions for conn in tls.getConnections())


def junction_signals(net_file: str, junction: str) -> tuple[SignalPlan, ...]:
    """The traffic lights controlling links into ``junction`` (none: an unsignalized junction),
    each with its links and the green phases of the net's first programme."""
    net = net_with_programmes(net_file)
    plans = []
    for tls in net.getTrafficLights():
        if not _touches(tls, {junction}):
            continue
        size = 1 + max(conn[2] for conn in tls.getConnections())
        links: list[tuple[str, str]] = [("", "")] * size
        for in_lane, out_lane, index in tls.getConnections():
            links[index] = (in_lane.getID(), out_lane.getID())
        programmes = tls.getPrograms()
        phases = next(iter(programmes.values())).getPhases() if programmes else []
        greens = tuple(dict.fromkeys(ph.state for ph in phases if _is_green(ph.state)))
        if greens:
            plans.append(SignalPlan(tls.getID(), tuple(links), greens))
    return tuple(plans)


def actuated_programmes(net_file: str, junctions: tuple[str, ...], min_green: float, max_green: float,
                        max_gap: float, detector_gap: float) -> ET.Element:
    """An ``<additional>`` with SUMO's actuated programme (type "actuated", programID
    ACTUATED_PROGRAMME) of every traffic light of ``junctions``: the net's own phases in their
    order; a green phase extends by gap ([s] ``max_gap`` between vehicles at SUMO's own detectors,
    ``detector_gap`` [s] upstream of the stop line) between its minDur and maxDur (the net's, else
    ``min_green``, ``max_green`` [s]); yellow and all-red phases keep their durations."""
    net = net_with_programmes(net_file)
    root = ET.Element("additional")
    for tls in net.getTrafficLights():
        programmes = tls.getPrograms()
        if not programmes or not _touches(tls, set(junctions)):
            continue
        programme = next(iter(programmes.values()))
        logic = ET.SubElement(root, "tlLogic", id=tls.getID(), type="actuated", programID=ACTUATED_PROGRAMME,
                              offset="0")
        ET.SubElement(logic, "param", key="max-gap", value=f"{max_gap:g}")
        ET.SubElement(logic, "param", key="detector-gap", value=f"{detector_gap:g}")
        for ph in programme.getPhases():
            attrs = {"duration": f"{ph.duration:g}", "state": ph.state}
            if _is_green(ph.state):
                low = ph.minDur if ph.minDur is not None and ph.minDur > 0 else min_green
                high = ph.maxDur if ph.maxDur is not None and ph.maxDur > 0 else max(max_green, ph.duration)
                attrs.update(minDur=f"{min(low, ph.duration):g}", maxDur=f"{max(high, ph.duration):g}")
            ET.SubElement(logic, "phase", attrs)
    return root
