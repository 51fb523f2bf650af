"""The lane-change gate of taken-over vehicles (sim/lane_change_hold.py) on a real SUMO run: a
vehicle that wants the lane beside it while another body stands there is held, and freed once the
place is clear; one that wants only the free side is not held (no lock)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import libsumo
import numpy as np
import pytest
import sumolib

from intersection_cosim.results.overlaps import overlapping_pairs
from intersection_cosim.sim.lane_change_hold import LaneChangeHold
from intersection_cosim.sim.sumo import LANE_CHANGE_MODE_STRATEGIC

VARS = (libsumo.VAR_POSITION, libsumo.VAR_SPEED, libsumo.VAR_ANGLE, libsumo.VAR_LANE_ID, libsumo.VAR_LANEPOSITION)


def _net(folder: Path) -> Path:
    """W -> A (three lanes: lane 0 only straight on to E, lanes 1 and 2 only left into N)."""
    (folder / "h.nod.xml").write_text('<nodes><node id="A" x="0" y="0" type="priority"/><node id="W" x="-300" y="0"/>'
                                      '<node id="E" x="150" y="0"/><node id="N" x="0" y="150"/></nodes>')
    (folder / "h.edg.xml").write_text('<edges><edge id="WA" from="W" to="A" numLanes="3" speed="13.89"/>'
                                      '<edge id="AE" from="A" to="E" numLanes="1" speed="13.89"/>'
                                      '<edge id="AN" from="A" to="N" numLanes="1" speed="13.89"/></edges>')
    (folder / "h.con.xml").write_text('<connections><connection from="WA" to="AE" fromLane="0" toLane="0"/>'
                                      '<connection from="WA" to="AN" fromLane="1" toLane="0"/>'
                                      '<connection from="WA" to="AN" fromLane="2" toLane="0"/></connections>')
    net = folder / "h.net.xml"
    subprocess.run([sumolib.checkBinary("netconvert"), "-n", "h.nod.xml", "-e", "h.edg.xml", "-x", "h.con.xml",
                    "--no-turnarounds", "-o", net.name], cwd=folder, check=True, capture_output=True)
    return net


def _drive(folder: Path, mover: str, stander: str, seconds: float) -> list[tuple[float, str, bool, int]]:
    """Run ``mover`` (a vehicle element, id "m", taken over) beside ``stander`` (id "b", standing
    for its stop) under the gate; per step: time [s], m's lane, whether m is held, overlaps."""
    routes = folder / "h.rou.xml"
    routes.write_text(f'<routes><vType id="car" length="4.5" width="1.8" minGap="2.5"/>{mover}{stander}</routes>')
    libsumo.start(["sumo", "-n", str(_net(folder)), "-r", str(routes), "--step-length", "0.1", "--no-step-log",
                   "true", "--no-warnings", "true"])
    try:
        hold = LaneChangeHold({}, frozenset(), LANE_CHANGE_MODE_STRATEGIC, 0.1)
        bodies, seen = {}, []
        while libsumo.simulation.getTime() < seconds:
            libsumo.simulationStep()
            for vid in libsumo.simulation.getDepartedIDList():
                libsumo.vehicle.subscribe(vid, VARS)
                bodies[vid] = (libsumo.vehicle.getLength(vid), libsumo.vehicle.getWidth(vid))
                if vid == "m":
                    libsumo.vehicle.setLaneChangeMode(vid, LANE_CHANGE_MODE_STRATEGIC)
            states = libsumo.vehicle.getAllSubscriptionResults()
            if "m" not in states:
                continue
            hold.update(libsumo, states, bodies, {"m"})
            ids = list(states)
            pos = np.array([states[v][libsumo.VAR_POSITION] for v in ids])
            heading = np.radians(90.0 - np.array([states[v][libsumo.VAR_ANGLE] for v in ids]))
            i, _ = overlapping_pairs(pos[:, 0], pos[:, 1], heading, [bodies[v][0] for v in ids],
                                     [bodies[v][1] for v in ids])
            seen.append((libsumo.simulation.getTime(), states["m"][libsumo.VAR_LANE_ID], "m" in hold.held, len(i)))
    finally:
        libsumo.close()
    return seen


STAND = ('<vehicle id="b" type="car" depart="0" departLane="{lane}" departPos="{pos}" departSpeed="0">'
         '<route edges="WA AN"/><stop lane="WA_{lane}" endPos="{end}" duration="8"/></vehicle>')


@pytest.mark.slow
def test_a_vehicle_does_not_change_into_a_place_another_body_takes(tmp_path):
    """m on lane 0 wants lane 1 for its left turn while b stands beside it on lane 1 (both stop
    for a while): m is held while b is beside it, freed once it has driven on past b, changes to
    lane 1 only then, and no two bodies ever overlap."""
    mover = ('<vehicle id="m" type="car" depart="0" departLane="0" departPos="101" departSpeed="0">'
             '<route edges="WA AN"/><stop lane="WA_0" endPos="106" duration="3"/></vehicle>')
    seen = _drive(tmp_path, mover, STAND.format(lane=1, pos=100, end=105), 12.0)
    early = [s for s in seen if s[0] <= 3.0]
    assert early and all(held and lane == "WA_0" for _, lane, held, _ in early)
    changed = next(t for t, lane, _, _ in seen if lane == "WA_1")
    freed = next(t for t, _, held, _ in seen if not held)
    assert 3.0 < freed <= changed  # [s] after m's stop, and only once freed
    assert all(n == 0 for *_, n in seen)


@pytest.mark.slow
def test_a_vehicle_that_wants_only_the_free_side_is_not_held(tmp_path):
    """m on lane 1 wants lane 0 (it goes straight on) while b stands on its left, on lane 2: the
    place beside it is taken on the side it does not want, so it is not held and moves over to
    lane 0 while b still stands (holding it would lock a vehicle that waits for m's lane)."""
    mover = ('<vehicle id="m" type="car" depart="0" departLane="1" departPos="250" departSpeed="0">'
             '<route edges="WA AE"/></vehicle>')
    seen = _drive(tmp_path, mover, STAND.format(lane=2, pos=250, end=255), 6.0)
    assert not any(held for _, _, held, _ in seen)
    changed = next(t for t, lane, _, _ in seen if lane == "WA_0")
    assert changed < 8.0  # [s] while b still stands
