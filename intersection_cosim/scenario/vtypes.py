"""``[[vtype]]`` tables and the vTypes of a user's route file -> :class:`VehicleType` values, and
how a ``[[vehicle]]`` or ``[[flow]]`` table refers to one (``vtype = "bus"``).

How a vehicle type and a driver combine:

* a vtype with ``driver = "human"`` makes every vehicle of it human: a vehicle of it may not say
  ``driver = "av"``, a flow of it may not give ``av_share`` (its share is 0);
* a vtype with ``driver = "av"`` (the default) is a body and its limits; a flow of it draws
  humans with its ``av_share`` as any flow does, and a vehicle of it may say ``driver = "human"``:
  such a human has the vtype's body and limits, driven by the ``[human]`` table's model;
* a vtype's ``kappa`` is the kappa of its vehicles and flows that give none.

Nothing is written anywhere.
"""

from __future__ import annotations

from typing import Any

from intersection_cosim.errors import InputError
from intersection_cosim.network.xml_files import xml_root
from intersection_cosim.scenario.model import VehicleType
from intersection_cosim.settings import from_table

RESERVED = ("av", "human")  # [-] the run's own default vType ids
TOML_KEYS = ("id", "length", "width", "accel", "decel", "max_speed", "kappa", "driver", "color", "min_gap")
# SUMO's defaults of a vType (vClass passenger) for attributes a route file's vType leaves out
SUMO_DEFAULTS = {"length": 5.0, "width": 1.8, "accel": 2.6, "decel": 4.5}


def vtypes_of(src: str, raw: Any, route_types: tuple[VehicleType, ...] = ()) -> tuple[VehicleType, ...]:
    """The ``[[vtype]]`` tables of a scenario (``raw``: the parsed array), then ``route_types``
    (the vTypes of its ``[network] routes`` file)."""
    if raw is None:
        return tuple(route_types)
    if not isinstance(raw, list):
        raise InputError(src, "vtype", raw, "must be an array of tables ([[vtype]])")
    out: list[VehicleType] = []
    for i, table in enumerate(raw):
        if not isinstance(table, dict):
            raise InputError(src, f"vtype[{i}]", table, "must be a table ([[vtype]])")
        vid = table.get("id")
        if not isinstance(vid, str) or not vid or any(ch.isspace() for ch in vid) or "." in vid:
            raise InputError(src, f"vtype[{i}].id", vid, "must be a non-empty string without spaces or dots")
        if vid in RESERVED:
            raise InputError(src, f"vtype[{i}].id", vid, f"is reserved ({', '.join(RESERVED)} are the run's own vTypes)")
        if any(t.id == vid for t in (*out, *route_types)):
            raise InputError(src, f"vtype[{i}].id", vid, "duplicate id (of a [[vtype]] or a vType of [network] routes)")
        for key in table:
            if key not in TOML_KEYS:
                raise InputError(src, f"vtype[{vid}].{key}", table[key], f"unknown key (known: {', '.join(TOML_KEYS)})")
        out.append(from_table(VehicleType, table, src, f"vtype[{vid}]"))
    return tuple(out) + tuple(route_types)


def route_file_vtypes(path: str) -> tuple[VehicleType, ...]:
    """The top-level vTypes of a SUMO route file as :class:`VehicleType` (length, width, accel,
    decel, maxSpeed; SUMO's passenger defaults where it gives none), drivers "av"."""
    out = []
    for el in xml_root(path):
        if el.tag != "vType" or el.get("id") in RESERVED:
            continue
        nums = {k: float(el.get(k, v)) for k, v in SUMO_DEFAULTS.items()}
        speed = el.get("maxSpeed")
        out.append(VehicleType(id=el.get("id"), max_speed=float(speed) if speed is not None else None,
                               from_routes=True, **nums))
    return tuple(out)


def referenced(src: str, field: str, table: dict, vtypes: tuple[VehicleType, ...]) -> VehicleType | None:
    """The vtype a vehicle or flow ``table`` names with ``vtype`` (None when it names none)."""
    if "vtype" not in table:
        return None
    name = table["vtype"]
    for vt in vtypes:
        if vt.id == name:
            return vt
    known = ", ".join(vt.id for vt in vtypes) or "none defined"
    raise InputError(src, f"{field}.vtype", name, f"is not a [[vtype]] id (known: {known})")


def with_vtype_defaults(src: str, field: str, table: dict, vt: VehicleType | None, flow: bool) -> dict:
    """``table`` without its ``vtype`` key, with the vtype's kappa and driver filled in where it
    gives none (see the module docstring for how they combine)."""
    out = {k: v for k, v in table.items() if k != "vtype"}
    if vt is None:
        return out
    if "kappa" not in out and vt.kappa is not None:
        out["kappa"] = vt.kappa
    if vt.driver == "human":
        if flow and "av_share" in out:
            raise InputError(src, f"{field}.av_share", out["av_share"],
                             f"does not apply: vtype {vt.id!r} has driver human (all its vehicles are human)")
        if not flow and out.get("driver", "human") != "human":
            raise InputError(src, f"{field}.driver", out["driver"],
                             f"contradicts vtype {vt.id!r}, whose driver is human")
        if flow:
            out["av_share"] = 0.0
        else:
            out["driver"] = "human"
    return out


def sumo_type(vt: VehicleType | None, driver: str) -> str:
    """The SUMO vType id of a vehicle of vtype ``vt`` (None: the default) driven by ``driver``."""
    if vt is None:
        return driver
    if vt.from_routes or vt.driver == driver:
        return vt.id
    return f"{vt.id}.human"
