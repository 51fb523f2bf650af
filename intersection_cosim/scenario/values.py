"""Checks of a scenario file's plain values, shared by the scenario loaders."""

from __future__ import annotations

import math
from typing import Any

from intersection_cosim.errors import InputError


def number(src: str, field: str, value: Any, *, minimum: float | None = None,
           maximum: float | None = None) -> float:
    """``value`` as a float, or an InputError naming ``field`` when it is not a finite number in
    [``minimum``, ``maximum``]."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(src, field, value, "must be a finite number")
    if minimum is not None and value < minimum:
        raise InputError(src, field, value, f"must be >= {minimum:g}")
    if maximum is not None and value > maximum:
        raise InputError(src, field, value, f"must be <= {maximum:g}")
    return float(value)


def choice(src: str, field: str, value: Any, options: tuple[str, ...]) -> str:
    if value not in options:
        raise InputError(src, field, value, f"must be one of {', '.join(options)}")
    return value


def unknown_keys(src: str, prefix: str, table: dict, known: tuple[str, ...]) -> None:
    for key in table:
        if key not in known:
            raise InputError(src, f"{prefix}.{key}", table[key], f"unknown key (known: {', '.join(known)})")
