"""scripts/try_any_net.py on a net with nothing to manage: one line and exit status 2."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _script():
    spec = importlib.util.spec_from_file_location("try_any_net", ROOT / "scripts" / "try_any_net.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("net", ["rail/net.net.xml",  # every junction's connections are rail only
                                 "racing/spreewaldring.net.xml"])  # a ring: no intersection at all
def test_a_net_without_a_manageable_junction_says_so(capsys, net):
    assert _script().main([f"$SUMO_HOME/tools/game/{net}"]) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and "no manageable junction in the net" in captured.err
    assert captured.out == ""  # no JSON line of an empty result
