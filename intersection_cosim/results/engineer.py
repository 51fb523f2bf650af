"""What a traffic engineer reads of a run, from SUMO's own outputs: control delay and its level of
service per approach and movement, queue lengths, throughput, fuel and CO2.

* control delay [s]: SUMO's ``timeLoss`` (tripinfo) of the trips through the junction, averaged
  over the arrived trips of each approach and movement (a trip through several managed junctions
  is counted at the last one it crossed);
* level of service: the Highway Capacity Manual's delay bands (HCM 6th ed.), the signalized table
  (exhibit 19-8) for a run with traffic lights, the unsignalized one (two-way and all-way stop,
  exhibits 20-2 and 21-8) otherwise; the table used is named in every row;
* queue [m]: SUMO's queue output aggregated over the whole run per approach edge
  (``--queue-output.aggregation``): the maximum, and the 95th percentile over the steps in which
  the edge had a queue (SUMO samples only those);
* throughput [veh/h]: arrived trips per hour of the run's demand window;
* fuel [g] and CO2 [kg]: the sum of SUMO's emissions device (its HBEFA model with each vType's
  emission class) over the inserted trips.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np
import pandas as pd

from intersection_cosim.network.paths import MovementPath

HCM_SIGNALIZED = ((10.0, "A"), (20.0, "B"), (35.0, "C"), (55.0, "D"), (80.0, "E"))  # [s] upper bound -> LOS
HCM_UNSIGNALIZED = ((10.0, "A"), (15.0, "B"), (25.0, "C"), (35.0, "D"), (50.0, "E"))  # [s] upper bound -> LOS
TABLES = {"HCM signalized": HCM_SIGNALIZED, "HCM unsignalized": HCM_UNSIGNALIZED}
APPROACH_COLUMNS = ["junction", "approach", "movement", "vehicles", "arrived", "control_delay", "los", "los_table",
                    "throughput", "queue_p95", "queue_max"]


def level_of_service(delay: float, table: str) -> str:
    """The LOS letter of a control delay [s] by HCM table ``table`` ("" for no delay)."""
    if delay is None or (isinstance(delay, float) and math.isnan(delay)):
        return ""
    for bound, letter in TABLES[table]:
        if delay <= bound:
            return letter
    return "F"


def approach_edges(paths: Mapping[str, MovementPath]) -> dict[tuple[str, str], str]:
    """(junction, approach) -> the SUMO edge of the lane a path's vehicles stop on before the junction."""
    out = {}
    for p in paths.values():
        lane = p.lanes[max(0, p.stop_index - 1)]
        out[(p.junction, p.approach)] = lane.rsplit("_", 1)[0]
    return out


def approach_table(vehicles: pd.DataFrame, junction_of: Mapping[str, str], paths: Mapping[str, MovementPath],
                   queues: pd.DataFrame, window: float, table: str) -> pd.DataFrame:
    """One row per junction, approach and movement, and one per approach with movement "all":
    trips (that took the approach), arrived, control delay [s], LOS, throughput [veh/h over
    ``window`` s], 95th-percentile and maximum queue [m] of the approach edge (same on its rows)."""
    v = vehicles[vehicles["approach"].astype(str) != ""].copy()
    v["junction"] = v["vehicle"].map(lambda vid: junction_of.get(vid, ""))
    edges = approach_edges(paths)
    q = queues.set_index("edge") if len(queues) else None
    rows = []
    for (junction, approach), group in v.groupby(["junction", "approach"], sort=True):
        edge = edges.get((junction, approach)) or edges.get(("", approach), "")  # "": the generated net's one
        p95 = float(q.loc[edge, "p95_m"]) if q is not None and edge in q.index else 0.0
        qmax = float(q.loc[edge, "max_m"]) if q is not None and edge in q.index else 0.0
        parts = [(m, g) for m, g in group.groupby("movement", sort=True)] + [("all", group)]
        for movement, g in parts:
            arrived = g["arrival"].notna()
            delay = float(g.loc[arrived, "time_loss"].mean()) if arrived.any() else np.nan
            rows.append({"junction": junction, "approach": approach, "movement": movement, "vehicles": len(g),
                         "arrived": int(arrived.sum()), "control_delay": delay,
                         "los": level_of_service(delay, table), "los_table": table,
                         "throughput": arrived.sum() / window * 3600.0, "queue_p95": p95, "queue_max": qmax})
    return pd.DataFrame(rows, columns=APPROACH_COLUMNS)


def run_energy(tripinfo: pd.DataFrame) -> dict:
    """Fuel [g] and CO2 [kg] summed over the run's trips (SUMO's emissions device), and per
    arrived trip [g]; None where the device wrote nothing."""
    if "fuel_mg" not in tripinfo or tripinfo["fuel_mg"].isna().all():
        return {"fuel_g": None, "co2_kg": None, "fuel_g_per_trip": None, "co2_g_per_trip": None}
    fuel, co2 = float(tripinfo["fuel_mg"].sum()) / 1e3, float(tripinfo["co2_mg"].sum()) / 1e3  # [g]
    n = max(1, int(tripinfo["arrival"].ge(0).sum()))
    return {"fuel_g": fuel, "co2_kg": co2 / 1e3, "fuel_g_per_trip": fuel / n, "co2_g_per_trip": co2 / n}


def delay_summary(table: pd.DataFrame) -> dict:
    """The run's control delay [s] over every arrived trip of the approaches (weighted by trips),
    its LOS, and the worst approach's LOS."""
    rows = table[table["movement"] == "all"]
    if rows.empty or rows["arrived"].sum() == 0:
        return {"control_delay": None, "los": "", "worst_los": "", "los_table": ""}
    ok = rows[rows["arrived"] > 0]
    delay = float((ok["control_delay"] * ok["arrived"]).sum() / ok["arrived"].sum())
    name = str(rows["los_table"].iloc[0])
    return {"control_delay": delay, "los": level_of_service(delay, name),
            "worst_los": max(ok["los"]), "los_table": name}
