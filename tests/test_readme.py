"""README.md stands alone and its walk-through runs as written (parsed by the CLI)."""

from __future__ import annotations

import dataclasses
import glob
import re
import shlex
from pathlib import Path

import pytest

from intersection_cosim.cli import build_parser
from intersection_cosim.report.reporting import FIGURES_DIR, TRADEOFF_PNG

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _bash_lines(text: str) -> list[str]:
    """The command lines of the ```bash blocks (continuations joined, comments dropped)."""
    lines = []
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split("  #")[0].strip()
            if line:
                lines.append(line)
    return lines


def test_no_reference_outside_the_repository():
    assert "../" not in README
    for path in re.findall(r"`((?:scripts|intersection_cosim|scenarios|sumo_networks|tests)/[^`\s]*)`", README):
        pattern = re.sub(r"\{[^}]*\}|<[^>]*>", "*", path)
        assert glob.glob(str(ROOT / pattern)), path


def test_the_readme_is_short():
    assert len(README.splitlines()) <= 300


def test_every_link_into_the_repository_exists():
    links = re.findall(r"\]\((?!https?:)([^)#\s]+)", README)
    assert links, "the README links into the docs"
    for link in links:
        assert (ROOT / link).exists(), link


def _settings_classes():
    from tests.scripts.script_module import load_script

    return [cls for _table, cls, _who in load_script("settings_reference").TABLES]


def test_no_default_value_is_restated():
    """A default is written once, in its settings class: the README names keys, never their defaults."""
    for cls in _settings_classes():
        for f in dataclasses.fields(cls):
            default = f.default
            if default is dataclasses.MISSING or default is None or isinstance(default, (tuple, str)):
                continue
            value = str(default).lower() if isinstance(default, bool) else f"{default:g}"
            near = re.compile(rf"`?{re.escape(f.name)}`?\s*(=|:|\(|is|of|default)?\s*`?{re.escape(value)}\b")
            assert not near.search(README), f"README restates {cls.__name__}.{f.name} = {value}"
    assert not re.search(r"\bdefaults? (?:is |of |to )?`?\d", README)


def test_the_install_commands_are_the_ones_ci_runs():
    ci = (ROOT / ".ci" / "run").read_text().strip().splitlines()[-1]
    assert ci in _bash_lines(README)
    assert ("python3.11 -m venv .venv && . .venv/bin/activate && pip install -e . && "
            "python scripts/reproduce_paper.py --out report") in _bash_lines(README)


def test_a_first_session_follows_the_install_commands():
    start = README.index("## A first session")
    assert README.index('pip install -e ".[test,docs]"') < start < README.index("## What it does")
    section = README[start:README.index("\n## ", start + 1)]
    commands = [c for c in _bash_lines(section) if c.startswith("intersection-cosim ")]
    assert [shlex.split(c)[1] for c in commands] == ["run", "report", "animate", "sweep", "report"]
    assert commands[0] == "intersection-cosim run scenarios/case1_A.toml --out runs/case1_A"
    assert commands[2] == "intersection-cosim animate runs/case1_A"
    sweep_out = shlex.split(commands[3])[shlex.split(commands[3]).index("--out") + 1]
    assert commands[4] == f"intersection-cosim report {sweep_out}"
    assert f"`{sweep_out}/{FIGURES_DIR}/{TRADEOFF_PNG.format(vehicle='V2')}`" in section


@pytest.mark.parametrize("command", [c for c in _bash_lines(README) if c.startswith("intersection-cosim ")])
def test_every_readme_command_parses(command, capsys):
    argv = shlex.split(command)[1:]
    try:
        build_parser().parse_args(argv)
    except SystemExit:
        raise AssertionError(capsys.readouterr().err) from None
