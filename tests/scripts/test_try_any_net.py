"""scripts/try_any_net.py on a net with nothing to manage: one line and exit status 2."""

from __future__ import annotations

import pytest

from tests.scripts.script_module import load_script


def _script():
    return load_script("try_any_net")


@pytest.mark.parametrize("net", ["rail/net.net.xml",  # every junction's connections are rail only
                                 "racing/spreewaldring.net.xml"])  # a ring: no intersection at all
def test_a_net_without_a_manageable_junction_says_so(capsys, net):
    assert _script().main([f"$SUMO_HOME/tools/game/{net}"]) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and "no manageable junction in the net" in captured.err
    assert captured.out == ""  # no JSON line of an empty result
