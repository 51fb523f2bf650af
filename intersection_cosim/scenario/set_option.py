"""``--set TABLE.KEY=VALUE``: one scenario-file setting given on the command line.

The value is read as a TOML value (``0.3``, ``false``, ``"nash"``, ``[1, 2]``); a word that is not
one is taken as a string. The setting is written into the parsed file before it is validated, so a
``--set`` is checked like the file itself: an unknown key or a bad value is one line naming it.
"""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path
from typing import Any

from intersection_cosim.errors import InputError
from intersection_cosim.scenario.load import TOP_LEVEL, load_scenario, scenario_from_dict
from intersection_cosim.scenario.model import Scenario

FLAG = "--set"


def parse_set(text: str) -> tuple[tuple[str, ...], Any]:
    """``"controller.safety.time_gap=0.3"`` -> (("controller", "safety", "time_gap"), 0.3)."""
    key, sep, raw = text.partition("=")
    parts = tuple(p.strip() for p in key.split("."))
    if not sep or len(parts) < 2 or not all(parts):
        raise InputError(FLAG, "set", text, "bad syntax: expected TABLE.KEY=VALUE, e.g. controller.safety.time_gap=0.3")
    if parts[0] not in TOP_LEVEL or parts[0] in ("flow", "vehicle", "vtype"):
        tables = ", ".join(t for t in TOP_LEVEL if t not in ("flow", "vehicle", "vtype"))
        raise InputError(FLAG, ".".join(parts), raw.strip(), f"unknown table {parts[0]!r} (known: {tables})")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()
    return parts, value


def apply_sets(data: dict, sets: list[str] | None) -> dict:
    """A copy of the parsed scenario ``data`` with every ``--set`` written in (not yet validated)."""
    data = copy.deepcopy(data)
    for text in sets or []:
        parts, value = parse_set(text)
        table = data
        for i, part in enumerate(parts[:-1]):
            table = table.setdefault(part, {})
            if not isinstance(table, dict):
                raise InputError(FLAG, ".".join(parts), value, f"{'.'.join(parts[:i + 1])} is not a table")
        table[parts[-1]] = value
    return data


def validated(data: dict, src: str, sets: list[str] | None, base: Path | None = None) -> Scenario:
    """``scenario_from_dict`` of ``data``; a problem with a ``--set`` key is reported as the
    ``--set`` option's."""
    try:
        return scenario_from_dict(data, src, base)
    except InputError as exc:
        for text in sets or []:
            parts, value = parse_set(text)
            key = ".".join(parts)
            if exc.field == key or exc.field.startswith(key + ".") or key.startswith(exc.field + "."):
                raise InputError(FLAG, key, value, exc.problem) from None
        raise


def read_data(path: str | Path) -> dict:
    """The parsed TOML of a scenario file (checked readable by :func:`load_scenario` first)."""
    load_scenario(path)
    with open(path, "rb") as fh:
        return tomllib.load(fh)


def load_with_sets(path: str | Path, sets: list[str] | None) -> Scenario:
    """The scenario file at ``path`` with every ``--set`` applied, validated."""
    if not sets:
        return load_scenario(path)
    with open(path, "rb") as fh:
        try:
            data = tomllib.load(fh)
        except (tomllib.TOMLDecodeError, UnicodeDecodeError):
            return load_scenario(path)  # its one-line error
    return validated(apply_sets(data, sets), str(path), sets)
