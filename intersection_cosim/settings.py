"""Typed settings objects: one dataclass per concern, defaults documented next to each field.

Every settings dataclass is built from a scenario-file table with :func:`from_table`, which rejects
unknown keys and values of the wrong type with an :class:`~intersection_cosim.errors.InputError`
naming the file, the field and the value. A dataclass may define ``check(self) -> list[tuple[str,
str]]`` returning ``(field, problem)`` pairs for values out of range.
"""

from __future__ import annotations

import dataclasses
import typing
from typing import Any, TypeVar

from intersection_cosim.errors import InputError

T = TypeVar("T")


def _coerce(tp: Any, value: Any) -> Any:
    """Convert a TOML value to the field's type, or raise TypeError."""
    origin = typing.get_origin(tp)
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise TypeError("must be a number")
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError("must be an integer")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise TypeError("must be true or false")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise TypeError("must be a string")
        return value
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise TypeError("must be a list")
        (inner, *_rest) = typing.get_args(tp)
        return tuple(_coerce(inner, v) for v in value)
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, dict):
            raise TypeError("must be a table")
        return value  # handled by from_table recursion
    return value


def from_table(cls: type[T], table: dict[str, Any] | None, source: str, prefix: str) -> T:
    """Build settings ``cls`` from a TOML table; ``prefix`` names the table in error messages."""
    table = dict(table or {})
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls) if f.init}
    kwargs: dict[str, Any] = {}
    for key, value in table.items():
        field = f"{prefix}.{key}" if prefix else key
        if key not in names:
            raise InputError(source, field, value, f"unknown key (known: {', '.join(sorted(names))})")
        tp = hints[key]
        if dataclasses.is_dataclass(tp):
            if not isinstance(value, dict):
                raise InputError(source, field, value, "must be a table")
            kwargs[key] = from_table(tp, value, source, field)
            continue
        try:
            kwargs[key] = _coerce(tp, value)
        except TypeError as exc:
            raise InputError(source, field, value, str(exc)) from None
    obj = cls(**kwargs)
    check = getattr(obj, "check", None)
    if check is not None:
        for name, problem in check():
            field = f"{prefix}.{name}" if prefix else name
            raise InputError(source, field, getattr(obj, name), problem)
    return obj


def to_dict(obj: Any) -> dict[str, Any]:
    """Settings as a plain, JSON-ready dict (for summary.json)."""
    return dataclasses.asdict(obj)


def positive(obj: Any, *names: str) -> list[tuple[str, str]]:
    return [(n, "must be > 0") for n in names if not getattr(obj, n) > 0]


def non_negative(obj: Any, *names: str) -> list[tuple[str, str]]:
    return [(n, "must be >= 0") for n in names if not getattr(obj, n) >= 0]
