"""SUMO's warnings of a run (``sumo.log``, SUMO's ``--error-log``), counted by kind.

A warning's kind is its text with the quoted ids and the numbers taken out, so that the same
message about many vehicles, lanes or signals counts as one kind ("Unsafe green phase # in tlLogic
'…'").
"""

from __future__ import annotations

import re
from pathlib import Path

FIRST = 3  # [-] distinct warnings a summary keeps in full (and ``run`` prints)
_QUOTED = re.compile(r"'[^']*'")
_NUMBER = re.compile(r"\d+(\.\d+)?")
_PREFIX = re.compile(r"^(Warning|Error): ")


def warning_kind(message: str) -> str:
    """The kind of a SUMO message: its text without the ``Warning:`` prefix, quoted ids as '…'
    and numbers as #."""
    text = _PREFIX.sub("", message.strip())
    return _NUMBER.sub("#", _QUOTED.sub("'…'", text))


def read_sumo_log(path: str | Path) -> dict:
    """``{"warnings": n, "errors": n, "by_kind": {kind: n, most first}, "first": [the first
    FIRST distinct warnings, in full]}`` of the SUMO log ``path`` (zeros if it does not exist)."""
    counts: dict[str, int] = {}
    first: list[str] = []
    n_warn = n_err = 0
    if Path(path).exists():
        for line in Path(path).read_text(errors="replace").splitlines():
            if line.startswith("Warning: "):
                n_warn += 1
            elif line.startswith("Error: "):
                n_err += 1
            else:
                continue
            kind = warning_kind(line)
            if kind not in counts and len(first) < FIRST:
                first.append(line.strip())
            counts[kind] = counts.get(kind, 0) + 1
    by_kind = dict(sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])))
    return {"warnings": n_warn, "errors": n_err, "by_kind": by_kind, "first": first}
