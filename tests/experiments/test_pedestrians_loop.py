"""Closed loop with people on the crossings (control/safety/pedestrians.py): SUMO's Braunschweig
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


def _run(tmp_path, name: str, kind: str = "nash", seed: int = 1, v2x: dict | None = None, **safety) -> dict:
    routes = tmp_path / "people.rou.xml"
    routes.write_text(PEOPLE)
    flows = [{"from": a, "to": b, "rate": 240, "kappa": 0.6, "begin": 0.0, "end": 60.0}
             for a, b in (("-1.23", "5"), ("-5.5", "1"), ("-2.10", "3"), ("-3.22", "2"))]
    data = {"scenario": {"name": "people", "duration": 60.0, "drain": 60.0, "seed": seed},
            "controller": {"kind": kind, **({"safety": safety} if safety else {})},
            "network": {"file": "$SUMO_HOME/tools/game/fokr_bs_demo/fokr_bs.net.xml.gz", "junctions": ["38"],
                        "routes": str(routes)},
            "flow": flows, **({"v2x": v2x} if v2x else {})}
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



@pytest.mark.slow
@pytest.mark.parametrize("seed", [5, 6])
def test_people_are_not_hit_when_the_vehicles_states_come_over_a_noisy_link(tmp_path, seed):
    """0.2 m / 0.1 m/s of V2X noise read vehicles standing at a crossing's edge as inside it, and
    the rule let them drive on into the person (4 and 1 hit in these seeds); a vehicle at the
    edge with a person in front now stops there (control/safety/pedestrians.py, _edge_stop)."""
    c = _run(tmp_path, "noisy", seed=seed, v2x={"position_noise": 0.2, "speed_noise": 0.1})["counts"]
    assert c["arrived"] == c["departed"] > 10
    assert c["pedestrian_collisions"] == 0 and c["collisions"] == 0 and c["pedestrian_holds"] > 50

WAITING = """<routes>
<personFlow id="pw" begin="0" end="60" period="8" departPos="297"><walk from="153021549" to="-331121198" arrivalPos="0.4"/></personFlow>
</routes>
"""


@pytest.mark.slow
def test_people_who_would_wait_at_a_kerb_cross_first_and_none_is_hit(tmp_path):
    """An OSM junction of SUMO's DRT net (tools/game/DRT) whose crossings give people no priority:
    SUMO's people wait at the kerb for a gap in the vehicles, judged by SUMO's right of way, which
    is off for the commanded vehicles. Waiting, then stepping out, they were hit (3-5 in these 60 s);
    yielded to while waiting they waited for the vehicles in turn (mean trip 80 s). They are now
    told the vehicles yield, and are yielded to when they wait all the same."""
    routes = tmp_path / "people.rou.xml"
    routes.write_text(WAITING)
    data = {"scenario": {"name": "kerb", "duration": 60.0, "drain": 60.0, "seed": 2},
            "controller": {"kind": "nash"},
            "network": {"file": "$SUMO_HOME/tools/game/DRT/osm.net.xml", "junctions": ["150751448"],
                        "routes": str(routes)},
            "flow": [{"from": "153021549", "to": "-149611526", "rate": 600, "kappa": 0.6, "begin": 0.0, "end": 60.0}]}
    summary = run_scenario(scenario_from_dict(data, "<kerb>"), tmp_path / "run")
    c = summary["counts"]
    assert c["arrived"] == c["departed"] == 14
    assert c["pedestrian_collisions"] == 0 and c["collisions"] == 0
    assert c["pedestrian_holds"] > 50  # [-] vehicle-steps held back for people
    assert summary["metrics"]["mean_travel_time"] < 55.0  # [s] ~44 s undisturbed; 80 s when both waited
