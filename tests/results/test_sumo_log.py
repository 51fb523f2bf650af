"""SUMO's warnings counted by kind: ids and numbers taken out, the first distinct ones kept."""

from intersection_cosim.results.sumo_log import read_sumo_log, warning_kind

LOG = """Warning: Vehicle 'a' performs emergency braking on lane 'x_0' with decel=9.00, wished=4.50, severity=1.00, time=25248.80.
Warning: Vehicle 'b' performs emergency braking on lane 'y_1' with decel=8.00, wished=4.50, severity=0.80, time=25300.00.
Warning: Unsafe green phase 4 in tlLogic 'gneJ210', program '0'.
some other line
Error: Vehicle 'c' has no valid route.
"""


def test_warnings_are_counted_by_kind(tmp_path):
    path = tmp_path / "sumo.log"
    path.write_text(LOG)
    got = read_sumo_log(path)
    assert (got["warnings"], got["errors"]) == (3, 1)
    braking = warning_kind(LOG.splitlines()[0])
    assert braking == warning_kind(LOG.splitlines()[1])
    assert list(got["by_kind"].items())[0] == (braking, 2)
    assert got["first"] == [LOG.splitlines()[0], LOG.splitlines()[2], LOG.splitlines()[4]]


def test_no_log_counts_nothing(tmp_path):
    assert read_sumo_log(tmp_path / "none.log") == {"warnings": 0, "errors": 0, "by_kind": {}, "first": []}
