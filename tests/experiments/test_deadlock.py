"""A run whose vehicles all stand still ends early and says so (experiments.deadlock)."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from intersection_cosim.experiments.deadlock import StandstillWatch
from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.scenario import load_scenario


def test_the_watch_fires_after_everyone_stood_still_for_the_limit():
    watch = StandstillWatch(2.0)
    assert watch.update(0.0, [0.0, 0.05]) is None  # standing since t = 0 s
    assert watch.update(1.9, [0.0, 0.0]) is None
    stuck = watch.update(2.0, [0.0, 0.09])
    assert stuck is not None and (stuck.time, stuck.since, stuck.vehicles) == (2.0, 0.0, 2)


def test_one_moving_vehicle_or_an_empty_network_restarts_the_clock():
    watch = StandstillWatch(2.0)
    watch.update(0.0, [0.0, 0.0])
    assert watch.update(1.0, [0.0, 0.2]) is None  # someone moves: no deadlock
    assert watch.update(2.5, [0.0, 0.0]) is None  # standing again since 2.5 s
    assert watch.update(3.0, []) is None  # nobody in the network
    assert watch.update(4.0, [0.0]) is None and watch.update(5.9, [0.0]) is None
    assert watch.update(6.0, [0.0]).since == 4.0


def test_a_limit_of_zero_never_fires():
    watch = StandstillWatch(0.0)
    assert all(watch.update(t, [0.0]) is None for t in range(1000))


def _stopping_run(tmp_path, deadlock_time: float):
    """One vehicle of the user's route file that stops for 500 s on SUMO's cross net."""
    routes = tmp_path / "stop.rou.xml"
    routes.write_text(
        '<routes>\n  <vType id="car" length="4.5" width="1.8"/>\n'
        '  <vehicle id="parked" type="car" depart="0" departSpeed="max"><route edges="1fi 1si 2o 2fo"/>'
        '<stop lane="1fi_0" endPos="30" duration="500"/></vehicle>\n</routes>\n')
    scenario = tmp_path / f"stop{deadlock_time:g}.toml"
    scenario.write_text(f'[scenario]\nname = "stop"\nduration = 20.0\ndrain = 60.0\ndeadlock_time = {deadlock_time}\n\n'
                        '[controller]\nkind = "sumo-priority"\n\n'
                        '[network]\nfile = "$SUMO_HOME/tools/game/cross/cross.net.xml"\njunctions = ["0"]\n'
                        f'routes = "{routes}"\n')
    out = tmp_path / f"run{deadlock_time:g}"
    summary = run_scenario(load_scenario(scenario), out)
    return summary, pd.read_csv(out / "steps.csv")


def test_a_run_where_everyone_stands_still_ends_after_deadlock_time(tmp_path):
    summary, steps = _stopping_run(tmp_path, 10.0)
    stuck = summary["ended_early"]
    assert stuck is not None and stuck["reason"] == "deadlock" and stuck["vehicles"] == 1
    assert 1.0 < stuck["since"] < 8.0  # 30 m down its first lane at up to 13.9 m/s
    assert stuck["time"] == pytest.approx(stuck["since"] + 10.0, abs=0.11)
    assert steps["time"].max() == pytest.approx(stuck["time"], abs=0.11)  # nothing recorded after it
    assert summary["counts"]["arrived"] == 0 and summary["counts"]["departed"] == 1
    on_disk = json.loads((tmp_path / "run10" / "summary.json").read_text())
    assert on_disk["ended_early"] == stuck and on_disk["settings"]["scenario"]["deadlock_time"] == 10.0
    # without the watch the same run goes on to its end (duration + drain = 80 s)
    free, free_steps = _stopping_run(tmp_path, 0.0)
    assert free["ended_early"] is None and free_steps["time"].max() > 79.0
