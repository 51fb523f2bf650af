"""A user's own SUMO config (``[network] sumocfg``) and the demand window of a route file.

:func:`read_sumocfg` reads the net, route files, additional files, begin and end of a ``.sumocfg``
with sumolib (paths relative to the config's folder, as SUMO resolves them); :func:`route_departs`
lists the depart times of a route file's demand, so that a window in which nothing departs is
refused at load time. Nothing is written anywhere.
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from typing import Any

import sumolib
from sumolib.options import readOptions

from intersection_cosim.errors import InputError
from intersection_cosim.network.xml_files import xml_root

DEMAND_TAGS = ("vehicle", "trip", "flow", "person", "personFlow", "container", "containerFlow")
VEHICLE_TAGS = ("vehicle", "trip", "flow")  # the demand elements that are vehicles


@dataclass(frozen=True)
class SumoConfig:
    """What a ``.sumocfg`` says about the inputs and clock of a run; paths absolute."""

    path: str  # [-] the config file
    net: str | None = None  # [-] its net-file
    routes: tuple[str, ...] = ()  # [-] its route-files, in order
    additional: tuple[str, ...] = ()  # [-] its additional-files, in order
    begin: float | None = None  # [s] its begin (None: not given)
    end: float | None = None  # [s] its end (None: not given)


def _files(value: str, folder: str) -> tuple[str, ...]:
    """A SUMO file list option (comma or space separated), each made absolute against ``folder``."""
    names = [n for n in value.replace(",", " ").split() if n]
    return tuple(os.path.normpath(os.path.join(folder, n)) for n in names)


def read_sumocfg(src: str, value: Any, path: str) -> SumoConfig:
    """The inputs and times of the SUMO config ``path`` (``value`` as the scenario gave it, for
    messages); an InputError if it is missing or not a SUMO configuration."""
    field = "network.sumocfg"
    if not os.path.isfile(path):
        raise InputError(src, field, value, f"no such file ({path})")
    try:
        root = xml_root(path)
        options = {opt.name: opt.value for opt in readOptions(path)}
    except Exception as exc:  # expat / sax parse errors
        raise InputError(src, field, value, f"is not a SUMO configuration ({type(exc).__name__}: {exc})") from None
    if root.tag != "configuration":
        raise InputError(src, field, value, f"is not a SUMO configuration (its root is <{root.tag}>)")
    folder = os.path.dirname(os.path.abspath(path))
    times = {}
    for key in ("begin", "end"):
        if key in options:
            try:
                times[key] = float(sumolib.miscutils.parseTime(options[key]))
            except ValueError:
                raise InputError(src, f"{field} <{key}>", options[key], "is not a time [s]") from None
    nets = _files(options.get("net-file", ""), folder)
    return SumoConfig(path=path, net=nets[0] if nets else None,
                      routes=_files(options.get("route-files", ""), folder),
                      additional=_files(options.get("additional-files", ""), folder),
                      begin=times.get("begin"), end=times.get("end"))


def route_departs(path: str, tags: tuple[str, ...] = DEMAND_TAGS) -> tuple[float, ...]:
    """[s] the depart time of each top-level demand element of a route file whose tag is among
    ``tags`` (a flow's begin), sorted; elements without a numeric depart ("triggered") are left out."""
    st = os.stat(path)
    return _route_departs(path, st.st_mtime_ns, st.st_size, tags)


@functools.lru_cache(maxsize=16)
def _route_departs(path: str, mtime_ns: int, size: int, tags: tuple[str, ...]) -> tuple[float, ...]:
    out = []
    for el in xml_root(path):
        if el.tag in tags:
            text = el.get("begin", "0") if el.tag.endswith("Flow") or el.tag == "flow" else el.get("depart")
            try:
                out.append(float(sumolib.miscutils.parseTime(text)))
            except (TypeError, ValueError):
                continue
    return tuple(sorted(out))


def in_window(depart: float, begin: float, end: float) -> bool:
    """Whether ``depart`` [s] lies in the demand window [``begin``, ``end``) [s]."""
    return begin - 1e-9 <= depart < end - 1e-9


def check_window(src: str, routes: str, begin: float, duration: float) -> int:
    """How many of the route file's vehicles depart in [begin, begin + duration) [s]; an
    InputError naming the file, the window and its first depart time if it has demand and none
    of it departs in the window (a file of vTypes only is no demand)."""
    departs = route_departs(routes)
    n = sum(in_window(t, begin, begin + duration) for t in departs)
    if n == 0 and departs:
        raise InputError(src, "scenario.begin", begin,
                         f"no vehicle of {routes} departs in the window [{begin:g}, {begin + duration:g}) s "
                         f"(scenario.begin + duration); its first vehicle departs at {departs[0]:g} s")
    return n

