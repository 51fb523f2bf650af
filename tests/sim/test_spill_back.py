"""Don't block the box across a corridor: a queue that spills back from a blocked exit road must
not lock the junction upstream (control/safety/exit_room.py), closed loop in SUMO."""

from pathlib import Path

import pandas as pd
import pytest

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import load_scenario

# SUMO's corridor: gneJ10 - gneE10 - gneJ11 - gneE11 - gneJ12 (200 m apart, one lane each way).
# A vehicle stands on gneE11 for good, 100 m after gneJ11 (outside gneJ12's control range); the
# eastbound main road queues behind it back into gneJ11, which north-south traffic crosses.
ROUTES = """<routes>
    <vehicle id="blocker" depart="0" departPos="100" departSpeed="0">
        <route edges="gneE11 gneE26"/>
        <stop lane="gneE11_0" endPos="101" duration="100000"/>
    </vehicle>
</routes>
"""

SCENARIO = """
[scenario]
name = "spill_back"
duration = 150.0
drain = 60.0
step_length = 0.05
seed = 3

[controller]
kind = "nash"

[controller.safety]
exit_room = {exit_room}

[network]
file = "$SUMO_HOME/tools/game/corridor/corridor.net.xml"
junctions = "all"
signals = "off"
control_range = 80.0
routes = "blocker.rou.xml"

[[flow]]
from = "gneE28"
to = "gneE26"
rate = 900.0
kappa = 0.5
begin = 0.0
end = 60.0

[[flow]]
from = "gneE14"
to = "gneE15"
rate = 300.0
kappa = 0.5
begin = 0.0
end = 150.0

[[flow]]
from = "gneE21"
to = "gneE22"
rate = 300.0
kappa = 0.5
begin = 0.0
end = 150.0
"""


def _crossing_traffic(tmp_path: Path, exit_room: bool) -> pd.DataFrame:
    folder = tmp_path / f"exit_room_{exit_room}"
    folder.mkdir()
    (folder / "blocker.rou.xml").write_text(ROUTES)
    path = folder / "spill_back.toml"
    path.write_text(SCENARIO.format(exit_room=str(exit_room).lower()))
    run_scenario(load_scenario(path), folder / "run")
    vehicles = pd.read_csv(folder / "run" / "vehicles.csv", dtype={"vehicle": str})
    return vehicles[vehicles["approach"].isin(["gneE14", "gneE21"])]


@pytest.mark.slow
def test_a_queue_spilling_back_locks_the_junction_upstream_without_the_exit_rule_and_not_with_it(tmp_path):
    without = _crossing_traffic(tmp_path, exit_room=False)
    with_rule = _crossing_traffic(tmp_path, exit_room=True)
    assert len(without) == len(with_rule) > 20  # the same north-south demand (the flows' draws)
    # without the rule an eastbound vehicle enters gneJ11 towards the full gneE11, stops in the
    # box and the north-south traffic behind it never crosses
    assert without["arrival"].isna().sum() >= 5
    # with it the eastbound queue waits at gneJ11's stop line and every crossing vehicle arrives
    assert with_rule["arrival"].notna().all()
