"""Per-vehicle and per-pair metrics of a run, computed from its trajectories and SUMO's outputs.

``min_ttc`` follows the paper's definitions: for a following pair TTC_log = gap / closing speed
(Eqs. 16-17); for a cross or confluence pair TTC_lat = |TCP_a - TCP_b| with TCP = distance to the
conflict point / speed (Eqs. 20-22), while neither vehicle has passed the point.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from intersection_cosim.models.cost import lateral_ttc, longitudinal_ttc, time_to_conflict_point
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.conflict_zones import conflict_zone, point_zone, swept_area
from intersection_cosim.network.paths import MovementPath
from intersection_cosim.results.overlaps import overlapping_pairs

VEHICLE_COLUMNS = ["vehicle", "approach", "movement", "kappa", "depart", "arrival", "travel_time",
                   "time_loss", "exit_lane", "collided", "driver", "vtype"]
PAIR_COLUMNS = ["vehicle_a", "vehicle_b", "conflict", "min_ttc", "pet", "min_ttc_ssm", "time_min_ttc_ssm", "pet_ssm",
                "game_steps",
                "driver_a", "driver_b", "vtype_a", "vtype_b"]


def vehicle_table(infos: dict, tripinfo: pd.DataFrame, exit_lanes: dict[str, str],
                  collisions: pd.DataFrame) -> pd.DataFrame:
    """vehicles.csv: travel_time and time_loss are tripinfo's ``duration`` and ``timeLoss`` [s];
    ``driver`` is "av" or "human", ``vtype`` the vehicle's SUMO vType id."""
    trip = tripinfo.set_index("vehicle")
    collided = set(collisions["collider"]) | set(collisions["victim"])
    rows = []
    for vid, info in infos.items():
        t = trip.loc[vid] if vid in trip.index else None
        arrived = t is not None and t["arrival"] >= 0
        rows.append({
            "vehicle": vid, "approach": info.approach, "movement": info.movement, "kappa": info.kappa,
            "depart": t["depart"] if t is not None else np.nan,
            "arrival": t["arrival"] if arrived else np.nan,
            "travel_time": t["duration"] if arrived else np.nan,
            "time_loss": t["time_loss"] if arrived else np.nan,
            "exit_lane": exit_lanes.get(vid, ""), "collided": vid in collided,
            "driver": getattr(info, "driver", "av"), "vtype": getattr(info, "vtype", "av"),
        })
    return pd.DataFrame(rows, columns=VEHICLE_COLUMNS)


def pair_min_ttc(conflict, a: pd.DataFrame, b: pd.DataFrame, model: ModelSettings,
                 zone_a: tuple[float, float] | None = None, zone_b: tuple[float, float] | None = None,
                 lengths: tuple[float, float] | None = None) -> float:
    """[s] minimum TTC of one conflicting pair (``lengths`` [m]: of ``a`` and ``b``, None: the
    model's vehicle_length for both; a following gap is to the leader's rear).

    ``a`` and ``b`` are the two vehicles' trajectory rows (time, s, speed) on common times, with
    ``conflict`` oriented so that ``s_a`` belongs to ``a``. ``zone_a`` / ``zone_b`` are the arc
    lengths [m] where each path is inside the conflict zone (stop line, junction exit).

    Following pairs: the minimum of TTC_log over the time both are on the shared stretch.
    Cross and confluence pairs: the minimum of TTC_lat = |TCP_a - TCP_b| over the *risk window*,
    the steps in which at least one of the two is inside the conflict zone and neither has passed
    the point. Before that window TTC_lat is a prediction from speeds that are still free to
    change (at the paper's start points it is below 0.5 s in every scenario, whatever the
    controller later does); inside it, the first vehicle is committed and the second's margin is
    what the decision produced.
    """
    return min_ttc_arrays(conflict, a["s"].to_numpy(), a["speed"].to_numpy(), b["s"].to_numpy(),
                          b["speed"].to_numpy(), model, zone_a, zone_b, lengths)


def min_ttc_arrays(conflict, sa: np.ndarray, va: np.ndarray, sb: np.ndarray, vb: np.ndarray,
                   model: ModelSettings, zone_a: tuple[float, float] | None = None,
                   zone_b: tuple[float, float] | None = None,
                   lengths: tuple[float, float] | None = None) -> float:
    """[s] :func:`pair_min_ttc` on arrays: arc lengths ``sa``, ``sb`` [m] and speeds ``va``,
    ``vb`` [m/s] of the two vehicles at their common times (``lengths`` [m] as there)."""
    if conflict.kind == "following":
        a_leads = sa >= sb
        s_lead, s_follow = np.where(a_leads, sa, sb), np.where(a_leads, sb, sa)
        v_lead, v_follow = np.where(a_leads, va, vb), np.where(a_leads, vb, va)
        len_a, len_b = lengths if lengths is not None else (model.vehicle_length, model.vehicle_length)
        len_lead = np.where(a_leads, len_a, len_b) if lengths is not None else model.vehicle_length  # [m]
        shared_end = min(conflict.s_a, conflict.s_b)
        on_shared = (s_follow <= shared_end) & (s_lead - len_lead <= shared_end)
        gap = s_lead - s_follow - len_lead
        ttc = np.asarray(longitudinal_ttc(gap, v_follow, v_lead), float)[on_shared]
    else:
        before = (sa < conflict.s_a) & (sb < conflict.s_b)
        if zone_a is not None and zone_b is not None:
            inside = ((sa >= zone_a[0]) & (sa <= zone_a[1])) | ((sb >= zone_b[0]) & (sb <= zone_b[1]))
            before &= inside
        tcp_a = time_to_conflict_point(conflict.s_a - sa, va, model.tcp_speed_floor)
        tcp_b = time_to_conflict_point(conflict.s_b - sb, vb, model.tcp_speed_floor)
        ttc = np.abs(np.asarray(lateral_ttc(tcp_a, tcp_b), float))[before]
    ttc = ttc[np.isfinite(ttc)]
    return float(ttc.min()) if ttc.size else np.nan


def crossing_time(time: np.ndarray, s: np.ndarray, s_mark: float) -> float:
    """[s] the first time the arc length ``s`` [m] reaches ``s_mark`` [m], interpolated linearly
    between the recorded steps ``time`` [s]; NaN if it never does (or did from the first step on,
    when the moment is unknown)."""
    reached = np.flatnonzero(s >= s_mark)
    if not reached.size or reached[0] == 0:
        return np.nan
    k = reached[0]
    ds = s[k] - s[k - 1]
    frac = (s_mark - s[k - 1]) / ds if ds > 0 else 1.0
    return float(time[k - 1] + frac * (time[k] - time[k - 1]))


def post_encroachment_time(a: pd.DataFrame, b: pd.DataFrame, zone_a: tuple[float, float],
                           zone_b: tuple[float, float]) -> float:
    """[s] PET of one conflicting pair: from the first vehicle's rear leaving the crossing zone to
    the second's front entering it.

    ``a``, ``b``: each vehicle's own trajectory (index time [s], column ``s`` [m] front arc
    length); ``zone_a`` / ``zone_b`` [m]: the front arc lengths between which each body overlaps
    the other's swept area (:func:`network.conflict_zones.conflict_zone`), so the front at
    ``zone_out`` is the rear leaving it. Zero when the two were in the zone at once; NaN when a
    vehicle's entry or exit was not recorded.
    """
    return pet_arrays(a.index.to_numpy(float), a["s"].to_numpy(float), b.index.to_numpy(float),
                      b["s"].to_numpy(float), zone_a, zone_b)


def pet_arrays(ta: np.ndarray, sa: np.ndarray, tb: np.ndarray, sb: np.ndarray,
               zone_a: tuple[float, float], zone_b: tuple[float, float]) -> float:
    """[s] :func:`post_encroachment_time` on arrays: each vehicle's times ``ta``, ``tb`` [s] and
    front arc lengths ``sa``, ``sb`` [m]."""
    in_a, out_a = crossing_time(ta, sa, zone_a[0]), crossing_time(ta, sa, zone_a[1])
    in_b, out_b = crossing_time(tb, sb, zone_b[0]), crossing_time(tb, sb, zone_b[1])
    first_a = in_a <= in_b
    pet = in_b - out_a if first_a else in_a - out_b
    return float(max(pet, 0.0)) if np.isfinite(pet) else np.nan


class _Zones:
    """Crossing zones per ordered path pair, with each path's swept area built once (per table)."""

    def __init__(self, paths: dict[str, MovementPath], model: ModelSettings):
        self.paths, self.model = paths, model
        self.swept: dict[str, object] = {}
        self.zones: dict[tuple[str, str], tuple[float, float]] = {}

    def zone(self, conflict, body_a: tuple[float, float] | None = None,
             body_b: tuple[float, float] | None = None) -> tuple[float, float] | None:
        """[m] front arc lengths on ``conflict.path_a`` inside the crossing zone: the body-overlap
        zone for a cross pair, the conflict point's occupancy (:func:`point_zone`) otherwise.
        ``body_a`` / ``body_b`` [m]: (length, width) of the vehicles on path_a / path_b (None:
        the model's)."""
        own = (self.model.vehicle_length, self.model.vehicle_width)
        body_a, body_b = body_a or own, body_b or own
        key = (conflict.path_a, conflict.path_b) + ((body_a, body_b) if (body_a, body_b) != (own, own) else ())
        if key not in self.zones:
            length, width = body_a
            zone = None
            if conflict.kind == "cross" and all(p in self.paths for p in key[:2]):
                swept_key = key[1] if body_b == own else (key[1], body_b)
                if swept_key not in self.swept:
                    self.swept[swept_key] = swept_area(self.paths[key[1]], *body_b)
                zone = conflict_zone(self.paths[key[0]], self.paths[key[1]], length, width, self.swept[swept_key])
            self.zones[key] = zone if zone is not None else point_zone(conflict.s_a, length, width)
        return self.zones[key]


def pair_table(traj: pd.DataFrame, final_paths: dict[str, str], paths: dict[str, MovementPath],
               conflicts: dict, model: ModelSettings, ssm: pd.DataFrame,
               game_steps: dict[tuple[str, str], int],
               kinds: dict[str, tuple[str, str]] | None = None,
               bodies: dict[str, tuple[float, float]] | None = None) -> pd.DataFrame:
    """pairs.csv: one row per pair of vehicles whose paths conflict and who met in the network;
    ``kinds``: vehicle id -> (driver, vtype), the kinds of the two vehicles of a row (missing:
    ("av", "av")); ``bodies``: vehicle id -> (length, width) [m] (missing: the model's), the
    bodies its PET zones and following gaps are measured with."""
    kinds, bodies = kinds or {}, bodies or {}
    own = (model.vehicle_length, model.vehicle_width)
    tracks = _tracks(traj)
    ssm_min = _ssm_minima(ssm)
    rows = []
    zones = _Zones(paths, model)
    ids = sorted(tracks)
    first = np.array([tracks[v][0].min() for v in ids])  # [s] first recorded time of each vehicle
    last = np.array([tracks[v][0].max() for v in ids])  # [s] last one
    for i, va in enumerate(ids):
        met = np.flatnonzero((last[i + 1:] >= first[i]) & (first[i + 1:] <= last[i])) + i + 1
        for j in met:
            vb = ids[j]
            conflict = conflicts.get((final_paths.get(va), final_paths.get(vb)))
            if conflict is None:
                continue
            (ta, sa, spa), (tb, sb, spb) = tracks[va], tracks[vb]
            ia, ib = _common_times(ta, tb)
            ttc_ssm, pet_ssm, ttc_ssm_time = ssm_min.get((va, vb), (np.nan, np.nan, np.nan))
            rows.append({"vehicle_a": va, "vehicle_b": vb, "conflict": conflict.kind,
                         "min_ttc": min_ttc_arrays(conflict, sa[ia], spa[ia], sb[ib], spb[ib], model,
                                                   _zone(paths, final_paths.get(va)),
                                                   _zone(paths, final_paths.get(vb)),
                                                   (bodies.get(va, own)[0], bodies.get(vb, own)[0]) if bodies else None),
                         "pet": pet_arrays(ta, sa, tb, sb, zones.zone(conflict, bodies.get(va), bodies.get(vb)),
                                           zones.zone(conflict.swapped(), bodies.get(vb), bodies.get(va))),
                         "min_ttc_ssm": ttc_ssm, "time_min_ttc_ssm": ttc_ssm_time,
                         "pet_ssm": pet_ssm, "game_steps": int(game_steps.get((va, vb), 0)),
                         "driver_a": kinds.get(va, ("av", "av"))[0], "driver_b": kinds.get(vb, ("av", "av"))[0],
                         "vtype_a": kinds.get(va, ("av", "av"))[1], "vtype_b": kinds.get(vb, ("av", "av"))[1]})
    return pd.DataFrame(rows, columns=PAIR_COLUMNS)


def _tracks(traj: pd.DataFrame) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """vehicle id -> (time [s], s [m], speed [m/s]) in the order of its recorded rows (one
    sort by vehicle and row, no per-vehicle DataFrame)."""
    vid = traj["vehicle"].to_numpy()
    order = np.argsort(vid, kind="stable")
    vid = vid[order]
    cols = [traj[c].to_numpy(float)[order] for c in ("time", "s", "speed")]
    starts = np.flatnonzero(np.r_[True, vid[1:] != vid[:-1]]) if len(vid) else np.zeros(0, int)
    ends = np.r_[starts[1:], len(vid)]
    return {vid[a]: tuple(c[a:b] for c in cols) for a, b in zip(starts, ends)}


def _common_times(ta: np.ndarray, tb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Indices into ``ta`` and ``tb`` of their common times, in the order of ``ta`` (an inner
    join on time; each vehicle has at most one row per time)."""
    ia = np.flatnonzero(np.isin(ta, tb))
    sorter = np.argsort(tb, kind="stable")
    ib = sorter[np.searchsorted(tb, ta[ia], sorter=sorter)]
    return ia, ib


def _ssm_minima(ssm: pd.DataFrame) -> dict[tuple[str, str], tuple[float, float, float]]:
    """(vehicle, vehicle) in sorted order -> the smallest (min_ttc [s], pet [s]) of SUMO's SSM
    encounters of the two (NaN where none was finite) and the time [s] that min_ttc was taken at."""
    if not len(ssm):
        return {}
    key = ssm.assign(a=ssm[["ego", "foe"]].min(axis=1), b=ssm[["ego", "foe"]].max(axis=1))
    if "min_ttc_time" not in key:
        key = key.assign(min_ttc_time=np.nan)
    agg = key.groupby(["a", "b"], sort=False)[["min_ttc", "pet"]].min()
    first = key.sort_values(["min_ttc", "min_ttc_time"], kind="stable").groupby(["a", "b"], sort=False).head(1)
    at = {(a, b): float(t) if np.isfinite(m) else np.nan
          for a, b, m, t in zip(first["a"], first["b"], first["min_ttc"].astype(float), first["min_ttc_time"].astype(float))}
    return {k: (float(r[0]), float(r[1]), at.get(k, np.nan)) for k, r in zip(agg.index, agg.to_numpy(float))}


def _zone(paths: dict[str, MovementPath], pid: str | None) -> tuple[float, float] | None:
    """[m] arc lengths of a path's stretch inside the conflict zone (stop line to junction exit)."""
    return None if pid is None or pid not in paths else (paths[pid].s_stop, paths[pid].s_exit)


def body_overlaps(traj: pd.DataFrame, length: float, width: float) -> list[tuple[float, str, str]]:
    """(time, vehicle, vehicle) of every recorded pair of overlapping vehicle bodies (each
    ``length`` x ``width`` [m] behind its recorded front bumper, :mod:`~intersection_cosim.results.overlaps`):
    an independent check next to SUMO's collision output."""
    out = []
    for tm, g in traj.groupby("time", sort=True):
        if len(g) < 2:
            continue
        n = len(g)
        i, j = overlapping_pairs(g["x"].to_numpy(), g["y"].to_numpy(), g["heading"].to_numpy(),
                                 np.full(n, float(length)), np.full(n, float(width)))
        ids = g["vehicle"].to_numpy()
        out += [(float(tm), str(ids[a]), str(ids[b])) for a, b in zip(i.tolist(), j.tolist())]
    return out
