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
