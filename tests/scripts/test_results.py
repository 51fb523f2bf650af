"""scripts/results.py: every results page is generated, and carries its provenance block."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from tests.scripts.script_module import load_script

ROOT = Path(__file__).resolve().parents[2]
results = load_script("results")


def test_every_results_page_exists_and_carries_a_provenance_block():
    pages = sorted((ROOT / "docs" / "results").glob("*.md"))
    assert {p.stem for p in pages} == {p.name for p in results.PAGES} | {"index"}
    for page in pages:
        assert results.has_provenance(page.read_text()), f"{page.name} has no complete provenance block"


def test_a_block_without_one_of_its_fields_is_not_a_provenance_block():
    block = results.provenance("python scripts/results.py", ["cmd a"], "abc123", "2030-01-01 00:00 UTC", "Linux")
    assert results.has_provenance(block)
    for field in results.PROVENANCE_FIELDS:
        assert not results.has_provenance("\n".join(l for l in block.splitlines() if f"- {field}:" not in l))


def test_a_page_embeds_its_benchmarks_report_and_figures(tmp_path, monkeypatch):
    monkeypatch.setattr(results, "DOCS", tmp_path / "docs")
    (tmp_path / "docs").mkdir()
    bench = tmp_path / "work" / "0"
    (bench / "figures").mkdir(parents=True)
    (bench / "figures" / "travel.png").write_bytes(b"png")
    (bench / "report.md").write_text("# Controller comparison\n\n| a [s] |\n|---|\n| 1.50 |\n\n"
                                      "![travel](figures/travel.png)\n\nsee [the csv](comparison.csv)\n")
    page = results.PAGES[1]
    header = {"command": "python scripts/results.py --quick", "commit": "abc", "date": "today", "machine": "here"}
    path = results.write_page(page, [("intersection-cosim compare x", bench / "report.md")], header)
    text = path.read_text()
    assert results.has_provenance(text)
    assert "### Controller comparison" in text and "| 1.50 |" in text
    assert f"![travel](figures/{page.name}/travel.png)" in text
    assert (tmp_path / "docs" / "figures" / page.name / "travel.png").read_bytes() == b"png"
    assert "the csv (`comparison.csv`)" in text  # a link into the work folder becomes plain text


def test_the_quick_commands_are_run_with_this_python(tmp_path):
    seen = []

    class Done:
        returncode = 0

    def run(argv, cwd):
        seen.append(argv)
        return Done()

    page = next(p for p in results.PAGES if p.name == "demand")
    done = results.run_page(page, quick=True, work=tmp_path, run=run)
    assert seen[0][:3] == [sys.executable, "-m", "intersection_cosim"] and seen[0][3] == "compare"
    assert "--duration" in seen[0] and str(tmp_path / "demand" / "0") in seen[0]
    assert done == [(page.quick[0].format(out=tmp_path / "demand" / "0"), tmp_path / "demand" / "0" / "report.md")]


def test_a_failing_benchmark_stops_the_page(tmp_path):
    class Failed:
        returncode = 2

    with pytest.raises(SystemExit):
        results.run_page(results.PAGES[0], quick=True, work=tmp_path, run=lambda argv, cwd: Failed())


def test_an_unknown_page_is_one_line_and_exit_status_2(capsys):
    assert results.main(["--pages", "nope"]) == 2
    assert capsys.readouterr().err.count("\n") == 1


@pytest.mark.parametrize("command", [c for p in results.PAGES for c in p.full + p.quick if c.startswith(results.COSIM)])
def test_every_benchmark_command_parses_and_names_shipped_scenarios(command, capsys):
    import shlex

    from intersection_cosim.cli import build_parser

    argv = shlex.split(command.format(out="build/results/x"))[1:]
    try:
        build_parser().parse_args(argv)
    except SystemExit:
        raise AssertionError(capsys.readouterr().err) from None
    for arg in argv:
        if arg.endswith(".toml"):
            assert (ROOT / arg).is_file(), arg
