"""Scenario files (TOML) -> a validated :class:`Scenario`.

Every problem is an :class:`InputError` naming the file, the field and the value; nothing is
written anywhere while loading (the net used for placement comes from the per-user cache).
"""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path
from typing import Any


from intersection_cosim.control import registry
from intersection_cosim.errors import InputError
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.cache import cached_net
from intersection_cosim.network.path_id import PathId
from intersection_cosim.network.paths import MovementPath, load_paths
from intersection_cosim.network.spec import ARMS, LANE_USE, LANES, MOVEMENTS, IntersectionSpec
from intersection_cosim.scenario.demand import check_generic_spacing, check_vehicle_keys, generic_vehicle
from intersection_cosim.scenario.flows import any_flow
from intersection_cosim.scenario.model import (
    DRIVERS,
    ControllerSettings,
    FlowSpec,
    HumanDriverSettings,
    NetworkSettings,
    Scenario,
    ScenarioSettings,
    VehicleSpec,
    VehicleType,
)
from intersection_cosim.scenario.stress_settings import stress_settings
from intersection_cosim.scenario.network import net_of, network_settings, route_file_ids
from intersection_cosim.scenario.sumocfg import check_window
from intersection_cosim.scenario.values import choice, number, unknown_keys
from intersection_cosim.scenario.vtypes import referenced, route_file_vtypes, vtypes_of, with_vtype_defaults
from intersection_cosim.settings import from_table
from intersection_cosim.v2x.settings import AttackSettings, V2XSettings

TOP_LEVEL = ("scenario", "controller", "model", "network", "human", "vtype", "vehicle", "flow", "v2x", "stress")
CONTROLLER_TABLES = ("game", "solver", "policy", "safety", "signals")  # [controller.<name>] sub-tables
VEHICLE_KEYS = ("id", "position", "approach", "lane", "distance", "movement", "exit_lane", "speed",
                "kappa", "depart", "desired_speed", "driver", "vtype")
PLACEMENT_TOLERANCE = 1.0  # [m] a position farther than this from every path of its movement is an error


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


def _vehicle_id(src: str, i: int, table: Any) -> str:
    if not isinstance(table, dict):
        raise InputError(src, f"vehicle[{i}]", table, "must be a table ([[vehicle]])")
    vid = table.get("id")
    if not isinstance(vid, str) or not vid or any(ch.isspace() for ch in vid):
        raise InputError(src, f"vehicle[{i}].id", vid, "must be a non-empty string without spaces")
    return vid


def _motion(src: str, field: str, table: dict) -> tuple[float, float, float, float | None]:
    """A vehicle's (speed [m/s], kappa [-], depart [s], desired_speed [m/s] or None)."""
    speed = number(src, f"{field}.speed", table["speed"], minimum=0.0)
    kappa = number(src, f"{field}.kappa", table["kappa"], minimum=0.0, maximum=1.0)
    depart = number(src, f"{field}.depart", table.get("depart", 0.0), minimum=0.0)
    desired = table.get("desired_speed")
    if desired is not None:
        desired = number(src, f"{field}.desired_speed", desired, minimum=0.0)
        if desired <= 0.0:
            raise InputError(src, f"{field}.desired_speed", desired, "must be > 0")
        if speed > desired:
            raise InputError(src, f"{field}.speed", speed, f"must not exceed desired_speed ({desired:g} m/s)")
    return speed, kappa, depart, desired


def driver_of(src: str, field: str, table: dict) -> str:
    """A vehicle table's ``driver``: "av" (default) or "human"."""
    return choice(src, f"{field}.driver", table.get("driver", "av"), DRIVERS)


def _any_vehicle(src: str, i: int, table: Any, paths: dict[str, MovementPath], net) -> VehicleSpec:
    """A ``[[vehicle]]`` table: on the generated net (``net`` None) or on a ``[network] file`` net."""
    if net is None:
        spec = _vehicle(src, i, table, paths)
        return dataclasses.replace(spec, driver=driver_of(src, f"vehicle[{spec.id}]", table))
    vid = _vehicle_id(src, i, table)
    check_vehicle_keys(src, f"vehicle[{i}]", table)
    field = f"vehicle[{vid}]"
    for key in ("speed", "kappa"):
        if key not in table:
            raise InputError(src, f"{field}.{key}", None, "is required")
    spec = generic_vehicle(src, field, vid, table, net, _motion(src, field, table))
    return dataclasses.replace(spec, driver=driver_of(src, field, table))


def _vehicle(src: str, i: int, table: Any, paths: dict[str, MovementPath]) -> VehicleSpec:
    if isinstance(table, dict):
        unknown_keys(src, f"vehicle[{i}]", table, VEHICLE_KEYS)
    vid = _vehicle_id(src, i, table)
    field = f"vehicle[{vid}]"
    for key in ("movement", "speed", "kappa"):
        if key not in table:
            raise InputError(src, f"{field}.{key}", None, "is required")
    movement = choice(src, f"{field}.movement", table["movement"], MOVEMENTS)
    speed, kappa, depart, desired = _motion(src, field, table)
    exit_lane = table.get("exit_lane")
    if exit_lane is not None:
        choice(src, f"{field}.exit_lane", exit_lane, LANES)

    if "position" in table:
        for key in ("approach", "lane", "distance"):
            if key in table:
                raise InputError(src, f"{field}.{key}", table[key], "give either position or approach/lane/distance, not both")
        path, s0, _ = _place_by_position(src, field, table["position"], movement, exit_lane, paths)
    else:
        for key in ("approach", "lane", "distance"):
            if key not in table:
                raise InputError(src, f"{field}.{key}", None, "is required when position is not given")
        approach = choice(src, f"{field}.approach", table["approach"], ARMS)
        lane = choice(src, f"{field}.lane", table["lane"], LANES)
        if movement not in LANE_USE[lane]:
            raise InputError(src, f"{field}.movement", movement,
                             f"the {lane} lane cannot turn {movement} (it allows {', '.join(LANE_USE[lane])})")
        chosen_exit = exit_lane or default_exit_lane(lane, movement)
        pid = str(PathId(approach, lane, movement, chosen_exit))
        if pid not in paths:
            raise InputError(src, f"{field}.exit_lane", exit_lane,
                             f"a {movement} turn from the {lane} lane can exit on {', '.join(LANE_USE[lane][movement])}")
        path = paths[pid]
        distance = number(src, f"{field}.distance", table["distance"], maximum=path.s_stop)
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
    except OSError as exc:  # a name too long, an unreadable device, ...
        raise InputError(src, "file", src, f"cannot be read ({exc.strerror or exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(src, "toml", str(exc), "malformed TOML") from None
    except UnicodeDecodeError:
        raise InputError(src, "file", src, "is not UTF-8 text") from None
    return scenario_from_dict(data, src)


def scenario_from_dict(data: dict[str, Any], src: str = "<scenario>", base: Path | None = None) -> Scenario:
    """Validate an already-parsed scenario (``src`` names it in messages; relative paths of its
    ``[network]`` table start at ``base``, default the folder of ``src``)."""
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
    if "human" in data and not isinstance(data["human"], dict):
        raise InputError(src, "human", data["human"], "must be a table")
    human = from_table(HumanDriverSettings, data.get("human"), src, "human")
    network = network_settings(src, data.get("network"), Path(src).parent if base is None else Path(base))
    scen = _clock(src, scen, data.get("scenario") or {}, network)
    route_types = tuple(vt for path in network.routes for vt in route_file_vtypes(path))
    vtypes = vtypes_of(src, data.get("vtype"), route_types)
    vehicles, flows = _demand(src, data, scen, model, network, vtypes)
    v2x = _v2x(src, data.get("v2x"), vehicles, flows, network)
    if network.routes and not scen.keep_all_demand:
        check_window(src, network.routes, scen.begin, scen.duration)
    stress_settings(src, data.get("stress"))  # read only by ``stress``; checked here so a typo is an error
    return Scenario(source=src, scenario=scen, controller=ctrl, model=model, controller_settings=settings,
                    controller_tables=tables, vehicles=tuple(vehicles), flows=tuple(flows), network=network,
                    v2x=v2x, human=human, vtypes=vtypes)


def _clock(src: str, scen: ScenarioSettings, table: dict, network: NetworkSettings) -> ScenarioSettings:
    """``scen`` with ``begin`` [s] resolved (the table's, else the sumocfg's, else 0) and, when the
    table gives no ``duration``, the sumocfg's end - begin [s] as the demand window."""
    begin = scen.begin if scen.begin is not None else (network.sumocfg_begin or 0.0)
    duration = scen.duration
    if "duration" not in table and network.sumocfg_end is not None:
        duration = network.sumocfg_end - begin
        if duration <= 0:
            raise InputError(src, "scenario.begin", begin,
                             f"is not before the end of {network.sumocfg} ({network.sumocfg_end:g} s); "
                             "give scenario.duration")
    return dataclasses.replace(scen, begin=float(begin), duration=float(duration))


def _v2x(src: str, table: Any, vehicles: list[VehicleSpec], flows: list[FlowSpec],
         network: NetworkSettings) -> V2XSettings:
    """The ``[v2x]`` table and its ``[[v2x.attack]]`` entries; an attacked vehicle must be one of
    the scenario's: a [[vehicle]], a flow's ``<flow id>.<k>`` or a vehicle of its route file."""
    if table is None:
        return V2XSettings()
    if not isinstance(table, dict):
        raise InputError(src, "v2x", table, "must be a table")
    table = dict(table)
    raw = table.pop("attack", [])
    if not isinstance(raw, list):
        raise InputError(src, "v2x.attack", raw, "must be an array of tables ([[v2x.attack]])")
    attacks = []
    for i, entry in enumerate(raw):
        if not isinstance(entry, dict):
            raise InputError(src, f"v2x.attack[{i}]", entry, "must be a table ([[v2x.attack]])")
        attacks.append(from_table(AttackSettings, entry, src, f"v2x.attack[{i}]"))
    settings = from_table(V2XSettings, table, src, "v2x")
    ids = {v.id for v in vehicles}
    for path in network.routes:
        ids |= route_file_ids(path)[1]
    flow_ids = {f.id for f in flows}
    for i, attack in enumerate(attacks):
        head, _, k = attack.vehicle.rpartition(".")
        if attack.vehicle not in ids and not (head in flow_ids and k.isdigit()):
            raise InputError(src, f"v2x.attack[{i}].vehicle", attack.vehicle,
                             "is not a vehicle of the scenario (a [[vehicle]] id or <flow id>.<k>)")
    return dataclasses.replace(settings, attack=tuple(attacks))


def _typed(src: str, field: str, table: Any, vtypes: tuple[VehicleType, ...], flow: bool,
           parse) -> VehicleSpec | FlowSpec:
    """``parse(table)`` of a vehicle or flow table naming a ``vtype``: its kappa and driver
    defaults filled in (scenario/vtypes.py), the spec carrying the vtype's id."""
    if not isinstance(table, dict) or "vtype" not in table:
        return parse(table)
    vt = referenced(src, field, table, vtypes)
    return dataclasses.replace(parse(with_vtype_defaults(src, field, table, vt, flow)), vtype=vt.id)


def _demand(src: str, data: dict[str, Any], scen: ScenarioSettings, model: ModelSettings,
            network: NetworkSettings, vtypes: tuple[VehicleType, ...] = ()) -> tuple[list[VehicleSpec], list[FlowSpec]]:
    """The scenario's [[vehicle]] and [[flow]] tables, validated on its net."""
    net = net_of(network)
    paths = load_paths(cached_net(IntersectionSpec(junction_type=scen.junction_type))) if net is None else {}
    raw_vehicles = data.get("vehicle", [])
    if not isinstance(raw_vehicles, list):
        raise InputError(src, "vehicle", raw_vehicles, "must be an array of tables ([[vehicle]])")
    vehicles = [_typed(src, f"vehicle[{i}]", t, vtypes, False, lambda t, i=i: _any_vehicle(src, i, t, paths, net))
                for i, t in enumerate(raw_vehicles)]
    seen: set[str] = set()
    for v in vehicles:
        if v.id in seen:
            raise InputError(src, "vehicle.id", v.id, "duplicate id")
        seen.add(v.id)
    longest = max([model.vehicle_length] + [vt.length for vt in vtypes if vt.length is not None])  # [m]
    if net is None:
        _check_spacing(src, vehicles, paths, longest)
    else:
        check_generic_spacing(src, vehicles, longest)
    raw_flows = data.get("flow", [])
    if not isinstance(raw_flows, list):
        raise InputError(src, "flow", raw_flows, "must be an array of tables ([[flow]])")
    flows = [_typed(src, f"flow[{i}]", t, vtypes, True, lambda t, i=i: any_flow(src, i, t, net))
             for i, t in enumerate(raw_flows)]
    fids: set[str] = set()
    for f in flows:
        if f.id in fids or f.id in seen:
            raise InputError(src, "flow.id", f.id, "duplicate id")
        fids.add(f.id)
    if network.routes:
        for path in network.routes:
            _check_route_file_ids(src, path, seen | fids)
    elif not vehicles and not flows:
        raise InputError(src, "vehicle", [], "a scenario needs at least one [[vehicle]] or [[flow]]")
    return vehicles, flows


def _check_route_file_ids(src: str, routes: str, ours: set[str]) -> None:
    """The user's route file must not redefine the run's vType ``av`` or reuse the scenario's ids."""
    types, demand = route_file_ids(routes)
    for own in ("av", "human"):
        if own in types:
            raise InputError(src, "network.routes", routes, f"defines vType {own!r}, a type of the scenario's own vehicles")
    for vid in sorted(demand & ours):
        raise InputError(src, "network.routes", routes, f"reuses the id {vid!r} of a [[vehicle]] or [[flow]]")


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
