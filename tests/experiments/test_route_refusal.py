"""A route of the user's own route file that SUMO cannot find in mid-run (SUMO's load check only
covers the first second) is bad input: one InputError naming network.routes, nothing on disk."""

from __future__ import annotations

import pytest

from intersection_cosim.errors import InputError
from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import scenario_from_dict

LOST = """<routes>
<person id="lost" depart="2"><walk from="29119849#1" to="-gneE9"/></person>
</routes>
"""


def test_a_person_sumo_cannot_route_at_its_departure_is_an_input_error_and_leaves_nothing(tmp_path):
    routes = tmp_path / "lost.rou.xml"
    routes.write_text(LOST)  # on Ingolstadt's net no walk joins these two edges
    data = {"scenario": {"name": "lost", "duration": 10.0, "drain": 0.0},
            "network": {"file": "$SUMO_HOME/tools/game/fkk_in/ingolstadt.net.xml.gz", "junctions": ["335525545"],
                        "routes": str(routes)}}
    with pytest.raises(InputError) as err:
        run_scenario(scenario_from_dict(data, "lost.toml"), tmp_path / "out")
    assert err.value.field == "network.routes" and err.value.value == str(routes)
    assert "at t = 2.05 s" in err.value.problem and "for person 'lost'" in err.value.problem
    assert "\n" not in str(err.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lost.rou.xml"]  # no run folder, no temp left
