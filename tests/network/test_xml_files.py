"""SUMO's XML inputs are read gzipped as they are plain, as SUMO itself reads them."""

import gzip
import shutil
from pathlib import Path

import sumo

from intersection_cosim.network.waiting import waiting_watches
from intersection_cosim.network.junction_net import load_movements
from intersection_cosim.network.xml_files import copy_plain, xml_root

CROSS = Path(sumo.SUMO_HOME) / "tools" / "game" / "cross" / "cross.net.xml"


def _gzipped(tmp_path: Path) -> Path:
    out = tmp_path / "cross.net.xml.gz"
    with open(CROSS, "rb") as fin, gzip.open(out, "wb") as fout:
        shutil.copyfileobj(fin, fout)
    return out


def test_a_gzipped_net_reads_as_the_plain_one(tmp_path):
    gz = _gzipped(tmp_path)
    plain, packed = xml_root(CROSS), xml_root(gz)
    assert packed.tag == "net" and len(packed) == len(plain) > 10
    assert [el.get("id") for el in packed.iter("junction")] == [el.get("id") for el in plain.iter("junction")]
    copy_plain(gz, tmp_path / "copy.net.xml")
    assert (tmp_path / "copy.net.xml").read_bytes() == CROSS.read_bytes()


def test_the_waiting_positions_of_a_gzipped_net_are_those_of_the_plain_one(tmp_path):
    """A left turn of SUMO's cross waits inside the junction for the opposing stream."""
    gz = _gzipped(tmp_path)
    watches = {str(f): waiting_watches(load_movements(f, ("0",), 60.0)) for f in (CROSS, gz)}
    assert watches[str(CROSS)] == watches[str(gz)] and len(watches[str(CROSS)]) >= 4
