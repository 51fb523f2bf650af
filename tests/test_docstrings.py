"""The package's docstrings and comments say what, the unit and why: no history.

Issue numbers, rounds of work, session dates and the seeds of past incidents belong in the
decision records (docs/decisions/) or the git log, where they keep their context.
"""

from __future__ import annotations

import ast
import io
import re
import tokenize
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "intersection_cosim"
MONTHS = "January|February|March|April|May|June|July|August|September|October|November|December"
HISTORY = {
    "an issue number": re.compile(r"\bissues?\s*#?\d+|(?<![\w&])#\d{1,4}\b(?![0-9a-fA-F])", re.I),
    "a round of work": re.compile(r"\brounds?\s+\d+", re.I),
    "a session date": re.compile(rf"\b\d{{1,2}}\s+({MONTHS})\b|\b({MONTHS})\s+\d{{4}}\b|\b20\d\d-\d\d-\d\d\b"),
    "the seed of an incident": re.compile(r"\bseed\s+\d+\b", re.I),
    "the old design notes": re.compile(r"design\.md"),
}


def texts(path: Path) -> list[tuple[int, str]]:
    """(line, text) of every docstring and comment of the module at ``path``."""
    source = path.read_text()
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc:
                out.append((getattr(node, "lineno", 1), doc))
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            out.append((tok.start[0], tok.string))
    return out


def findings(path: Path) -> list[str]:
    found = []
    for line, text in texts(path):
        flat = " ".join(text.split())
        for what, pattern in HISTORY.items():
            m = pattern.search(flat)
            if m:
                found.append(f"{path.name}:{line}: {what}: {m.group(0)!r}")
    return found


def test_the_patterns_catch_history(tmp_path):
    sample = tmp_path / "sample.py"
    sample.write_text('"""Fixed in issue 18, round 8 (4 December 2026; seed 7, docs/design.md)."""\n'
                      "X = 1  # see #52\nCOLOR = '#595959'  # a colour, not an issue\n")
    kinds = {f.split(": ")[1] for f in findings(sample)}
    assert kinds == set(HISTORY)


@pytest.mark.parametrize("path", sorted(PACKAGE.rglob("*.py")), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_history_in_docstrings_or_comments(path):
    assert findings(path) == []
