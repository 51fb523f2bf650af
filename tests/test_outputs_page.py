"""docs/outputs.md names every file a run, a sweep and a comparison write, and every column."""

from __future__ import annotations

import re
from pathlib import Path

from intersection_cosim.experiments.compare import COLUMNS as COMPARISON_COLUMNS
from intersection_cosim.results import layout
from intersection_cosim.results.metrics import PAIR_COLUMNS, VEHICLE_COLUMNS
from intersection_cosim.results.overlaps import OVERLAP_COLUMNS

PAGE = (Path(__file__).resolve().parents[1] / "docs" / "outputs.md").read_text()
NAMED = set(re.findall(r"`([^`\s]+)`", PAGE))


def test_every_file_is_on_the_page():
    files = {getattr(layout, name) for name in dir(layout) if name.endswith("_FILE")}
    assert files and files <= NAMED, sorted(files - NAMED)


def test_every_column_is_on_the_page():
    tables = {"trajectories.csv": layout.TRAJECTORY_COLUMNS, "steps.csv": layout.STEP_COLUMNS,
              "convergence.csv": layout.CONVERGENCE_COLUMNS, "games.csv": layout.GAME_COLUMNS,
              "walkers.csv": layout.WALKER_COLUMNS, "collisions.csv": layout.COLLISION_LOG_COLUMNS,
              "overlaps.csv": OVERLAP_COLUMNS, "vehicles.csv": VEHICLE_COLUMNS, "pairs.csv": PAIR_COLUMNS,
              "comparison.csv": COMPARISON_COLUMNS}
    for table, columns in tables.items():
        # a column is named alone (`speed`) or in a group of a table row (`x`, `y`)
        missing = [c for c in columns if c not in NAMED]
        assert not missing, f"{table}: {missing} not on docs/outputs.md"
