"""Scenario axes of ``sweep`` and ``compare``: a command-line option that sets one scenario field.

One :class:`Axis` per entry of :data:`AXES`: its name (a sweep.csv / comparison.csv column and a
part of run ids, e.g. ``-latency_0.10``), its command-line flag, the scenario field every run of
the axis value overrides, the range a value must lie in and how it is applied. A new axis is one
more entry here.

Values are a comma-separated list, ``--latency 0,0.1,0.2``; each axis multiplies the grid.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

from intersection_cosim.errors import InputError
from intersection_cosim.scenario.model import Scenario

MAX_AXIS_VALUES = 100  # [-] values one axis option may list


@dataclasses.dataclass(frozen=True)
class Axis:
    name: str  # column of sweep.csv / comparison.csv and part of the run ids
    flag: str  # command-line option of sweep and compare
    field: str  # the scenario field it overrides in every run
    unit: str  # of the values (for figure labels)
    minimum: float  # smallest allowed value
    maximum: float  # largest allowed value (math.inf: none)
    apply: Callable[[Scenario, float], Scenario]  # the scenario with the field set


def _v2x_field(name: str) -> Callable[[Scenario, float], Scenario]:
    def apply(scn: Scenario, value: float) -> Scenario:
        return dataclasses.replace(scn, v2x=dataclasses.replace(scn.v2x, **{name: value}))

    return apply


def _every_flow(name: str) -> Callable[[Scenario, float], Scenario]:
    def apply(scn: Scenario, value: float) -> Scenario:
        return dataclasses.replace(scn, flows=tuple(dataclasses.replace(f, **{name: value}) for f in scn.flows))

    return apply


AXES: dict[str, Axis] = {axis.name: axis for axis in (
    Axis("latency", "--latency", "v2x.latency", "s", 0.0, math.inf, _v2x_field("latency")),
    Axis("loss", "--loss", "v2x.loss", "-", 0.0, 1.0, _v2x_field("loss")),
    Axis("av_share", "--av-share", "flow.av_share", "-", 0.0, 1.0, _every_flow("av_share")),
)}


def parse_axis(name: str, text: str) -> tuple[float, ...]:
    """``0,0.1,0.2`` -> (0.0, 0.1, 0.2) for axis ``name``; an InputError naming its flag otherwise."""
    axis = AXES[name]
    values = []
    for part in str(text).split(","):
        try:
            value = round(float(part), 6)
        except ValueError:
            raise InputError(axis.flag, name, text, f"bad syntax: {part.strip()!r} is not a number "
                             "(give a comma-separated list, e.g. 0,0.1,0.2)") from None
        if not (math.isfinite(value) and axis.minimum <= value <= axis.maximum):
            bound = f"[{axis.minimum:g}, {axis.maximum:g}]" if math.isfinite(axis.maximum) else f">= {axis.minimum:g}"
            raise InputError(axis.flag, name, text, f"value {part.strip()} must be {bound} ({axis.field})")
        if value in values:
            raise InputError(axis.flag, name, text, f"value {value:g} given twice")
        values.append(value)
    if len(values) > MAX_AXIS_VALUES:
        raise InputError(axis.flag, name, text, f"more than {MAX_AXIS_VALUES} values")
    return tuple(values)


def parse_axes(given: dict[str, str | None] | None) -> tuple[tuple[str, tuple[float, ...]], ...]:
    """The axes given on the command line (name -> text or None), in :data:`AXES` order."""
    given = given or {}
    for name in given:
        if name not in AXES:
            raise InputError("sweep", name, given[name], f"is not an axis (known: {', '.join(AXES)})")
    return tuple((name, parse_axis(name, given[name])) for name in AXES if given.get(name) is not None)


def apply_axes(scn: Scenario, values: tuple[tuple[str, float], ...]) -> Scenario:
    """``scn`` with every (axis name, value) applied."""
    for name, value in values:
        scn = AXES[name].apply(scn, value)
    return scn
