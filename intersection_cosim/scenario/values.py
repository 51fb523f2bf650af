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
