"""Scenario files (TOML) -> a validated :class:`Scenario`.

Every problem is an :class:`InputError` naming the file, the field and the value; nothing is
written anywhere while loading (the net used for placement comes from the per-user cache).
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from intersection_cosim.control import registry
from intersection_cosim.errors import InputError
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.cache import cached_net
from intersection_cosim.network.path_id import PathId
from intersection_cosim.network.paths import MovementPath, load_paths
from intersection_cosim.network.spec import ARMS, LANE_USE, LANES, MOVEMENTS, IntersectionSpec
from intersection_cosim.scenario.model import (
    ControllerSettings,
    FlowSpec,
    KappaDistribution,
    Scenario,
    ScenarioSettings,
    VehicleSpec,
)
from intersection_cosim.settings import from_table

TOP_LEVEL = ("scenario", "controller", "model", "vehicle", "flow")
CONTROLLER_TABLES = ("game", "solver", "policy", "safety")  # [controller.<name>] sub-tables
VEHICLE_KEYS = ("id", "position", "approach", "lane", "distance", "movement", "exit_lane", "speed",
                "kappa", "depart", "desired_speed")
FLOW_KEYS = ("id", "approach", "movement", "rate", "kappa", "begin", "end", "lane", "speed", "distance")
PLACEMENT_TOLERANCE = 1.0  # [m] a position farther than this from every path of its movement is an error


def _number(src: str, field: str, value: Any, *, minimum: float | None = None,
            maximum: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(src, field, value, "must be a finite number")
    if minimum is not None and value < minimum:
        raise InputError(src, field, value, f"must be >= {minimum:g}")
    if maximum is not None and value > maximum:
        raise InputError(src, field, value, f"must be <= {maximum:g}")
    return float(value)


def _choice(src: str, field: str, value: Any, options: tuple[str, ...]) -> str:
    if value not in options:
        raise InputError(src, field, value, f"must be one of {', '.join(options)}")
    return value


def _unknown_keys(src: str, prefix: str, table: dict, known: tuple[str, ...]) -> None:
    for key in table:
        if key not in known:
            raise InputError(src, f"{prefix}.{key}", table[key], f"unknown key (known: {', '.join(known)})")


def default_exit_lane(lane: str, movement: str) -> str:
    """The exit lane a vehicle takes when it states no preference: the first of LANE_USE."""
    return LANE_USE[lane][movement][0]


def _place_by_position(src: str, field: str, xy: Any, movement: str, exit_lane: str | None,
                       paths: dict[str, MovementPath]) -> tuple[MovementPath, float, float]:
    if (not isinstance(xy, list) or len(xy) != 2
            or any(isinstance(c, bool) or not isinstance(c, (int, float)) for c in xy)):
        raise InputError(src, f"{field}.position", xy, "must be [x, y] in metres")
    best: tuple[float, MovementPath, float] | None = None
    for path in paths.values():
        if path.movement != movement or (exit_lane is not None and path.exit_lane != exit_lane):
            continue
        s, dist = path.project(float(xy[0]), float(xy[1]))
        # Prefer the movement's default exit lane among equally near paths (shared approach lane).
        rank = dist + (0.0 if path.exit_lane == default_exit_lane(path.lane, movement) else 1e-6)
        if best is None or rank < best[0]:
            best = (rank, path, s)
    if best is None or best[0] > PLACEMENT_TOLERANCE:
        raise InputError(src, f"{field}.position", xy,
                         f"more than {PLACEMENT_TOLERANCE:g} m from every lane and path of a {movement} movement")
    return best[1], best[2], best[0]


def _vehicle(src: str, i: int, table: Any, paths: dict[str, MovementPath]) -> VehicleSpec:
    field = f"vehicle[{i}]"
    if not isinstance(table, dict):
        raise InputError(src, field, table, "must be a table ([[vehicle]])")
    _unknown_keys(src, field, table, VEHICLE_KEYS)
    vid = table.get("id")
    if not isinstance(vid, str) or not vid or any(ch.isspace() for ch in vid):
        raise InputError(src, f"{field}.id", vid, "must be a non-empty string without spaces")
    field = f"vehicle[{vid}]"
    for key in ("movement", "speed", "kappa"):
        if key not in table:
            raise InputError(src, f"{field}.{key}", None, "is required")
    movement = _choice(src, f"{field}.movement", table["movement"], MOVEMENTS)
    speed = _number(src, f"{field}.speed", table["speed"], minimum=0.0)
    kappa = _number(src, f"{field}.kappa", table["kappa"], minimum=0.0, maximum=1.0)
    depart = _number(src, f"{field}.depart", table.get("depart", 0.0), minimum=0.0)
    desired = table.get("desired_speed")
    if desired is not None:
        desired = _number(src, f"{field}.desired_speed", desired, minimum=0.0)
        if desired <= 0.0:
            raise InputError(src, f"{field}.desired_speed", desired, "must be > 0")
        if speed > desired:
            raise InputError(src, f"{field}.speed", speed, f"must not exceed desired_speed ({desired:g} m/s)")
    exit_lane = table.get("exit_lane")
    if exit_lane is not None:
        _choice(src, f"{field}.exit_lane", exit_lane, LANES)

    if "position" in table:
        for key in ("approach", "lane", "distance"):
            if key in table:
                raise InputError(src, f"{field}.{key}", table[key], "give either position or approach/lane/distance, not both")
        path, s0, _ = _place_by_position(src, field, table["position"], movement, exit_lane, paths)
    else:
        for key in ("approach", "lane", "distance"):
            if key not in table:
                raise InputError(src, f"{field}.{key}", None, "is required when position is not given")
        approach = _choice(src, f"{field}.approach", table["approach"], ARMS)
        lane = _choice(src, f"{field}.lane", table["lane"], LANES)
        if movement not in LANE_USE[lane]:
            raise InputError(src, f"{field}.movement", movement,
                             f"the {lane} lane cannot turn {movement} (it allows {', '.join(LANE_USE[lane])})")
        chosen_exit = exit_lane or default_exit_lane(lane, movement)
        pid = str(PathId(approach, lane, movement, chosen_exit))
        if pid not in paths:
            raise InputError(src, f"{field}.exit_lane", exit_lane,
                             f"a {movement} turn from the {lane} lane can exit on {', '.join(LANE_USE[lane][movement])}")
        path = paths[pid]
        distance = _number(src, f"{field}.distance", table["distance"], maximum=path.s_stop)
        s0 = path.s_stop - distance
        if s0 > path.s_exit:
            raise InputError(src, f"{field}.distance", distance, "places the vehicle beyond the junction")
    if exit_lane is not None and path.exit_lane != exit_lane:
        raise InputError(src, f"{field}.exit_lane", exit_lane, f"cannot be reached from the {path.lane} lane")
    s0 = float(min(max(s0, 0.0), path.s_exit - 0.5))
    x, y = path.point_at(s0)
    return VehicleSpec(id=vid, approach=path.approach, lane=path.lane, movement=movement,
                       path_id=path.id, s0=s0, x=float(x), y=float(y), speed=speed, kappa=kappa,
                       depart=depart, exit_lane=exit_lane, in_junction=bool(s0 > path.s_stop),
                       desired_speed=desired)


def _kappa_distribution(src: str, field: str, value: Any) -> KappaDistribution:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return KappaDistribution(dist="fixed", value=_number(src, field, value, minimum=0.0, maximum=1.0))
    if not isinstance(value, dict):
        raise InputError(src, field, value, 'must be a number in [0, 1] or a table like {dist = "uniform", low = 0.2, high = 0.8}')
    dist = _choice(src, f"{field}.dist", value.get("dist"), ("fixed", "uniform", "normal"))
    known = {"fixed": ("dist", "value"), "uniform": ("dist", "low", "high"), "normal": ("dist", "mean", "std")}[dist]
    _unknown_keys(src, field, value, known)
    nums = {k: _number(src, f"{field}.{k}", v, minimum=0.0, maximum=1.0 if k != "std" else None)
            for k, v in value.items() if k != "dist"}
    if dist == "uniform" and not nums.get("low", 0.0) <= nums.get("high", 1.0):
        raise InputError(src, f"{field}.high", nums.get("high"), "must be >= low")
    return KappaDistribution(dist=dist, **nums)


def _flow(src: str, i: int, table: Any) -> FlowSpec:
    field = f"flow[{i}]"
    if not isinstance(table, dict):
        raise InputError(src, field, table, "must be a table ([[flow]])")
    _unknown_keys(src, field, table, FLOW_KEYS)
    for key in ("approach", "movement", "rate", "kappa"):
        if key not in table:
            raise InputError(src, f"{field}.{key}", None, "is required")
    approach = _choice(src, f"{field}.approach", table["approach"], ARMS)
    movement = _choice(src, f"{field}.movement", table["movement"], MOVEMENTS)
    fid = table.get("id", f"{approach}_{movement}_{i}")
    if not isinstance(fid, str) or not fid or any(ch.isspace() for ch in fid):
        raise InputError(src, f"{field}.id", fid, "must be a non-empty string without spaces")
    lane = table.get("lane")
    if lane is not None:
        _choice(src, f"{field}.lane", lane, LANES)
        if movement not in LANE_USE[lane]:
            raise InputError(src, f"{field}.movement", movement, f"the {lane} lane cannot turn {movement}")
    begin = _number(src, f"{field}.begin", table.get("begin", 0.0), minimum=0.0)
    end = _number(src, f"{field}.end", table.get("end", 3600.0), minimum=0.0)
    if end <= begin:
        raise InputError(src, f"{field}.end", end, "must be > begin")
    distance = table.get("distance")
    return FlowSpec(
        id=fid, approach=approach, movement=movement,
        rate=_number(src, f"{field}.rate", table["rate"], minimum=0.0),
        kappa=_kappa_distribution(src, f"{field}.kappa", table["kappa"]),
        begin=begin, end=end, lane=lane,
        speed=_number(src, f"{field}.speed", table.get("speed", 10.0), minimum=0.0),
        distance=None if distance is None else _number(src, f"{field}.distance", distance, minimum=0.0))


def _check_spacing(src: str, vehicles: list[VehicleSpec], paths: dict[str, MovementPath],
                   min_gap: float) -> None:
    """Two vehicles placed at the same time closer than a vehicle length on one lane: an error."""
    placed: dict[tuple[float, str], list[tuple[float, str]]] = {}
    for v in vehicles:
        lane, pos = paths[v.path_id].lane_at(v.s0)
        for other_pos, other in placed.get((v.depart, lane), []):
            if abs(other_pos - pos) < min_gap:
                raise InputError(src, f"vehicle[{v.id}].position", [round(v.x, 2), round(v.y, 2)],
                                 f"within {min_gap:g} m of {other} on lane {lane}")
        placed.setdefault((v.depart, lane), []).append((pos, v.id))


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file."""
    src = str(path)
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise InputError(src, "file", src, "no such file") from None
    except IsADirectoryError:
        raise InputError(src, "file", src, "is a directory, not a scenario file") from None
    except PermissionError:
        raise InputError(src, "file", src, "cannot be read (permission denied)") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(src, "toml", str(exc), "malformed TOML") from None
    except UnicodeDecodeError:
        raise InputError(src, "file", src, "is not UTF-8 text") from None
    return scenario_from_dict(data, src)


def scenario_from_dict(data: dict[str, Any], src: str = "<scenario>") -> Scenario:
    """Validate an already-parsed scenario (``src`` names it in messages)."""
    for key in data:
        if key not in TOP_LEVEL:
            raise InputError(src, key, data[key], f"unknown table (known: {', '.join(TOP_LEVEL)})")
    for key in ("scenario", "controller", "model"):
        if key in data and not isinstance(data[key], dict):
            raise InputError(src, key, data[key], "must be a table")
    scen = from_table(ScenarioSettings, data.get("scenario"), src, "scenario")
    ctrl_table = dict(data.get("controller", {}))
    tables = {name: ctrl_table.pop(name) for name in CONTROLLER_TABLES if name in ctrl_table}
    for name, table in tables.items():
        if not isinstance(table, dict):
            raise InputError(src, f"controller.{name}", table, "must be a table")
    ctrl = from_table(ControllerSettings, ctrl_table, src, "controller")
    if ctrl.kind not in registry.names():
        raise InputError(src, "controller.kind", ctrl.kind, f"must be one of {', '.join(registry.names())}")
    settings = registry.validate_tables(ctrl.kind, tables, src)
    model = from_table(ModelSettings, data.get("model"), src, "model")

    paths = load_paths(cached_net(IntersectionSpec(junction_type=scen.junction_type)))
    raw_vehicles = data.get("vehicle", [])
    if not isinstance(raw_vehicles, list):
        raise InputError(src, "vehicle", raw_vehicles, "must be an array of tables ([[vehicle]])")
    vehicles = [_vehicle(src, i, t, paths) for i, t in enumerate(raw_vehicles)]
    seen: set[str] = set()
    for v in vehicles:
        if v.id in seen:
            raise InputError(src, "vehicle.id", v.id, "duplicate id")
        seen.add(v.id)
    _check_spacing(src, vehicles, paths, model.vehicle_length)
    raw_flows = data.get("flow", [])
    if not isinstance(raw_flows, list):
        raise InputError(src, "flow", raw_flows, "must be an array of tables ([[flow]])")
    flows = [_flow(src, i, t) for i, t in enumerate(raw_flows)]
    fids: set[str] = set()
    for f in flows:
        if f.id in fids or f.id in seen:
            raise InputError(src, "flow.id", f.id, "duplicate id")
        fids.add(f.id)
    if not vehicles and not flows:
        raise InputError(src, "vehicle", [], "a scenario needs at least one [[vehicle]] or [[flow]]")
    return Scenario(source=src, scenario=scen, controller=ctrl, model=model, controller_settings=settings,
                    controller_tables=tables, vehicles=tuple(vehicles), flows=tuple(flows))


def with_overrides(scn: Scenario, *, controller: str | None = None, seed: int | None = None,
                   **controller_fields: Any) -> Scenario:
    """A copy with command-line overrides applied (validated like the file)."""
    ctrl = scn.controller
    if controller is not None:
        if controller not in registry.names():
            raise InputError("--controller", "controller", controller, f"must be one of {', '.join(registry.names())}")
        ctrl = dataclasses.replace(ctrl, kind=controller)
        scn = dataclasses.replace(scn, controller_settings=registry.validate_tables(controller, scn.controller_tables,
                                                                                     scn.source))
    fields = {k: v for k, v in controller_fields.items() if v is not None}
    if fields:
        ctrl = dataclasses.replace(ctrl, **fields)
        for name, problem in ctrl.check():
            raise InputError(f"--{name.replace('_', '-')}", name, getattr(ctrl, name), problem)
    scen = scn.scenario
    if seed is not None:
        if seed < 0:
            raise InputError("--seed", "seed", seed, "must be >= 0")
        scen = dataclasses.replace(scen, seed=seed)
    return dataclasses.replace(scn, controller=ctrl, scenario=scen)


def generate_flow_vehicles(scn: Scenario, rng: np.random.Generator) -> list[dict]:
    """Poisson arrivals of every flow, drawn with ``rng`` (seeded from the scenario's seed).

    Returns one dict per vehicle: id, approach, lane, movement, depart [s], kappa, speed [m/s],
    distance [m] to the stop line (None = start of the arm).
    """
    out: list[dict] = []
    for flow in scn.flows:
        if flow.rate <= 0:
            continue
        mean_headway = 3600.0 / flow.rate  # [s]
        t = flow.begin + rng.exponential(mean_headway)
        k = 0
        lanes = [flow.lane] if flow.lane else [ln for ln in LANES if flow.movement in LANE_USE[ln]]
        while t < min(flow.end, scn.scenario.duration):
            kd = flow.kappa
            if kd.dist == "uniform":
                kappa = rng.uniform(kd.low, kd.high)
            elif kd.dist == "normal":
                kappa = rng.normal(kd.mean, kd.std)
            else:
                kappa = kd.value
            out.append({"id": f"{flow.id}.{k}", "approach": flow.approach, "movement": flow.movement,
                        "lane": lanes[int(rng.integers(len(lanes)))], "depart": round(float(t), 2),
                        "kappa": float(np.clip(kappa, 0.0, 1.0)), "speed": flow.speed,
                        "distance": flow.distance})
            k += 1
            t += rng.exponential(mean_headway)
    out.sort(key=lambda d: (d["depart"], d["id"]))
    return out
