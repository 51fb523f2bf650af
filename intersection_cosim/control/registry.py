"""Registry of controllers by name: the only place that knows every controller.

Each entry maps a name to a factory ``(settings, junction type) -> Controller`` and the class of
its settings, read from the scenario's ``[controller.<table>]`` sub-tables (None if it takes
none). The factory gets plain values, not a Scenario: the scenario layer sits above this one (it
validates a scenario file's ``[controller]`` tables against :func:`names` and
:func:`validate_tables`).
"""

from __future__ import annotations

import dataclasses
import typing
from dataclasses import dataclass
from typing import Any, Callable

from intersection_cosim.control.base import Controller
from intersection_cosim.control.baselines.actuated import ActuatedController
from intersection_cosim.control.baselines.fcfs import FcfsController
from intersection_cosim.control.baselines.max_pressure import MaxPressureController
from intersection_cosim.control.baselines.reservations import FcfsSettings
from intersection_cosim.control.baselines.signal_settings import SignalSettings
from intersection_cosim.control.game.controller import GameController
from intersection_cosim.control.per_junction import PerJunction
from intersection_cosim.control.game.settings import GameControllerSettings
from intersection_cosim.control.baselines.sumo_baseline import SumoController
from intersection_cosim.errors import InputError
from intersection_cosim.settings import from_table


@dataclass(frozen=True)
class Entry:
    factory: Callable[[Any, str], Controller]  # (settings or None, junction type) -> Controller
    settings: type | None = None  # class of the controller's validated settings (None: takes none)
    description: str = ""
    table: str | None = None  # the one [controller.<table>] its settings come from; None: the
    #                           settings class has one field per sub-table ([controller.game], ...)


_REGISTRY: dict[str, Entry] = {}


def register(name: str, entry: Entry) -> None:
    _REGISTRY[name] = entry


def names() -> list[str]:
    return sorted(_REGISTRY)


def get(name: str) -> Entry:
    return _REGISTRY[name]


def validate_tables(kind: str, tables: dict[str, dict], src: str) -> Any:
    """The settings of controller ``kind`` from its ``[controller.<table>]`` sub-tables (table
    name -> raw table); a key in a table it does not belong to is an InputError naming the table
    it belongs in."""
    entry = get(kind)
    given = {name: table for name, table in tables.items() if table}
    if entry.settings is None or entry.table is not None:
        for name, table in given.items():
            if name != entry.table:
                key = next(iter(table))
                what = "no settings" if entry.settings is None else f"only [controller.{entry.table}]"
                raise InputError(src, f"controller.{name}.{key}", table[key], f"the {kind} controller takes {what}")
        if entry.settings is None:
            return None
        return from_table(entry.settings, given.get(entry.table), src, f"controller.{entry.table}")
    _check_moved_keys(entry.settings, given, src)
    return from_table(entry.settings, given, src, "controller")


def _check_moved_keys(settings: type, tables: dict[str, dict], src: str) -> None:
    hints = typing.get_type_hints(settings)  # sub-table name -> its settings class
    fields = {f.name: {g.name for g in dataclasses.fields(hints[f.name])} for f in dataclasses.fields(settings)}
    for name, table in tables.items():
        for key, value in table.items():
            if name in fields and key in fields[name]:
                continue
            home = [other for other, keys in fields.items() if key in keys]
            if home:
                raise InputError(src, f"controller.{name}.{key}", value, f"moved to [controller.{home[0]}]")


def create(kind: str, settings: Any, junction_type: str) -> Controller:
    """A new controller ``kind`` with its validated settings; ``junction_type`` is the
    scenario's SUMO node type of the centre (used by the ``sumo`` controller)."""
    return get(kind).factory(settings, junction_type)


def create_per_junction(kind: str, settings: Any, junction_type: str) -> PerJunction:
    """Controllers ``kind``, one per managed junction (made at setup, see control.per_junction)."""
    return PerJunction(lambda: create(kind, settings, junction_type))


def _register_builtin() -> None:
    register("sumo", Entry(lambda settings, jtype: SumoController(junction_type=jtype),
                           None, "SUMO's own driver model and right of way"))
    for name, fixed, what in (("sumo-priority", "priority", "a priority junction (right of way by road priority)"),
                              ("sumo-allway-stop", "allway_stop", "an all-way stop"),
                              ("sumo-tls", "traffic_light", "traffic lights (SUMO's default signal programme)")):
        register(name, Entry(lambda settings, jtype, fixed=fixed: SumoController(junction_type=fixed),
                             None, f"baseline: SUMO's driver model at {what}"))
    for name, what in (("nash", "Nash"), ("stackelberg", "Stackelberg")):
        register(name, Entry(lambda settings, jtype, name=name: GameController(name, settings),
                             GameControllerSettings, f"the paper's differential game, {what} equilibrium"))
        register(f"{name}-coupled", Entry(lambda settings, jtype, name=name: GameController(name, settings, coupling="cluster"),
                                          GameControllerSettings,
                                          f"the differential game, {what} equilibrium, one N-player game per conflict "
                                          "cluster of three or more vehicles"))
    register("sumo-actuated", Entry(lambda settings, jtype: ActuatedController(settings=settings), SignalSettings,
                                    "baseline: SUMO's actuated signal programme from the net's own phases "
                                    "(gap-based extension)", table="signals"))
    register("max-pressure", Entry(lambda settings, jtype: MaxPressureController(settings), SignalSettings,
                                   "baseline: max-pressure phase choice on the net's traffic lights "
                                   "(defaults: every 5 s, min green 5 s, yellow 3 s)", table="signals"))
    register("fcfs", Entry(lambda settings, jtype: FcfsController(settings), FcfsSettings,
                           "first-come-first-served reservation of the conflict points (Dresner and Stone)",
                           table="solver"))


_register_builtin()
