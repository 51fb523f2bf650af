"""RESCO's average delay of a run, computed as RESCO computes it, so that our baselines can be put
next to RESCO's published ones (Ault and Sharon, "Reinforcement Learning Benchmarks for Traffic
Signal Control", NeurIPS 2021 Datasets and Benchmarks; their ``resco_benchmark/utils/readXML.py``).

RESCO's runs stop at the scenario's end; its delay [s] is the mean over

* every trip of SUMO's tripinfo (arrived by the end): ``timeLoss + departDelay`` [s], and
* every vehicle of the demand whose scheduled depart lies after that of the last trip to depart
  (RESCO's "never departed"): ``end - depart`` [s].

It differs from our ``time_loss_mean`` (tripinfo timeLoss of every arrived trip, drain included) by
the insertion delay and the penalty of the backlog, which is why a jammed controller scores much
worse under it. Vehicles inserted but still driving at the end count in neither term (as in RESCO).
Only single departures (vehicles, trips) enter the backlog term: flows have no one depart time.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from intersection_cosim.results.sumo_outputs import read_tripinfo
from intersection_cosim.scenario.sumocfg import route_demand

SINGLE_DEPARTURES = ("vehicle", "trip")  # demand elements with one scheduled depart each


def scheduled_departs(route_files: list[Path]) -> np.ndarray:
    """[s] the scheduled departs of the vehicles and trips of ``route_files``."""
    return np.array([d.begin for path in route_files for d in route_demand(str(path), SINGLE_DEPARTURES)], float)


def resco_delay(tripinfo: Path, route_files: list[Path], end: float) -> float:
    """[s] RESCO's average delay of one run whose demand ends at ``end`` [s] (see the module);
    NaN if no trip arrived by ``end`` and no vehicle is left waiting."""
    trips = read_tripinfo(tripinfo)
    trips = trips[trips["arrival"] <= end + 1e-9]
    delays = (trips["time_loss"] + trips["depart_delay"]).to_numpy(float)
    if len(trips):
        last = trips.loc[trips["depart"].idxmax()]
        last_scheduled = float(last["depart"] - last["depart_delay"])  # [s]
    else:
        last_scheduled = -math.inf
    departs = scheduled_departs(route_files)
    waiting = departs[(departs > last_scheduled + 1e-9) & (departs < end)]
    total = np.concatenate([delays, end - waiting])
    return float(total.mean()) if len(total) else math.nan
