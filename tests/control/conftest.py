"""Fixtures of the controller tests."""

import pytest

from intersection_cosim.control.base import ControlContext
from intersection_cosim.control.game import GameController
from intersection_cosim.models.settings import ModelSettings


@pytest.fixture
def controller(paths, net_file):
    """A Nash game controller set up on the default net (ETM on, 0.1 s period)."""
    c = GameController("nash")
    c.setup(ControlContext(paths=paths, net_file=str(net_file), model=ModelSettings(), control_period=0.1,
                           solver=None, etm=True))
    return c
