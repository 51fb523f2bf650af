"""Readers of SUMO's own output files: tripinfo, SSM device and collisions.

These are measurements independent of ours; the run writes them next to our CSVs.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import pandas as pd


def _float(text: str | None) -> float:
    try:
        value = float(text)  # "NA" and None become NaN
    except (TypeError, ValueError):
        return math.nan
    # SUMO writes +-DBL_MAX (1.8e308) where a measure is undefined (e.g. the SSM's PET of some
    # junction encounters): not a value.
    return value if abs(value) < 1e300 else math.nan


def read_tripinfo(path: str | Path) -> pd.DataFrame:
    """One row per vehicle: depart, depart_delay (its wait for insertion), arrival, duration,
    time_loss [s], arrival_lane (SUMO id),
    and fuel_mg, co2_mg [mg] of its emissions device (NaN without one)."""
    rows = []
    for _, el in ET.iterparse(path):
        if el.tag == "tripinfo":
            em = el.find("emissions")
            rows.append({"vehicle": el.get("id"), "depart": _float(el.get("depart")),
                         "depart_delay": _float(el.get("departDelay")), "arrival": _float(el.get("arrival")), "duration": _float(el.get("duration")),
                         "time_loss": _float(el.get("timeLoss")), "arrival_lane": el.get("arrivalLane"),
                         "vaporized": el.get("vaporized", ""),
                         "fuel_mg": _float(em.get("fuel_abs")) if em is not None else math.nan,
                         "co2_mg": _float(em.get("CO2_abs")) if em is not None else math.nan})
    return pd.DataFrame(rows, columns=["vehicle", "depart", "depart_delay", "arrival", "duration", "time_loss",
                                       "arrival_lane", "vaporized", "fuel_mg", "co2_mg"])


def read_queues(path: str | Path) -> pd.DataFrame:
    """One row per edge of SUMO's aggregated queue output: p95_m and max_m [m], the 95th-percentile
    and maximum queue length over the run (no file: no rows)."""
    rows = []
    if Path(path).exists():
        for _, el in ET.iterparse(path):
            if el.tag == "edge":
                rows.append({"edge": el.get("id"), "p95_m": _float(el.get("percentileQueueLengthInMeters")),
                             "max_m": _float(el.get("maxQueueLengthInMeters"))})
    return pd.DataFrame(rows, columns=["edge", "p95_m", "max_m"]).drop_duplicates("edge", keep="last")


SSM_COLUMNS = ["ego", "foe", "min_ttc", "min_ttc_time", "pet", "max_drac", "ssm_collision"]
# SSM's encounter type "collision": its own gap estimate went to 0 or below (TTC 0). At merges it
# flags encounters SUMO's collision check does not confirm, so such a TTC is kept out of min_ttc
# (``ssm_collision`` True) and collisions are counted by SUMO's collision output.
SSM_COLLISION_TYPE = "111"


def read_ssm(path: str | Path) -> pd.DataFrame:
    """One row per SSM encounter: ego, foe, min_ttc [s], the simulation time min_ttc_time [s] it was
    taken at, pet [s], max_drac [m/s^2] (NaN if none); ``ssm_collision``: SSM classified the
    encounter as a collision at its min TTC (SSM_COLLISION_TYPE), whose TTC 0 is then left out
    (NaN)."""
    rows = []
    if not Path(path).exists():
        return pd.DataFrame(columns=SSM_COLUMNS)
    for _, el in ET.iterparse(path):
        if el.tag == "conflict":
            ttc = el.find("minTTC")
            pet = el.find("PET")
            drac = el.find("maxDRAC")
            flagged = ttc is not None and ttc.get("type") == SSM_COLLISION_TYPE
            rows.append({"ego": el.get("ego"), "foe": el.get("foe"),
                         "min_ttc": _float(ttc.get("value")) if ttc is not None and not flagged else math.nan,
                         "min_ttc_time": _float(ttc.get("time")) if ttc is not None and not flagged else math.nan,
                         "pet": _float(pet.get("value")) if pet is not None else math.nan,
                         "max_drac": _float(drac.get("value")) if drac is not None else math.nan,
                         "ssm_collision": flagged})
    return pd.DataFrame(rows, columns=SSM_COLUMNS)


PEDESTRIAN_COLLISIONS = ("crossing", "walkingarea", "sharedLane")  # SUMO's collision types of a vehicle and a person


def read_collisions(path: str | Path) -> pd.DataFrame:
    """One row per collision SUMO detected: time [s], collider, victim, type, lane."""
    rows = []
    if Path(path).exists():
        for _, el in ET.iterparse(path):
            if el.tag == "collision":
                rows.append({"time": _float(el.get("time")), "collider": el.get("collider"),
                             "victim": el.get("victim"), "type": el.get("type"), "lane": el.get("lane")})
    return pd.DataFrame(rows, columns=["time", "collider", "victim", "type", "lane"])
