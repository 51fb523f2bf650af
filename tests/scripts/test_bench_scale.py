"""scripts/bench_scale.py: the controller and SUMO are measured over the same window (a real run)."""

from __future__ import annotations

from intersection_cosim.sim.timing import sumo_step_timer

from tests.scripts.script_module import load_script


def _bench():
    return load_script("bench_scale")


def test_sumo_steps_are_taken_from_the_controllers_window(tmp_path):
    """A 4 s run at the 10-vehicle level with a 2 s warmup: control steps from 2.0 s, SUMO steps
    that reach 2.05-4.0 s (40 at 0.05 s), the whole run's 80 kept apart."""
    bs = _bench()
    scn = bs.build_scenario(bs.TOTAL_RATES[10], 4.0, 1, True)
    times: list[float] = []
    with sumo_step_timer(times) as ms:
        r = bs.run_one(scn, 2.0, ms, times)
    assert r["steps"]["time"].min() >= 2.0 - 1e-9
    assert len(r["sumo_ms_all"]) == 80 and len(r["sumo_ms"]) == 40
    assert r["sumo_ms"] == r["sumo_ms_all"][40:]
    assert min(r["sumo_ms"]) > 0.0


def test_the_report_lists_each_populated_level_with_its_ratio_to_sumo(tmp_path):
    bs = _bench()
    level = {"target": 10, "steps": 100, "n_median": 10.0, "compute_ms_median": 2.5, "compute_ms_p95": 5.0,
             "ratio_to_sumo": 9.1}
    result = {"ssm": False, "sumo_step_ms_median": {"etm": 0.8, "noetm": 0.9}, "exponent_etm": 1.05,
              "exponent_noetm": 1.9, "note": None,
              "bins": {"etm": [level, {**level, "target": 80, "n_median": 75.0, "ratio_to_sumo": 9.7},
                               {**level, "target": 160, "steps": 0}], "noetm": []}}
    text = bs.write_report(tmp_path, result).read_text()
    rows = [line for line in text.splitlines() if line.startswith("| ") and line[2].isdigit()]
    assert [r.split(" | ")[0] for r in rows] == ["| 10", "| 80"]  # the empty level left out
    assert rows[1].endswith("| 9.7 |") and "k = 1.05" in text and "0.8 ms" in text and "SSM device off" in text
