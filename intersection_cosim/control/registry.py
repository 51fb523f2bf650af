"""Registry of controllers by name: the only place that knows every controller.

Each entry maps a name to a factory ``(solver settings, junction type) -> Controller`` and the
settings class of its ``[controller.solver]`` table (None if it takes none). The factory gets plain
values, not a Scenario: the scenario layer sits above this one (it validates a scenario file's
``[controller]`` table against :func:`names` and :func:`validate_solver_table`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from intersection_cosim.control.base import Controller
from intersection_cosim.control.fcfs import FcfsController, FcfsSettings
from intersection_cosim.control.game import GameController
from intersection_cosim.control.sumo_baseline import SumoController
from intersection_cosim.errors import InputError
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.settings import from_table


@dataclass(frozen=True)
class Entry:
    factory: Callable[[Any, str], Controller]  # (solver settings or None, junction type) -> Controller
    solver_settings: type | None = None
    description: str = ""


_REGISTRY: dict[str, Entry] = {}


def register(name: str, entry: Entry) -> None:
    _REGISTRY[name] = entry


def names() -> list[str]:
    return sorted(_REGISTRY)


def get(name: str) -> Entry:
    return _REGISTRY[name]


def validate_solver_table(kind: str, table: dict, src: str) -> Any:
    entry = get(kind)
    if entry.solver_settings is None:
        if table:
            key = next(iter(table))
            raise InputError(src, f"controller.solver.{key}", table[key], f"the {kind} controller takes no solver settings")
        return None
    return from_table(entry.solver_settings, table, src, "controller.solver")


def create(kind: str, solver: Any, junction_type: str) -> Controller:
    """A new controller ``kind`` with its validated solver settings; ``junction_type`` is the
    scenario's SUMO node type of the centre (used by the ``sumo`` controller)."""
    return get(kind).factory(solver, junction_type)


def _register_builtin() -> None:
    register("sumo", Entry(lambda solver, jtype: SumoController(junction_type=jtype),
                           None, "SUMO's own driver model and right of way"))
    for name, fixed, what in (("sumo-priority", "priority", "priority junction (right of way by road priority)"),
                              ("sumo-allway-stop", "allway_stop", "all-way stop"),
                              ("sumo-tls", "traffic_light", "traffic lights, SUMO's default signal programme")):
        register(name, Entry(lambda solver, jtype, fixed=fixed: SumoController(junction_type=fixed),
                             None, f"baseline: SUMO's driver model at a {what}"))
    for name, what in (("nash", "Nash"), ("stackelberg", "Stackelberg")):
        register(name, Entry(lambda solver, jtype, name=name: GameController(name, solver),
                             GameSettings, f"the paper's differential game, {what} equilibrium"))
    register("fcfs", Entry(lambda solver, jtype: FcfsController(solver), FcfsSettings,
                           "first-come-first-served reservation of the conflict points (Dresner and Stone)"))


_register_builtin()
