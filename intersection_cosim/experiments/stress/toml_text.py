"""A scenario dict (as ``tomllib`` reads it) written back as TOML text: tables, arrays of tables,
inline tables of scalars, strings, booleans, integers, floats and lists of them."""

from __future__ import annotations

import json
import math
import re

BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(key: str) -> str:
    return key if BARE_KEY.match(key) else json.dumps(key)


def value_text(value) -> str:
    """One TOML value: a scalar, a list or an inline table of them."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(value_text(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_key(k)} = {value_text(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"cannot write {type(value).__name__} as TOML")


def _is_table_array(value) -> bool:
    return isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)


def _table(lines: list[str], table: dict, path: tuple[str, ...], nested_inline: bool) -> None:
    """Append ``table``'s keys, then its sub-tables and arrays of tables, to ``lines``."""
    subs = []
    for key, value in table.items():
        plain = not (isinstance(value, dict) or _is_table_array(value))
        if plain or (nested_inline and isinstance(value, dict)):
            lines.append(f"{_key(key)} = {value_text(value)}")
        else:
            subs.append((key, value))
    for key, value in subs:
        name = ".".join(_key(k) for k in (*path, key))
        if isinstance(value, dict):
            lines += ["", f"[{name}]"]
            _table(lines, value, (*path, key), False)
        else:
            for item in value:
                lines += ["", f"[[{name}]]"]
                _table(lines, item, (*path, key), True)


def dumps(data: dict, header: str = "") -> str:
    """``data`` as TOML text; ``header`` lines (without ``#``) go first as comments."""
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    body: list[str] = []
    _table(body, data, (), False)
    while body and body[0] == "":
        body.pop(0)
    return "\n".join(lines + ([""] if lines else []) + body) + "\n"
