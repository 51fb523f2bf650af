"""The verdict of one finished stress run, read from its run folder only: what SUMO and the run's
own checks recorded, never the controller's bookkeeping.

Failure kinds (the first event of each kind in a run):

- ``collision``: SUMO's collision output (collisions.csv: SUMO's records as the loop saw them);
- ``person_hit``: a SUMO collision of a vehicle and a person (types of PEDESTRIAN_COLLISIONS);
- ``overlap``: our own body-overlap check of the vehicles in and around the managed junctions
  (overlaps.csv, results/overlaps.py);
- ``lock``: the run ended early because every vehicle stood still for ``deadlock_time``
  (summary.json ``ended_early``, experiments/deadlock.py);
- ``never_arrived``: a vehicle that departed, had not arrived when the run ended and stood still
  for at least ``stuck_time`` before its end (one still driving only ran out of drain time);
- ``hard_braking``: a vehicle whose acceleration SUMO realised (trajectories.csv) was below minus
  its vType's ``emergencyDecel`` (scenario.rou.xml) by more than the tolerance: harder than the
  vehicle can brake at all. SUMO caps its own drivers at emergencyDecel and realises a controlled
  vehicle's command as given (speed mode 0), so this is a command no vehicle could follow, or SUMO
  forcing a stop.

Near misses (recorded, but no failure unless ``emergency_braking_fails`` is set):

- ``emergency_braking``: a vehicle braked harder than its vType's ``decel`` by more than the
  tolerance, but not harder than its ``emergencyDecel`` (SUMO's "performs emergency braking"
  events). The safety rules command this on purpose when a vehicle must stop short (a pedestrian
  stepping out, a leader braking), and SUMO's human drivers do it when a controlled vehicle takes
  their right of way; counted as a failure it fired in most runs and drowned the real failures.
  Its ``why`` says whether the controller commanded it or SUMO's driver model braked.

The margin [s] is the least of the PET of every crossing and merging pair (pairs.csv) and the time
gap of every follower to the vehicle ahead of it on its lane (trajectories.csv); a collision,
person hit, overlap or lock puts it at :data:`FAILED_MARGIN`, below every margin.
"""

from __future__ import annotations

import dataclasses
import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas as pd

from intersection_cosim.experiments.deadlock import STANDSTILL_SPEED
from intersection_cosim.results.layout import (COLLISION_LOG_FILE, OVERLAPS_FILE, PAIRS_FILE, RUN_MARKER,
                                               VEHICLES_FILE, trajectories_file)
from intersection_cosim.results.sumo_outputs import PEDESTRIAN_COLLISIONS

FAILED_MARGIN = -1.0  # [s] the margin of a run with a collision, overlap or lock
NO_MARGIN = 99.0  # [s] the margin of a run without any pair or follower (nothing came close)
SEVERE = ("collision", "person_hit", "overlap", "lock")  # kinds that put the margin below every other
KINDS = ("collision", "person_hit", "overlap", "lock", "never_arrived", "hard_braking", "emergency_braking")
NEAR_MISS_KINDS = ("emergency_braking",)  # kinds that are no failure unless emergency_braking_fails
DEFAULT_DECEL = 4.5  # [m/s^2] SUMO's default decel, for a vType the route file does not define
DEFAULT_EMERGENCY_DECEL = 9.0  # [m/s^2] SUMO's default emergencyDecel of a passenger car (at least decel)
ROUTES_FILE = "scenario.rou.xml"  # the run's SUMO routes (experiments/run_inputs.py)


@dataclasses.dataclass(frozen=True)
class Failure:
    """The first event of one kind in a run: when [s], where (a lane), who, and why it counts."""

    kind: str
    time: float
    place: str
    vehicles: tuple[str, ...]
    why: str

    @property
    def site(self) -> str:
        """The place failures are de-duplicated by: the edge of the lane (``:J`` inside junction J)."""
        lane = self.place
        if lane.startswith(":"):
            return lane[1:].rsplit("_", 2)[0] if lane.count("_") >= 2 else lane[1:]
        return lane.rsplit("_", 1)[0] if "_" in lane else lane


@dataclasses.dataclass(frozen=True)
class Verdict:
    """A run's margin [s], its failures (one per kind, by time), arrivals and compute."""

    margin: float
    min_pet: float  # [s] NaN: no crossing or merging pair
    min_time_gap: float  # [s] NaN: no follower
    failures: tuple[Failure, ...]
    vehicles: int
    arrived: int
    compute_ms_median: float  # [ms] per control step
    near_misses: tuple[Failure, ...] = ()  # NEAR_MISS_KINDS events that do not count as failures

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "Verdict":
        def events(rows: list[dict]) -> tuple[Failure, ...]:
            return tuple(Failure(**{**f, "vehicles": tuple(f["vehicles"])}) for f in rows)
        return cls(**{**d, "failures": events(d["failures"]), "near_misses": events(d.get("near_misses", []))})


def _first_collision(folder: Path) -> list[Failure]:
    log = pd.read_csv(folder / COLLISION_LOG_FILE)
    out = []
    for kind, rows in (("person_hit", log[log["type"].isin(PEDESTRIAN_COLLISIONS)]),
                       ("collision", log[~log["type"].isin(PEDESTRIAN_COLLISIONS)])):
        if len(rows):
            r = rows.sort_values("time", kind="stable").iloc[0]
            who = (str(r["collider"]), str(r["victim"]))
            out.append(Failure(kind, float(r["time"]), str(r["lane"]), who,
                               f"SUMO recorded a {r['type']} collision of {who[0]} and {who[1]} on {r['lane']}"))
    return out


def _first_overlap(folder: Path) -> list[Failure]:
    rows = pd.read_csv(folder / OVERLAPS_FILE)
    if not len(rows):
        return []
    r = rows.sort_values("time", kind="stable").iloc[0]
    who = (str(r["vehicle_a"]), str(r["vehicle_b"]))
    return [Failure("overlap", float(r["time"]), str(r["lane_a"]), who,
                    f"the bodies of {who[0]} and {who[1]} overlap (our overlap check) on {r['lane_a']}")]


def _lock_and_stuck(folder: Path, summary: dict, traj: pd.DataFrame, stuck_time: float) -> list[Failure]:
    out = []
    end = summary.get("ended_early")
    last = traj.sort_values("time", kind="stable").groupby("vehicle").tail(1)
    if end and end.get("reason") == "deadlock":
        standing = last[last["time"] >= end["since"] - 1e-6]
        place = str(standing["lane"].mode().iloc[0]) if len(standing) else ""
        out.append(Failure("lock", float(end["since"]), place, tuple(sorted(standing["vehicle"].astype(str)))[:8],
                           f"all {end['vehicles']} vehicles stood still from t={end['since']:.1f} s "
                           f"to t={end['time']:.1f} s (deadlock_time)"))
    vehicles = pd.read_csv(folder / VEHICLES_FILE)
    stuck = vehicles[vehicles["depart"].notna() & vehicles["arrival"].isna()]
    if len(stuck):
        moving = traj[traj["vehicle"].isin(set(stuck["vehicle"])) & (traj["speed"] >= STANDSTILL_SPEED)]
        last_moved = moving.groupby("vehicle")["time"].max()
        when = {v: float(last_moved.get(v, d)) for v, d in zip(stuck["vehicle"], stuck["depart"])}
        end = float(traj["time"].max())
        when = {v: t for v, t in when.items() if t <= end - stuck_time + 1e-9}
    if len(stuck) and when:
        first = min(when, key=lambda v: (when[v], v))
        where = last.set_index("vehicle")["lane"].get(first, "")
        order = tuple(sorted(when, key=lambda v: (when[v], v)))[:8]
        out.append(Failure("never_arrived", when[first], str(where), order,
                           f"{len(when)} departed vehicles never arrived: they stood still for the last "
                           f"{stuck_time:g} s or more of the run; {first} from t={when[first]:.1f} s on {where}"))
    return out


def _decels(folder: Path) -> tuple[dict[str, tuple[float, float]], dict[str, str]]:
    """[m/s^2] each vType's (decel, emergencyDecel), and each vehicle's vType, from the run's routes file."""
    decel, vtype = {}, {}
    path = folder / ROUTES_FILE
    if path.is_file():
        for _, el in ET.iterparse(path):
            if el.tag == "vType":
                d = float(el.get("decel", DEFAULT_DECEL))
                decel[el.get("id")] = (d, float(el.get("emergencyDecel", max(d, DEFAULT_EMERGENCY_DECEL))))
            elif el.tag == "vehicle":
                vtype[el.get("id")] = el.get("type", "DEFAULT_VEHTYPE")
    return decel, vtype


def _braking(folder: Path, traj: pd.DataFrame, tolerance: float) -> list[Failure]:
    """The first ``hard_braking`` (beyond emergencyDecel + ``tolerance`` [m/s^2]) and the first
    ``emergency_braking`` (beyond decel + ``tolerance``, within emergencyDecel + ``tolerance``)."""
    decel, vtype = _decels(folder)
    limits = traj["vehicle"].map(lambda v: decel.get(vtype.get(v, ""), (DEFAULT_DECEL, DEFAULT_EMERGENCY_DECEL)))
    normal = limits.map(lambda lim: lim[0]).astype(float)
    emergency = limits.map(lambda lim: lim[1]).astype(float)
    beyond = traj["accel"] < -(emergency + tolerance)
    out = []
    for kind, rows, limit, what in (
            ("hard_braking", traj[beyond], emergency, "emergencyDecel"),
            ("emergency_braking", traj[~beyond & (traj["accel"] < -(normal + tolerance))], normal, "decel")):
        if not len(rows):
            continue
        r = rows.sort_values("time", kind="stable").iloc[0]
        by = ("the controller commanded it" if not pd.isna(r["accel_cmd"])
              else "SUMO's driver model braked")
        out.append(Failure(kind, float(r["time"]), str(r["lane"]), (str(r["vehicle"]),),
                           f"{r['vehicle']} braked at {-r['accel']:.2f} m/s^2, harder than its {what} "
                           f"{limit[r.name]:g} m/s^2 on {r['lane']} ({by})"))
    return out


def min_time_gap(traj: pd.DataFrame, length: float, floor: float) -> float:
    """[s] the least time gap of a follower (speed >= ``floor`` [m/s]) to the nearest vehicle ahead
    of it on its lane (its rear ``length`` [m] behind its front), over the run; NaN: none."""
    best = math.inf
    t = traj[~traj["lane"].astype(str).str.startswith(":")]
    for _, g in t.groupby(["time", "lane"], sort=False):
        if len(g) < 2:
            continue
        x, y, h, v = (g[c].to_numpy(float) for c in ("x", "y", "heading", "speed"))
        dx, dy = x[None, :] - x[:, None], y[None, :] - y[:, None]  # [i, j]: j relative to i
        ahead = dx * np.cos(h)[:, None] + dy * np.sin(h)[:, None]  # [m] along i's heading
        ahead = np.where(ahead > 0, ahead, np.inf)
        gap = ahead.min(axis=1) - length  # [m] front of i to rear of the one ahead
        ok = np.isfinite(gap) & (v >= floor)
        if ok.any():
            best = min(best, float((np.maximum(gap[ok], 0.0) / v[ok]).min()))
    return best if math.isfinite(best) else math.nan


def judge(folder: str | Path, time_gap_floor: float = 1.0, braking_tolerance: float = 0.5,
          stuck_time: float = 30.0, near_misses_fail: bool = False) -> Verdict:
    """The verdict of the finished run in ``folder`` (module docstring); ``near_misses_fail``: the
    near misses count as failures too."""
    folder = Path(folder)
    summary = json.loads((folder / RUN_MARKER).read_text())
    traj = pd.read_csv(trajectories_file(folder), usecols=["time", "vehicle", "x", "y", "speed", "accel",
                                                            "heading", "lane", "accel_cmd"])
    failures = _first_collision(folder) + _first_overlap(folder) + _lock_and_stuck(folder, summary, traj, stuck_time)
    events = _braking(folder, traj, braking_tolerance)
    near = [] if near_misses_fail else [f for f in events if f.kind in NEAR_MISS_KINDS]
    failures += [f for f in events if f not in near]
    pairs = pd.read_csv(folder / PAIRS_FILE)
    pet = float(pairs["pet"].min()) if len(pairs) and pairs["pet"].notna().any() else math.nan
    length = float(summary["settings"]["model"]["vehicle_length"])
    gap = min_time_gap(traj, length, time_gap_floor)
    margin = min([m for m in (pet, gap) if not math.isnan(m)], default=NO_MARGIN)
    if any(f.kind in SEVERE for f in failures):
        margin = FAILED_MARGIN
    counts, metrics = summary["counts"], summary["metrics"]
    return Verdict(margin=round(margin, 4), min_pet=pet, min_time_gap=gap,
                   failures=tuple(sorted(failures, key=lambda f: (f.time, KINDS.index(f.kind)))),
                   vehicles=int(counts["vehicles"]), arrived=int(counts["arrived"]),
                   compute_ms_median=float(metrics["compute_ms_median"] or math.nan),
                   near_misses=tuple(sorted(near, key=lambda f: (f.time, KINDS.index(f.kind)))))
