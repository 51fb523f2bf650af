"""``[[flow]]`` tables -> :class:`FlowSpec`: on the generated paper net by approach and movement
(or by its entry and exit edges), on a ``[network] file`` net through scenario/demand.py; with
each flow's kappa distribution, time window and share of AVs."""

from __future__ import annotations

import dataclasses
from typing import Any

from intersection_cosim.errors import InputError
from intersection_cosim.network.spec import ARMS, LANE_USE, LANES, MOVEMENTS, exit_arm
from intersection_cosim.scenario.demand import generic_flow
from intersection_cosim.scenario.model import FlowSpec, KappaDistribution
from intersection_cosim.scenario.values import choice, number, unknown_keys

FLOW_KEYS = ("id", "approach", "movement", "from", "to", "route", "rate", "kappa", "begin", "end", "lane", "speed",
             "distance", "av_share", "vtype")


def av_share_of(src: str, field: str, table: dict) -> float:
    """A flow table's ``av_share`` [-] in [0, 1] (default 1: every vehicle an AV)."""
    return number(src, f"{field}.av_share", table.get("av_share", 1.0), minimum=0.0, maximum=1.0)


def _kappa_distribution(src: str, field: str, value: Any) -> KappaDistribution:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return KappaDistribution(dist="fixed", value=number(src, field, value, minimum=0.0, maximum=1.0))
    if not isinstance(value, dict):
        raise InputError(src, field, value, 'must be a number in [0, 1] or a table like {dist = "uniform", low = 0.2, high = 0.8}')
    dist = choice(src, f"{field}.dist", value.get("dist"), ("fixed", "uniform", "normal"))
    known = {"fixed": ("dist", "value"), "uniform": ("dist", "low", "high"), "normal": ("dist", "mean", "std")}[dist]
    unknown_keys(src, field, value, known)
    nums = {k: number(src, f"{field}.{k}", v, minimum=0.0, maximum=1.0 if k != "std" else None)
            for k, v in value.items() if k != "dist"}
    if dist == "uniform" and not nums.get("low", 0.0) <= nums.get("high", 1.0):
        raise InputError(src, f"{field}.high", nums.get("high"), "must be >= low")
    return KappaDistribution(dist=dist, **nums)


def _paper_movement(src: str, field: str, table: dict) -> tuple[str, str]:
    """(approach, movement) of a flow on the generated net given by edges: ``from`` / ``to`` or a
    two-edge ``route``, like "south_in" -> "west_out"."""
    for key in ("approach", "movement"):
        if key in table:
            raise InputError(src, f"{field}.{key}", table[key], "give either approach/movement or from/to/route")
    if "route" in table:
        route = table["route"]
        if not isinstance(route, list) or len(route) != 2:
            raise InputError(src, f"{field}.route", route, 'must be two edges on the generated net, like '
                             '["south_in", "west_out"]')
        start, end, start_field, end_field = route[0], route[1], f"{field}.route[0]", f"{field}.route[1]"
    else:
        for key in ("from", "to"):
            if key not in table:
                raise InputError(src, f"{field}.{key}", None, "is required (or approach/movement)")
        start, end, start_field, end_field = table["from"], table["to"], f"{field}.from", f"{field}.to"
    entries, exits = [f"{arm}_in" for arm in ARMS], [f"{arm}_out" for arm in ARMS]
    if start not in entries:
        raise InputError(src, start_field, start, f"is not an entry edge of the generated net ({', '.join(entries)})")
    if end not in exits:
        raise InputError(src, end_field, end, f"is not an exit edge of the generated net ({', '.join(exits)})")
    approach = start[:-len("_in")]
    for movement in MOVEMENTS:
        if exit_arm(approach, movement) == end[:-len("_out")]:
            return approach, movement
    raise InputError(src, end_field, end, f"no route from {start!r} (the generated net has no U-turns)")


def _flow_window(src: str, field: str, table: dict) -> tuple[float, float]:
    """A flow's (begin, end) [s]."""
    begin = number(src, f"{field}.begin", table.get("begin", 0.0), minimum=0.0)
    end = number(src, f"{field}.end", table.get("end", 3600.0), minimum=0.0)
    if end <= begin:
        raise InputError(src, f"{field}.end", end, "must be > begin")
    return begin, end


def any_flow(src: str, i: int, table: Any, net) -> FlowSpec:
    """A ``[[flow]]`` table: on the generated net (``net`` None) or on a ``[network] file`` net."""
    if net is None or not isinstance(table, dict):
        return _flow(src, i, table)
    field = f"flow[{i}]"
    if "kappa" not in table:
        raise InputError(src, f"{field}.kappa", None, "is required")
    kappa = _kappa_distribution(src, f"{field}.kappa", table["kappa"])
    spec = generic_flow(src, i, table, net, kappa, _flow_window(src, field, table))
    return dataclasses.replace(spec, av_share=av_share_of(src, field, table))


def _flow(src: str, i: int, table: Any) -> FlowSpec:
    field = f"flow[{i}]"
    if not isinstance(table, dict):
        raise InputError(src, field, table, "must be a table ([[flow]])")
    unknown_keys(src, field, table, FLOW_KEYS)
    by_edges = any(key in table for key in ("from", "to", "route"))
    for key in ("rate", "kappa") if by_edges else ("approach", "movement", "rate", "kappa"):
        if key not in table:
            raise InputError(src, f"{field}.{key}", None, "is required")
    if by_edges:
        approach, movement = _paper_movement(src, field, table)
    else:
        approach = choice(src, f"{field}.approach", table["approach"], ARMS)
        movement = choice(src, f"{field}.movement", table["movement"], MOVEMENTS)
    fid = table.get("id", f"{approach}_{movement}_{i}")
    if not isinstance(fid, str) or not fid or any(ch.isspace() for ch in fid):
        raise InputError(src, f"{field}.id", fid, "must be a non-empty string without spaces")
    lane = table.get("lane")
    if lane is not None:
        choice(src, f"{field}.lane", lane, LANES)
        if movement not in LANE_USE[lane]:
            raise InputError(src, f"{field}.movement", movement, f"the {lane} lane cannot turn {movement}")
    begin, end = _flow_window(src, field, table)
    distance = table.get("distance")
    return FlowSpec(
        id=fid, approach=approach, movement=movement,
        rate=number(src, f"{field}.rate", table["rate"], minimum=0.0),
        kappa=_kappa_distribution(src, f"{field}.kappa", table["kappa"]),
        begin=begin, end=end, lane=lane,
        speed=number(src, f"{field}.speed", table.get("speed", 10.0), minimum=0.0),
        distance=None if distance is None else number(src, f"{field}.distance", distance, minimum=0.0),
        av_share=av_share_of(src, field, table))
