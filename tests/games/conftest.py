"""Fixtures of the game-solver tests: settings and a seeded battery of random pairs."""

from __future__ import annotations

import pytest

from intersection_cosim.games import GameSettings, battery, nash_equilibrium
from intersection_cosim.models.settings import ModelSettings

BATTERY_SIZE = 60  # problems: alternating crossing and merging pairs
BATTERY_SEED = 2024


@pytest.fixture(scope="session")
def gs() -> GameSettings:
    return GameSettings()


@pytest.fixture(scope="session")
def ms() -> ModelSettings:
    return ModelSettings()


@pytest.fixture(scope="session")
def pair_battery():
    return battery(BATTERY_SIZE, seed=BATTERY_SEED)


@pytest.fixture(scope="session")
def nash_battery(pair_battery, gs, ms):
    """Cold Nash equilibria of the battery, solved once for all tests."""
    return [nash_equilibrium(p, gs, ms) for p in pair_battery]
