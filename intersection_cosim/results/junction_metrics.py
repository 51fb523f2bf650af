"""Per-junction figures of a run with one controller per managed junction.

:func:`junction_table` has one row per managed junction: its controller's control steps, compute
time and missed deadlines (its rows of steps.csv), the games it played, and the vehicles that
passed it with their mean delay, from trajectories.csv: a vehicle's delay at a junction is the
time it lost against ``v_free`` (one speed, or one per path) while on that junction's movement
paths (its control range, the junction and its exit lane), sum over its samples of
period * max(0, 1 - v / v_free).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np
import pandas as pd

from intersection_cosim.network.movements import Movements

JUNCTION_COLUMNS = ["junction", "control_steps", "compute_ms_median", "compute_ms_p95", "deadline_misses",
                    "games", "vehicles", "mean_delay"]


def path_junctions(movements: Movements) -> Mapping[str, str]:
    """Path id -> the managed junction it crosses."""
    return {pid: p.junction or movements.junctions[0] for pid, p in movements.paths.items()}


def junction_delays(traj: pd.DataFrame, junction_of: Mapping[str, str], period: float,
                    v_free: float | Mapping[str, float]) -> pd.DataFrame:
    """[s] per (junction, vehicle): the time lost against ``v_free`` [m/s] (one speed, or one per
    path id) while on the junction's paths; ``period`` [s] the time between two trajectory rows of
    a vehicle."""
    on = traj[traj["path"].isin(list(junction_of))]
    free = (on["path"].map(v_free).to_numpy(float) if isinstance(v_free, Mapping)
            else np.full(len(on), float(v_free)))
    lost = period * np.clip(1.0 - on["speed"].to_numpy(float) / free, 0.0, None)
    frame = pd.DataFrame({"junction": on["path"].map(junction_of).to_numpy(), "vehicle": on["vehicle"].to_numpy(),
                          "delay": lost})
    return frame.groupby(["junction", "vehicle"], as_index=False)["delay"].sum()


def junction_table(steps: pd.DataFrame, traj: pd.DataFrame, movements: Movements, period: float,
                   v_free: float | Mapping[str, float]) -> pd.DataFrame:
    """One row per managed junction (JUNCTION_COLUMNS; compute in [ms], mean_delay in [s])."""
    delays = junction_delays(traj, path_junctions(movements), period, v_free)
    rows = []
    for j in movements.junctions:
        mine = steps[steps["junction"].astype(str) == j] if "junction" in steps else steps
        d = delays[delays["junction"] == j]["delay"]
        rows.append({"junction": j, "control_steps": len(mine),
                     "compute_ms_median": float(mine["compute_ms"].median()) if len(mine) else np.nan,
                     "compute_ms_p95": float(mine["compute_ms"].quantile(0.95)) if len(mine) else np.nan,
                     "deadline_misses": int(mine["deadline_missed"].astype(bool).sum()),
                     "games": int(mine["games"].sum()), "vehicles": int(len(d)),
                     "mean_delay": float(d.mean()) if len(d) else np.nan})
    return pd.DataFrame(rows, columns=JUNCTION_COLUMNS)
