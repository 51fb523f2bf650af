"""The exported scenario.sumocfg replays into replay/ and never over the run's own SUMO outputs."""

import hashlib
import subprocess
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import sumolib

from intersection_cosim.experiments.files import REPLAY_DIR
from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.results.sumo_outputs import read_tripinfo
from intersection_cosim.scenario import load_scenario, with_overrides

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
OUTPUTS = ("tripinfo.xml", "ssm.xml", "collisions.xml")


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("replay") / "case1_A"
    run_scenario(with_overrides(load_scenario(SCENARIOS / "case1_A.toml"), controller="sumo"), out)
    return out


def _hashes(folder: Path) -> dict[str, str]:
    return {name: hashlib.sha256((folder / name).read_bytes()).hexdigest() for name in OUTPUTS}


def test_run_outputs_stay_in_the_run_folder(short_run):
    assert sorted(read_tripinfo(short_run / "tripinfo.xml")["vehicle"]) == ["V1", "V2", "V3"]
    assert sorted(p.name for p in (short_run / REPLAY_DIR).iterdir()) == ["README.txt"]  # nothing replayed yet
    cfg = ET.parse(short_run / "scenario.sumocfg").getroot()
    values = {el.tag: el.get("value") for sec in cfg for el in sec}
    assert values["tripinfo-output"] == "replay/tripinfo.xml"
    assert values["collision-output"] == "replay/collisions.xml"
    assert values["device.ssm.file"] == "replay/ssm.xml"


def test_replaying_the_exported_config_leaves_the_run_outputs_byte_identical(short_run):
    before = _hashes(short_run)
    proc = subprocess.run([sumolib.checkBinary("sumo"), "-c", str(short_run / "scenario.sumocfg")],
                          capture_output=True, text=True, timeout=120, cwd=short_run.parent)
    assert proc.returncode == 0, proc.stderr
    assert _hashes(short_run) == before
    replay = short_run / REPLAY_DIR
    assert {p.name for p in replay.iterdir()} == {"README.txt", *OUTPUTS}
    trips = read_tripinfo(replay / "tripinfo.xml")
    assert sorted(trips["vehicle"]) == ["V1", "V2", "V3"]
    assert (trips["arrival"] > 0).all()
    assert "NOT the game controller" in " ".join((replay / "README.txt").read_text().split())
