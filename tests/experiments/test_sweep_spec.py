"""Sweep specs: range/list/seed syntax, run ids, and malformed specs rejected before any run."""

from __future__ import annotations

import json

import pytest

from intersection_cosim.cli import main
from intersection_cosim.errors import InputError
from intersection_cosim.experiments.sweep import kappa_warning, make_spec, parse_kappa, parse_seeds, sweep_jobs
from intersection_cosim.results.layout import SPEC_FILE
from intersection_cosim.results.sweep_folder import SweepSpec, format_kappa

from sweep_helpers import CASE1A

VIDS = ["V1", "V2", "V3"]


def test_range_includes_both_ends_without_float_noise():
    grid = parse_kappa(["V1=0.1:0.9:0.1"], VIDS)
    assert grid["V1"] == (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)
    assert parse_kappa(["V2=0:1:0.25"], VIDS)["V2"] == (0.0, 0.25, 0.5, 0.75, 1.0)
    assert parse_kappa(["V2=0.2:0.95:0.3"], VIDS)["V2"] == (0.2, 0.5, 0.8)  # end not on the grid


def test_lists_and_single_values():
    grid = parse_kappa(["V1=0.5, 0.2", "V3=0.7"], VIDS)
    assert grid == {"V1": (0.2, 0.5), "V3": (0.7,)}
    assert list(grid) == ["V1", "V3"]  # axis order as given


def test_seeds():
    assert parse_seeds("1-5") == (1, 2, 3, 4, 5)
    assert parse_seeds("1,3,7") == (1, 3, 7)
    assert parse_seeds("1-3,7") == (1, 2, 3, 7)
    assert parse_seeds("0") == (0,)


def test_run_ids_are_stable_and_unique():
    assert format_kappa(0.3) == "0.30"
    assert format_kappa(0.125) == "0.125"
    assert format_kappa(1.0) == "1.00"
    spec = make_spec(CASE1A, ["V1=0.1:0.9:0.1", "V2=0.2,0.5"], "sumo", "1-2")
    jobs = sweep_jobs(spec, "/tmp/x")
    assert spec.total == len(jobs) == 9 * 2 * 2
    assert len({j.run_id for j in jobs}) == len(jobs)
    assert jobs[0].run_id == "sumo-seed1-V1_0.10-V2_0.20"
    assert jobs[-1].run_id == "sumo-seed2-V1_0.90-V2_0.50"
    assert SweepSpec.from_dict(json.loads(json.dumps(spec.to_dict()))) == spec


@pytest.mark.parametrize("spec, words", [
    ("V9=0.1", "unknown vehicle"),
    ("V1=1.5", "outside [0, 1]"),
    ("V1=-0.1:0.5:0.1", "outside [0, 1]"),
    ("V1=0.2,1.01", "outside [0, 1]"),
    ("V1=0.9:0.1:0.1", "empty range"),
    ("V1=0.1:0.9:0", "empty range"),
    ("V1=0.1:0.9:-0.1", "empty range"),
    ("V1", "bad syntax"),
    ("=0.5", "bad syntax"),
    ("V1=", "bad syntax"),
    ("V1=abc", "bad syntax"),
    ("V1=0.1:0.9", "bad syntax"),
    ("V1=0.1,,0.2", "bad syntax"),
    ("V1=0.2,0.2", "given twice"),
])
def test_malformed_kappa_is_one_line_exit_2_before_any_run(tmp_path, capsys, spec, words):
    out = tmp_path / "sweep"
    assert main(["sweep", CASE1A, "--kappa", spec, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("intersection-cosim: error: --kappa")
    assert words in err
    assert not out.exists()  # nothing started, nothing written


@pytest.mark.parametrize("args, words", [
    (["--kappa", "V1=0.1", "--kappa", "V1=0.2"], "swept twice"),
    (["--seeds", "5-1"], "empty range"),
    (["--seeds", "1;2"], "bad syntax"),
    (["--seeds", "-1"], "bad syntax"),
    (["--controller", "sumo,nope"], "unknown controller"),  # the old spelling
    (["--controllers", "sumo,nope"], "unknown controller"),  # as compare spells it
    (["--controllers", "sumo,sumo"], "given twice"),
])
def test_other_malformed_specs(tmp_path, capsys, args, words):
    out = tmp_path / "sweep"
    assert main(["sweep", CASE1A, *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err
    assert not out.exists()


def test_bad_worker_count_and_both_executors(tmp_path, capsys):
    for extra in (["--workers", "0"], ["--workers", "2", "--dask-scheduler", "tcp://127.0.0.1:1"]):
        with pytest.raises(SystemExit) as exc:
            main(["sweep", CASE1A, "--out", str(tmp_path / "s"), *extra])
        assert exc.value.code == 2
        assert capsys.readouterr().err.count("\n") == 1
    assert not (tmp_path / "s").exists()


def test_out_holding_another_sweep_or_other_files_is_refused(tmp_path, capsys):
    other = make_spec(CASE1A, ["V1=0.3"], None, "7")
    out = tmp_path / "sweep"
    out.mkdir()
    (out / SPEC_FILE).write_text(json.dumps(other.to_dict()))
    assert main(["sweep", CASE1A, "--kappa", "V1=0.5", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds another sweep" in err and "kappa grid" in err and "seeds" in err
    assert not (out / "runs").exists()

    junk = tmp_path / "junk"
    junk.mkdir()
    (junk / "notes.txt").write_text("mine")
    assert main(["sweep", CASE1A, "--out", str(junk)]) == 2
    assert "not a sweep folder" in capsys.readouterr().err
    assert sorted(p.name for p in junk.iterdir()) == ["notes.txt"]


def test_unreachable_dask_scheduler_is_an_input_error(tmp_path, capsys, monkeypatch):
    pytest.importorskip("distributed")
    monkeypatch.setattr("intersection_cosim.experiments.executors.CONNECT_TIMEOUT", "1s")
    out = tmp_path / "sweep"
    assert main(["sweep", CASE1A, "--out", str(out), "--dask-scheduler", "tcp://127.0.0.1:9"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot connect" in err
    assert not out.exists()


def test_input_error_type():
    with pytest.raises(InputError):
        parse_kappa(["V1=2"], VIDS)


def test_a_kappa_sweep_of_a_paper_scenario_plays_the_game_and_does_not_warn():
    spec = make_spec(CASE1A, ["V2=0.1:0.9:0.2"], None, None)
    assert spec.controllers == ("nash",) and sweep_jobs(spec, "/tmp/x")[0].run_id == "nash-seed42-V2_0.10"
    assert kappa_warning(spec) is None


@pytest.mark.parametrize("controllers, named", [
    ("sumo", "sumo ignores kappa"),
    ("nash,sumo-tls,fcfs", "sumo-tls, fcfs ignore kappa"),
    ("sumo-priority,stackelberg", "sumo-priority ignores kappa"),
])
def test_kappa_warning_names_the_controllers_that_ignore_kappa(controllers, named):
    warning = kappa_warning(make_spec(CASE1A, ["V1=0.3,0.7"], controllers, "1"))
    assert warning is not None and "\n" not in warning and named in warning
    assert "nash" not in warning.split("(")[0] and "stackelberg" not in warning.split("(")[0]
    assert kappa_warning(make_spec(CASE1A, None, controllers, "1")) is None  # no --kappa: nothing to ignore
    assert kappa_warning(make_spec(CASE1A, ["V1=0.3,0.7"], "nash,stackelberg", "1")) is None


def test_a_kappa_sweep_with_sumo_warns_once_on_stderr(tmp_path, capsys):
    """One SUMO run (about 2 s): the warning is one line, printed once, and the sweep still runs."""
    out = tmp_path / "sweep"
    argv = ["sweep", CASE1A, "--kappa", "V1=0.3", "--controllers", "sumo", "--seeds", "1", "--out", str(out),
            "--no-progress", "--workers", "1"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert err.splitlines() == ["intersection-cosim: warning: sumo ignores kappa: its runs differ only by seed, "
                                "whatever --kappa says (kappa is used by nash, stackelberg)"]
    assert (out / "runs" / "sumo-seed1-V1_0.30" / "summary.json").is_file()
