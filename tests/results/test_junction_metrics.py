"""results/junction_metrics.py: per-junction compute and delay."""

import pandas as pd
import pytest

from intersection_cosim.results.junction_metrics import junction_delays


def test_delay_is_the_time_lost_against_free_speed_on_the_junction_s_paths():
    junction_of = {"p1": "J1", "p2": "J2"}
    rows = [(t / 10, "a", "p1", 0.0) for t in range(10)]  # standing 1 s at J1
    rows += [(1 + t / 10, "a", "p2", 5.0) for t in range(10)]  # 1 s at half of 10 m/s at J2
    rows += [(t / 10, "b", "p1", 12.0) for t in range(10)]  # faster than free speed: no delay
    rows += [(t / 10, "c", "elsewhere", 0.0) for t in range(10)]  # on no managed path
    traj = pd.DataFrame(rows, columns=["time", "vehicle", "path", "speed"])
    d = junction_delays(traj, junction_of, period=0.1, v_free=10.0).set_index(["junction", "vehicle"])["delay"]
    assert d[("J1", "a")] == pytest.approx(1.0)
    assert d[("J2", "a")] == pytest.approx(0.5)
    assert d[("J1", "b")] == 0.0
    assert "c" not in d.index.get_level_values("vehicle")


def test_delay_per_path_counts_each_path_against_its_own_free_speed():
    """Route-file vehicles desiring their roads' limits: 12 m/s on a 13.89 m/s approach is a delay,
    12 m/s on an 8.33 m/s one is none (against one 10 m/s both would count nothing)."""
    junction_of = {"fast": "J1", "slow": "J2"}
    rows = [(t / 10, "a", "fast", 12.0) for t in range(10)] + [(t / 10, "b", "slow", 12.0) for t in range(10)]
    traj = pd.DataFrame(rows, columns=["time", "vehicle", "path", "speed"])
    d = junction_delays(traj, junction_of, period=0.1, v_free={"fast": 13.89, "slow": 8.33})
    d = d.set_index(["junction", "vehicle"])["delay"]
    assert d[("J1", "a")] == pytest.approx(1.0 - 12.0 / 13.89)
    assert d[("J2", "b")] == 0.0
