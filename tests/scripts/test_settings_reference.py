"""docs/reference/settings.md is generated from the settings dataclasses and is current."""

from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

from tests.scripts.script_module import load_script

ROOT = Path(__file__).resolve().parents[2]
ref = load_script("settings_reference")


def test_the_page_is_what_the_code_says():
    assert (ROOT / "docs" / "reference" / "settings.md").read_text() == ref.page(), \
        "run: python scripts/settings_reference.py"


def test_every_settings_class_of_the_package_is_on_the_page():
    named = set()
    for path in (ROOT / "intersection_cosim").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef) and node.name.endswith("Settings"):
                named.add(node.name)
    covered = {cls.__name__ for _table, cls, _who in ref.TABLES}
    assert named - ref.CONTAINERS <= covered


def test_every_field_has_its_unit_default_and_meaning_on_the_page():
    page = ref.page()
    for _table, cls, _who in ref.TABLES:
        rows = {r["name"]: r for r in ref.rows(cls)}
        for f in dataclasses.fields(cls):
            if (cls.__name__, f.name) in ref.INTERNAL:
                continue
            if f.name not in rows:  # a nested table, listed as its own table
                assert str(f.type).endswith("Settings") or "AttackSettings" in str(f.type), f.name
                continue
            row = rows[f.name]
            assert row["unit"].startswith("["), f"{cls.__name__}.{f.name} has no [unit] comment"
            assert row["meaning"], f"{cls.__name__}.{f.name} has no meaning in its comment"
            assert row["default"], f"{cls.__name__}.{f.name}"
            assert f"| `{f.name}` |" in page


def test_a_default_is_read_from_the_dataclass_and_a_unit_from_its_comment():
    from intersection_cosim.games.settings import ProblemSettings

    row = next(r for r in ref.rows(ProblemSettings) if r["name"] == "horizon")
    assert (row["unit"], row["default"]) == ("[s]", repr(ProblemSettings().horizon))
    assert "planning horizon" in row["meaning"]


def test_comments_above_and_after_a_field_are_both_read():
    src = """class S:
    a: float = 1.0  # [m] first line
    #                 and its continuation
    # [s] a leading comment
    # on two lines
    b: float = 2.0
    # --- a section header ---
    c: bool = True  # [-] a switch
"""
    assert ref.comments_of_class_source(src) == {
        "a": ("[m]", "first line and its continuation"),
        "b": ("[s]", "a leading comment on two lines"),
        "c": ("[-]", "a switch")}
