"""Registry of controllers by name: the only place that knows every controller.

Each entry maps a name to a factory ``(scenario) -> Controller`` and the settings class of its
``[controller.solver]`` table (None if it takes none).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from intersection_cosim.errors import InputError
from intersection_cosim.settings import from_table


@dataclass(frozen=True)
class Entry:
    factory: Callable[[Any], Any]  # (Scenario) -> Controller
    solver_settings: type | None = None
    description: str = ""


_REGISTRY: dict[str, Entry] = {}


def register(name: str, entry: Entry) -> None:
    _REGISTRY[name] = entry


def names() -> list[str]:
    _load_builtin()
    return sorted(_REGISTRY)


def get(name: str) -> Entry:
    _load_builtin()
    return _REGISTRY[name]


def validate_solver_table(kind: str, table: dict, src: str) -> Any:
    entry = get(kind)
    if entry.solver_settings is None:
        if table:
            key = next(iter(table))
            raise InputError(src, f"controller.solver.{key}", table[key], f"the {kind} controller takes no solver settings")
        return None
    return from_table(entry.solver_settings, table, src, "controller.solver")


def create(scenario) -> Any:
    return get(scenario.controller.kind).factory(scenario)


_loaded = False


def _load_builtin() -> None:
    global _loaded
    if _loaded:
        return
    _loaded = True
    from intersection_cosim.control.sumo_baseline import SumoController

    register("sumo", Entry(lambda scn: SumoController(junction_type=scn.scenario.junction_type),
                           None, "SUMO's own driver model and right of way"))
    for name, jtype, what in (("sumo-priority", "priority", "priority junction (right of way by road priority)"),
                              ("sumo-allway-stop", "allway_stop", "all-way stop"),
                              ("sumo-tls", "traffic_light", "traffic lights, SUMO's default signal programme")):
        register(name, Entry(lambda scn, jtype=jtype: SumoController(junction_type=jtype),
                             None, f"baseline: SUMO's driver model at a {what}"))

    from intersection_cosim.control.game import GameController
    from intersection_cosim.games.settings import GameSettings

    for name, what in (("nash", "Nash"), ("stackelberg", "Stackelberg")):
        register(name, Entry(lambda scn, name=name: GameController(name, scn.solver),
                             GameSettings, f"the paper's differential game, {what} equilibrium"))

    from intersection_cosim.control.fcfs import FcfsController, FcfsSettings

    register("fcfs", Entry(lambda scn: FcfsController(scn.solver), FcfsSettings,
                           "first-come-first-served reservation of the conflict points (Dresner and Stone)"))
