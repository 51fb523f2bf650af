"""Honest collision counts of a run, from SUMO's collision log and our own overlap check.

SUMO records a collision every step two bodies overlap under ``collision.action = warn``, and on
OSM nets it reports overlaps of its own drivers inside junction clusters whose internal lanes
cross without a foe relation. So a run counts SUMO's records, the distinct vehicles involved, and
the distinct pairs (a collision event), each split by whether a commanded vehicle (one a
controller commanded at that step) is involved; our own body-overlap check of every vehicle in
and around the managed junctions (results/overlaps.py) is counted beside it the same way.
"""

from __future__ import annotations

import pandas as pd


def _pairs(frame: pd.DataFrame, a: str, b: str) -> set[tuple[str, str]]:
    return {(x, y) if x < y else (y, x) for x, y in zip(frame[a].astype(str), frame[b].astype(str))}


def _vehicles(frame: pd.DataFrame, a: str, b: str) -> int:
    return len(set(frame[a].astype(str)) | set(frame[b].astype(str)))


def collision_counts(log: pd.DataFrame, overlaps: pd.DataFrame) -> dict[str, int]:
    """The counts of summary.json's ``collisions``: ``log`` has COLLISION_LOG_COLUMNS (one row per
    SUMO record), ``overlaps`` OVERLAP_COLUMNS (one row per overlap event)."""
    by_us = log["collider_commanded"].astype(bool) | log["victim_commanded"].astype(bool)
    ours = overlaps["a_commanded"].astype(bool) | overlaps["b_commanded"].astype(bool)
    mine, theirs = log[by_us], log[~by_us]
    return {
        "sumo_records": int(len(log)),
        "sumo_vehicles": _vehicles(log, "collider", "victim"),
        "sumo_pairs": len(_pairs(log, "collider", "victim")),
        "sumo_records_commanded": int(len(mine)),
        "sumo_vehicles_commanded": _vehicles(mine, "collider", "victim"),
        "sumo_pairs_commanded": len(_pairs(mine, "collider", "victim")),
        "sumo_records_uncommanded": int(len(theirs)),
        "sumo_pairs_uncommanded": len(_pairs(theirs, "collider", "victim")),
        "overlap_events": int(len(overlaps)),
        "overlap_vehicles": _vehicles(overlaps, "vehicle_a", "vehicle_b"),
        "overlap_pairs": len(_pairs(overlaps, "vehicle_a", "vehicle_b")),
        "overlap_pairs_commanded": len(_pairs(overlaps[ours], "vehicle_a", "vehicle_b")),
    }
