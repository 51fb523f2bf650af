"""Closed-loop runs on SUMO nets that are not the generated paper intersection."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pandas as pd
import pytest

from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.network.junction_net import load_movements
from intersection_cosim.scenario import load_scenario, with_overrides

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"

pytestmark = pytest.mark.slow


def _run(name: str, controller: str, out: Path, duration: float = 90.0):
    scn = with_overrides(load_scenario(SCENARIOS / f"{name}.toml"), controller=controller, budget_ms=2000.0)
    scn = dataclasses.replace(scn, scenario=dataclasses.replace(scn.scenario, duration=duration))
    summary = run_scenario(scn, out)
    return summary, pd.read_csv(out / "trajectories.csv"), pd.read_csv(out / "vehicles.csv")


@pytest.mark.parametrize("name", ["cross_medium", "tjunction_high"])
def test_the_game_controller_drives_a_net_file_junction_without_collision(tmp_path, name):
    summary, traj, vehicles = _run(name, "nash", tmp_path / name)
    counts = summary["counts"]
    assert counts["departed"] >= 10 and counts["arrived"] == counts["departed"]
    assert counts["collisions"] == 0
    assert set(traj["role"]) == {"ready", "passing", "outside"}
    assert traj["path"].str.contains(">").all()  # paths of the net's connections: from lane > to lane
    commanded = traj[traj["role"] != "outside"]
    assert commanded["accel_cmd"].notna().all()  # every vehicle in the zone is the controller's
    scn = load_scenario(SCENARIOS / f"{name}.toml")
    paths = load_movements(scn.network.file, scn.network.junctions, scn.network.control_range).paths
    first = commanded.groupby("vehicle").first()
    to_stop = first["path"].map(lambda p: paths[p].s_stop) - first["s"]  # [m] when taken over
    assert (to_stop <= scn.network.control_range + 1e-6).all() and (to_stop > 0.0).all()
    assert (vehicles["approach"] != "").all() and set(vehicles["movement"]) <= {"left", "straight", "right"}
    assert pd.read_csv(tmp_path / name / "games.csv").shape[0] > 0


def test_the_lights_are_off_for_the_controllers_and_on_for_sumo_tls(tmp_path):
    """On SUMO's cross (a signalized junction), its own programme stops vehicles at red: SUMO's
    priority rules with the lights off and the game controller both pass them faster."""
    tt = {kind: _run("cross_medium", kind, tmp_path / kind)[2]["travel_time"].mean()
          for kind in ("sumo-tls", "sumo-priority", "nash")}
    assert tt["sumo-tls"] > tt["sumo-priority"] + 5.0
    assert tt["sumo-tls"] > tt["nash"] + 5.0


def test_vehicles_of_the_users_own_route_file_are_controlled_with_their_kappa(tmp_path):
    """A scenario whose only demand is the user's route file: its vehicles are adopted on
    departure, taken over at the managed junction with the kappa of their ``kappa`` parameter
    (0.5 without one) and all arrive."""
    routes = tmp_path / "mine.rou.xml"
    routes.write_text(
        '<routes>\n'
        '  <vType id="car" length="4.5" width="1.8"/>\n'
        '  <vehicle id="bold" type="car" depart="0" departSpeed="max"><param key="kappa" value="0.9"/>'
        '<route edges="1fi 1si 2o 2fo"/></vehicle>\n'
        '  <vehicle id="plain" type="car" depart="1" departSpeed="max"><route edges="3fi 3si 4o 4fo"/></vehicle>\n'
        '  <vehicle id="third" type="car" depart="2" departSpeed="max"><route edges="2fi 2si 3o 3fo"/></vehicle>\n'
        '</routes>\n')
    scenario = tmp_path / "own.toml"
    scenario.write_text('[scenario]\nname = "own"\nduration = 30.0\ndrain = 60.0\n\n[controller]\nkind = "nash"\n\n'
                        '[network]\nfile = "$SUMO_HOME/tools/game/cross/cross.net.xml"\njunctions = ["0"]\n'
                        f'routes = "{routes}"\n')
    summary = run_scenario(load_scenario(scenario), tmp_path / "run")
    vehicles = pd.read_csv(tmp_path / "run" / "vehicles.csv").set_index("vehicle")
    traj = pd.read_csv(tmp_path / "run" / "trajectories.csv")
    assert summary["counts"]["collisions"] == 0 and summary["counts"]["arrived"] == 3
    assert vehicles.loc["bold", "kappa"] == 0.9 and vehicles.loc["plain", "kappa"] == 0.5
    assert set(vehicles.index) == {"bold", "plain", "third"} and (vehicles["approach"] != "").all()
    commanded = traj[traj["role"] != "outside"]
    assert set(commanded["vehicle"]) == {"bold", "plain", "third"} and commanded["accel_cmd"].notna().all()


def test_a_gzipped_net_runs_as_the_plain_one(tmp_path):
    """SUMO reads ``.net.xml.gz``; so does every reader of ours (the waiting positions, the run
    folder's copy, which is written out plain): the same demand gives the same trajectories."""
    import gzip
    import shutil

    scn = with_overrides(load_scenario(SCENARIOS / "cross_medium.toml"), budget_ms=2000.0)
    scn = dataclasses.replace(scn, scenario=dataclasses.replace(scn.scenario, duration=40.0))
    gz = tmp_path / "cross.net.xml.gz"
    with open(scn.network.file, "rb") as fin, gzip.open(gz, "wb") as fout:
        shutil.copyfileobj(fin, fout)
    packed = dataclasses.replace(scn, network=dataclasses.replace(scn.network, file=str(gz)))
    summaries = {name: run_scenario(s, tmp_path / name) for name, s in (("plain", scn), ("gz", packed))}
    counts = summaries["gz"]["counts"]
    assert counts["departed"] >= 5 and counts["arrived"] == counts["departed"] and counts["collisions"] == 0
    assert (tmp_path / "gz" / "intersection.net.xml").read_bytes() == Path(scn.network.file).read_bytes()
    trajs = [pd.read_csv(tmp_path / name / "trajectories.csv") for name in ("plain", "gz")]
    pd.testing.assert_frame_equal(trajs[0], trajs[1])


def _alone(tmp_path: Path, name: str, vtype: str, desired: str) -> pd.DataFrame:
    """One vehicle of the user's route file straight over SUMO's cross (roads signed 13.89 m/s),
    alone: its speeds [m/s] inside the managed junction (role passing)."""
    routes = tmp_path / f"{name}.rou.xml"
    routes.write_text(f'<routes>\n  <vType id="car" length="4.5" width="1.8" {vtype}/>\n'
                      '  <vehicle id="car" type="car" depart="0" departSpeed="0"><route edges="1fi 1si 2o 2fo"/>'
                      '</vehicle>\n</routes>\n')
    scenario = tmp_path / f"{name}.toml"
    scenario.write_text('[scenario]\nname = "alone"\nduration = 5.0\ndrain = 60.0\n\n[controller]\nkind = "nash"\n\n'
                        '[network]\nfile = "$SUMO_HOME/tools/game/cross/cross.net.xml"\njunctions = ["0"]\n'
                        f'routes = "{routes}"\ndesired_speed = "{desired}"\n')
    summary = run_scenario(load_scenario(scenario), tmp_path / name)
    assert summary["counts"]["arrived"] == 1 and summary["counts"]["collisions"] == 0
    traj = pd.read_csv(tmp_path / name / "trajectories.csv")
    return traj[traj["role"] == "passing"]["speed"]


def test_a_route_file_vehicle_desires_its_roads_limit_up_to_its_vtypes_max_speed(tmp_path):
    """network.desired_speed "road": an adopted vehicle alone on the cross's 13.89 m/s roads
    crosses the managed junction close to that limit, never over it, and no faster than its vType's
    maxSpeed; "v_max": slowed to the model's v_max (10 m/s), as before the setting."""
    road = _alone(tmp_path, "road", "", "road")
    capped = _alone(tmp_path, "capped", 'maxSpeed="12"', "road")
    model = _alone(tmp_path, "model", "", "v_max")
    assert len(road) > 5 and len(capped) > 5 and len(model) > 5
    assert 13.0 < road.min() and road.max() <= 13.89 + 0.05  # [m/s]
    assert 11.5 < capped.min() and capped.max() <= 12.0 + 0.05
    assert model.max() <= 10.5 and model.min() > 9.0
