"""Closed loop with people on the crossings (control/pedestrians.py): SUMO's Braunschweig
junction 38 (tools/game/fokr_bs_demo), its lights off, four through flows and two streams of
people walking round the junction over its zebra crossings. The game controller's vehicles yield
to them; the same run with ``yield_to_pedestrians = false`` hits one (SUMO's collision check,
type "crossing")."""

from __future__ import annotations

import pandas as pd
import pytest

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import scenario_from_dict

PEOPLE = """<routes>
<personFlow id="pc" begin="0" end="60" period="10"><walk from="-2.10" to="3"/></personFlow>
<personFlow id="pa" begin="3" end="60" period="10"><walk from="-5.5" to="1"/></personFlow>
</routes>
"""


def _run(tmp_path, name: str, kind: str = "nash", **safety) -> dict:
    routes = tmp_path / "people.rou.xml"
    routes.write_text(PEOPLE)
    flows = [{"from": a, "to": b, "rate": 240, "kappa": 0.6, "begin": 0.0, "end": 60.0}
             for a, b in (("-1.23", "5"), ("-5.5", "1"), ("-2.10", "3"), ("-3.22", "2"))]
    data = {"scenario": {"name": "people", "duration": 60.0, "drain": 60.0, "seed": 1},
            "controller": {"kind": kind, **({"safety": safety} if safety else {})},
            "network": {"file": "$SUMO_HOME/tools/game/fokr_bs_demo/fokr_bs.net.xml.gz", "junctions": ["38"],
                        "routes": str(routes)},
            "flow": flows}
    return run_scenario(scenario_from_dict(data, "<people>"), tmp_path / name)


@pytest.mark.slow
def test_the_game_controllers_vehicles_yield_to_people_on_the_crossings(tmp_path):
    yielding = _run(tmp_path, "yield")
    c = yielding["counts"]
    assert c["arrived"] == c["departed"] == 16
    assert c["collisions"] == 0 and c["pedestrian_collisions"] == 0
    assert c["pedestrian_holds"] > 50  # [-] vehicle-steps held back for a person
    people = pd.read_csv(tmp_path / "yield" / "walkers.csv")  # what the animation draws
    assert people["person"].nunique() >= 8 and people["crossing"].str.startswith(":38_c").all()
    on = people[people["position"].between(0.0, 20.0)]
    assert len(on) > 100 and on["speed"].between(0.0, 2.0).all()  # [m/s] walking over the crossings
    sumo = _run(tmp_path, "sumo", "sumo-priority")["counts"]  # SUMO's drivers, the reference
    assert sumo["collisions"] == 0 and sumo["arrived"] == 16 and sumo["pedestrian_holds"] is None
    # the same run with the rule switched off: a vehicle drives into a person at 10 m/s
    blind = _run(tmp_path, "blind", yield_to_pedestrians=False)
    assert blind["counts"]["pedestrian_collisions"] >= 1 and blind["counts"]["pedestrian_holds"] == 0
    assert blind["metrics"]["mean_travel_time"] < yielding["metrics"]["mean_travel_time"]  # [s] yielding costs time
