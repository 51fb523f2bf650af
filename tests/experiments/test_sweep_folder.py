"""What a finished sweep leaves in its folder, and the lock that keeps two sweeps out of one folder."""

from __future__ import annotations

import fcntl

from intersection_cosim.cli import main
from intersection_cosim.experiments.sweep import LOCK_FILE
from sweep_helpers import CASE1A

ARGS = ["--kappa", "V1=0.3", "--controllers", "sumo", "--seeds", "1", "--no-progress", "--workers", "1"]


def test_a_finished_sweep_leaves_no_lock_file(tmp_path, capsys):
    """One SUMO run (about 2 s)."""
    out = tmp_path / "sweep"
    assert main(["sweep", CASE1A, "--out", str(out), *ARGS]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["runs", "sweep.csv", "sweep.json", "units.csv"]
    assert main(["sweep", CASE1A, "--out", str(out), *ARGS]) == 0  # rerun: skipped, still no lock
    assert "1/1 runs finished (1 already before)" in capsys.readouterr().out
    assert not (out / LOCK_FILE).exists()


def test_a_sweep_holding_the_lock_keeps_another_out(tmp_path, capsys):
    out = tmp_path / "sweep"
    out.mkdir()
    with open(out / LOCK_FILE, "w") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)  # as a running sweep holds it
        assert main(["sweep", CASE1A, "--out", str(out), *ARGS]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "another sweep is writing into this folder" in err
    assert not (out / "runs").exists()
