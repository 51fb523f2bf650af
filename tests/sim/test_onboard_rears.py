"""The onboard guard (sim/onboard.py) on a real SUMO run: a vehicle whose front has turned onto an
internal lane the commanded vehicle does not take, its rear still on the commanded vehicle's lane,
is a leader too (SUMO's leader query does not return it)."""

from __future__ import annotations

from pathlib import Path

import libsumo
import pytest

from intersection_cosim.control.safety.onboard import OnboardSettings
from intersection_cosim.sim.onboard import OnboardGuard

LENGTH, MIN_GAP = 4.5, 2.5  # [m] every vehicle's body and SUMO's minGap
STEP = 0.1  # [s]


NET = Path(__file__).resolve().parents[2] / "sumo_networks" / "intersection.net.xml"  # the paper's net
RIGHT = ":C_21_0"  # the right turn west_in_0 -> south_out_0 (west_in_0 also goes straight on)


def test_a_vehicle_going_straight_stops_behind_the_rear_of_one_turning_right_just_past_the_line(tmp_path):
    """On the paper's net R has turned right 0.5 m onto its internal lane and stands, 4 m of its
    body still on west_in_0. F, going straight on from west_in_0, stands 1.5 m behind R's rear:
    nearer than its minGap, where SUMO's leader query returns nothing (demand_balanced_high under
    V2X noise: an AV crept into such a rear). Commanded to 10 m/s with SUMO's own checks off, F
    is held by its guard, never touching R."""
    routes = tmp_path / "r.rou.xml"
    routes.write_text(f'<routes><vType id="car" length="{LENGTH}" width="1.8" minGap="{MIN_GAP}"/>'
                      '<route id="right" edges="west_in south_out"/><route id="straight" edges="west_in east_out"/>'
                      '<vehicle id="R" type="car" route="right" depart="0" departLane="0" departPos="100" departSpeed="0"/>'
                      '<vehicle id="F" type="car" route="straight" depart="0" departLane="0" departPos="132.5" departSpeed="0"/>'
                      '</routes>')
    libsumo.start(["sumo", "-n", str(NET), "-r", str(routes), "--step-length", str(STEP), "--no-step-log", "true",
                   "--no-warnings", "true", "--collision.action", "warn"])
    try:
        libsumo.simulationStep()
        libsumo.vehicle.moveTo("R", RIGHT, 0.5)
        libsumo.vehicle.setSpeed("R", 0.0)
        libsumo.vehicle.setSpeedMode("F", 0)  # SUMO's own safe-speed checks off: the guard alone
        libsumo.vehicle.setLaneChangeMode("F", 0)  # F keeps west_in_0
        guard = OnboardGuard(libsumo, OnboardSettings(), STEP)
        bodies = {v: (LENGTH, 1.8, 2.6, 4.5, 9.0) for v in ("R", "F")}
        wa = libsumo.lane.getLength("west_in_0")  # [m]
        gaps = []
        for _ in range(80):
            libsumo.simulationStep()
            states = {v: {libsumo.VAR_SPEED: libsumo.vehicle.getSpeed(v), libsumo.VAR_LANE_ID: libsumo.vehicle.getLaneID(v),
                          libsumo.VAR_LANEPOSITION: libsumo.vehicle.getLanePosition(v)} for v in ("R", "F")}
            assert states["R"][libsumo.VAR_LANE_ID] == RIGHT
            assert states["F"][libsumo.VAR_LANE_ID] == "west_in_0", "F drove on through R's rear"
            rear = wa + states["R"][libsumo.VAR_LANEPOSITION] - LENGTH  # [m] R's rear along west_in_0
            gaps.append(rear - states["F"][libsumo.VAR_LANEPOSITION])
            guard.begin_step(states, tracked=(), commanded={"F"})
            v = states["F"][libsumo.VAR_SPEED]
            libsumo.vehicle.setSpeed("F", guard.speed("F", v, 10.0, states, bodies, {"R": MIN_GAP, "F": MIN_GAP}))
        assert rear < wa - 3.0  # R's rear is on west_in_0 all along
        assert gaps[0] == pytest.approx(1.5, abs=0.05), gaps[0]
        assert min(gaps) > 0.0, f"F drove into R's rear: gaps {min(gaps):.2f} m"
        assert min(gaps) >= OnboardSettings().margin - 0.05 and libsumo.vehicle.getSpeed("F") < 0.1
        assert libsumo.simulation.getCollidingVehiclesNumber() == 0
    finally:
        libsumo.close()
