"""The documentation site: every page of mkdocs.yml's nav exists, and `mkdocs build --strict`
passes where MkDocs is installed (pip install -e ".[docs]")."""

from __future__ import annotations

import re
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CONFIG = (ROOT / "mkdocs.yml").read_text()


def nav_pages() -> list[str]:
    nav = CONFIG[CONFIG.index("\nnav:"):]
    return re.findall(r"^\s*-\s+(?:[^:\n]+:\s+)?(\S+\.md)\s*$", nav, re.M)


def test_every_nav_page_exists_and_every_page_is_in_the_nav():
    pages = nav_pages()
    assert "index.md" in pages and "reference/settings.md" in pages and "results/index.md" in pages
    for page in pages:
        assert (ROOT / "docs" / page).is_file(), page
    on_disk = {p.relative_to(ROOT / "docs").as_posix() for p in (ROOT / "docs").rglob("*.md")}
    assert on_disk == set(pages)


def test_the_design_notes_are_short_or_gone():
    design = ROOT / "docs" / "design.md"
    assert not design.exists() or len(design.read_text().splitlines()) <= 500
    assert len((ROOT / "docs" / "architecture.md").read_text().splitlines()) <= 500


def test_decision_records_are_numbered_and_indexed():
    index = (ROOT / "docs" / "decisions" / "index.md").read_text()
    records = sorted((ROOT / "docs" / "decisions").glob("[0-9][0-9][0-9]-*.md"))
    assert records
    for n, record in enumerate(records, start=1):
        assert record.name.startswith(f"{n:03d}-")
        assert f"({record.name})" in index
        assert record.read_text().startswith(f"# {n:03d}. ")


def test_no_text_file_holds_a_merge_conflict_marker():
    """A merge left `<<<<<<<` / `=======` / `>>>>>>>` lines in a page once; MkDocs renders them."""
    marker = re.compile(r"^(<{7} |={7}$|>{7} )", re.M)
    roots = [ROOT / d for d in ("docs", "intersection_cosim", "tests", "scripts", "scenarios")]
    files = [p for r in roots for p in r.rglob("*") if p.suffix in {".md", ".py", ".toml", ".yml"}]
    files += [ROOT / "README.md", ROOT / "pyproject.toml", ROOT / "mkdocs.yml"]
    assert len(files) > 100
    marked = [p.relative_to(ROOT).as_posix() for p in files if marker.search(p.read_text())]
    assert marked == []


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("mkdocs") is None,
                    reason='mkdocs is not installed (pip install -e ".[docs]")')
def test_mkdocs_build_strict_passes(tmp_path):
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")], cwd=ROOT,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
