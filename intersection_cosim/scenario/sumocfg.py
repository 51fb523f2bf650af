"""A user's own SUMO config (``[network] sumocfg``) and the demand window of a route file.

:func:`read_sumocfg` reads the net, route files, additional files, begin and end of a ``.sumocfg``
with sumolib (paths relative to the config's folder, as SUMO resolves them); :func:`route_demand`
lists the departures of a route file's demand (a flow's by its interval), so that a window in
which nothing departs is refused at load time and the run's counts are those of its vehicles. Nothing is written anywhere.
"""

from __future__ import annotations

import functools
import math
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
    loading: tuple[tuple[str, str], ...] = ()  # [-] its options of LOADING_OPTIONS, as (name, value)


def _files(value: str, folder: str) -> tuple[str, ...]:
    """A SUMO file list option (comma or space separated), each made absolute against ``folder``."""
    names = [n for n in value.replace(",", " ").split() if n]
    return tuple(os.path.normpath(os.path.join(folder, n)) for n in names)


CONFIG_ROOTS = ("configuration", "sumoConfiguration")  # hand-written configs, and those SUMO saves itself
# how SUMO reads the inputs: a run loads them as the user's config does (real scenarios' files
# may carry attributes newer schemas no longer declare, and their configs switch validation off)
LOADING_OPTIONS = ("xml-validation", "xml-validation.net", "xml-validation.routes")


ROUTE_FILE_TAGS = DEMAND_TAGS + ("vType", "vTypeDistribution", "route", "routeDistribution")


def _is_demand(path: str) -> bool:
    """Whether an additional file is a route file in all but name: it holds demand and nothing a
    route file cannot (SUMO's own demo configs list their routes as additional files)."""
    try:
        tags = {el.tag for el in xml_root(path)}
    except Exception:  # unreadable: SUMO will say so when it loads it
        return False
    return bool(tags & set(DEMAND_TAGS)) and tags <= set(ROUTE_FILE_TAGS)


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
    if root.tag not in CONFIG_ROOTS:
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
    additional = _files(options.get("additional-files", ""), folder)
    demand = tuple(f for f in additional if _is_demand(f))  # SUMO loads them first, as additional files
    return SumoConfig(path=path, net=nets[0] if nets else None,
                      routes=demand + _files(options.get("route-files", ""), folder),
                      additional=tuple(f for f in additional if f not in demand),
                      begin=times.get("begin"), end=times.get("end"),
                      loading=tuple((k, options[k]) for k in LOADING_OPTIONS if k in options))


FLOW_END = 86400.0  # [s] a flow's end where it gives none (SUMO's default: a day after 0)


@dataclass(frozen=True)
class Departures:
    """The departures of one top-level demand element of a route file: one at ``begin`` [s] (a
    vehicle, trip or person), or a flow's over [begin, end) [s]: every ``period`` [s] from its
    begin (its period, per-hour rate, or number spread over the interval), or at random at
    ``rate`` [1/s] (a probability per second or a Poisson period: an expected count)."""

    tag: str
    begin: float  # [s]
    end: float | None = None  # [s] a flow's end (None: a single departure)
    period: float | None = None  # [s] a regular flow's headway
    rate: float = 0.0  # [1/s] a random flow's

    def count(self, a: float, b: float) -> float:
        """[-] how many depart within [a, b) [s] (expected, for a random flow)."""
        if self.end is None:
            return 1.0 if in_window(self.begin, a, b) else 0.0
        lo, hi = max(a, self.begin), min(b, self.end)  # [s]
        if hi <= lo:
            return 0.0
        if self.period is None:
            return (hi - lo) * self.rate
        first = max(0, math.ceil((lo - self.begin) / self.period - 1e-9))  # [-] the first departure's index
        last = math.ceil((hi - self.begin) / self.period - 1e-9)  # [-] one past the last
        return float(max(0, last - first))


def sumo_number(text: str | None) -> float | None:
    """A SUMO number or time attribute (None if absent or not a number, e.g. "triggered"), its
    argument for ``exp(x)`` (a Poisson period's rate)."""
    if text is None:
        return None
    text = text.strip()
    try:
        return float(text[4:-1]) if text.startswith("exp(") else float(sumolib.miscutils.parseTime(text))
    except (TypeError, ValueError):
        return None


def _flow(el) -> Departures | None:
    """A flow element's departures (None: no numeric begin)."""
    begin = sumo_number(el.get("begin", "0"))
    if begin is None:
        return None
    end, number = sumo_number(el.get("end")), sumo_number(el.get("number"))
    text = el.get("period") or ""
    per_hour = sumo_number(el.get("vehsPerHour") or el.get("personsPerHour") or el.get("perHour"))
    probability = sumo_number(el.get("probability"))  # [1/s]
    if text.strip().startswith("exp(") or probability is not None:  # random: an expected count
        rate = (sumo_number(text) or 0.0) if probability is None else probability  # [1/s]
        return Departures(el.tag, begin, end if end is not None else FLOW_END, None, rate)
    period = sumo_number(text) or (3600.0 / per_hour if per_hour else None)  # [s]
    if period is None:  # a number spread over the interval
        end = end if end is not None else FLOW_END
        period = (end - begin) / number if number else math.inf
    elif number is not None:
        end = min(end if end is not None else math.inf, begin + number * period)
    return Departures(el.tag, begin, end if end is not None else FLOW_END, period)


def route_demand(path: str, tags: tuple[str, ...] = DEMAND_TAGS) -> tuple[Departures, ...]:
    """The departures of each top-level demand element of a route file whose tag is among
    ``tags``; elements without a numeric depart ("triggered") are left out."""
    st = os.stat(path)
    return _route_demand(path, st.st_mtime_ns, st.st_size, tags)


@functools.lru_cache(maxsize=16)
def _route_demand(path: str, mtime_ns: int, size: int, tags: tuple[str, ...]) -> tuple[Departures, ...]:
    out = []
    for el in xml_root(path):
        if el.tag not in tags:
            continue
        if el.tag.endswith("Flow") or el.tag == "flow":
            flow = _flow(el)
            if flow is not None:
                out.append(flow)
        elif sumo_number(el.get("depart")) is not None:
            out.append(Departures(el.tag, sumo_number(el.get("depart"))))
    return tuple(out)


def in_window(depart: float, begin: float, end: float) -> bool:
    """Whether ``depart`` [s] lies in the demand window [``begin``, ``end``) [s]."""
    return begin - 1e-9 <= depart < end - 1e-9


def check_window(src: str, routes: tuple[str, ...], begin: float, duration: float) -> int:
    """How many of the route files' vehicles and people depart in [begin, begin + duration) [s]
    (a flow by its interval); an InputError naming the files, the window and their first depart
    time if they have demand and none of it departs in the window (files of vTypes only are no
    demand)."""
    demand = [d for path in routes for d in route_demand(path)]
    n = round(sum(d.count(begin, begin + duration) for d in demand))
    if n == 0 and demand:
        names = ", ".join(routes)
        raise InputError(src, "scenario.begin", begin,
                         f"no vehicle of {names} departs in the window [{begin:g}, {begin + duration:g}) s "
                         f"(scenario.begin + duration); its first vehicle departs at {min(d.begin for d in demand):g} s")
    return n

