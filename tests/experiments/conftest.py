"""Fixtures of the sweep and report tests: one small finished sweep of Case 1 A (SUMO's own controller, chosen by sweep_helpers.GRID)."""

from __future__ import annotations

from pathlib import Path

import pytest

from intersection_cosim.cli import main
from sweep_helpers import sweep_args


@pytest.fixture(scope="session")
def reference_sweep(tmp_path_factory) -> Path:
    """An uninterrupted sweep of the 2 x 2 grid with 2 local workers."""
    out = tmp_path_factory.mktemp("reference") / "sweep"
    assert main(sweep_args(out, "--workers", "2")) == 0
    return out
