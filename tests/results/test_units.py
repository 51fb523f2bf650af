"""units.csv: every CSV column the package writes has a unit, or is declared without one."""

from __future__ import annotations

import pandas as pd
import pytest

from intersection_cosim.experiments.axes import AXES
from intersection_cosim.experiments.compare import COLUMNS as COMPARISON_COLUMNS
from intersection_cosim.results import layout
from intersection_cosim.results.metrics import PAIR_COLUMNS, VEHICLE_COLUMNS
from intersection_cosim.results.overlaps import OVERLAP_COLUMNS
from intersection_cosim.results.sweep_folder import COUNT_COLUMNS, TIMING_COLUMNS
from intersection_cosim.results.units import UNITLESS, UNITS_FILE, csv_columns, unit_of, units_table, write_units

PHYSICAL = ("s", "ms", "m", "m/s", "m/s^2", "rad", "veh/h")
WRITTEN = {  # file -> its columns, as the writers declare them
    "trajectories.csv": layout.TRAJECTORY_COLUMNS, "steps.csv": layout.STEP_COLUMNS,
    "convergence.csv": layout.CONVERGENCE_COLUMNS, "games.csv": layout.GAME_COLUMNS,
    "walkers.csv": layout.WALKER_COLUMNS, "collisions.csv": layout.COLLISION_LOG_COLUMNS,
    "overlaps.csv": list(OVERLAP_COLUMNS), "vehicles.csv": VEHICLE_COLUMNS, "pairs.csv": PAIR_COLUMNS,
    "comparison.csv": [*COMPARISON_COLUMNS, *AXES],
    "sweep.csv": ["run_id", "controller", "seed", "kappa_V1", "travel_time_V1", "mean_travel_time", "min_ttc_V1_V2",
                  "min_ttc_ssm_V1_V2", "pet_V1_V2", "min_ttc", "min_ttc_ssm", "min_pet", *COUNT_COLUMNS,
                  *TIMING_COLUMNS, "time_min_ttc_ssm", "v2x_messages_sent", "status", "error"],
}


def assert_declared(units: pd.DataFrame) -> None:
    """Every row of a units table has a physical unit or a declared unitless one, and a meaning."""
    bad = units[~units["unit"].isin(PHYSICAL + UNITLESS) | (units["meaning"] == "")]
    assert bad.empty, bad.to_string()


@pytest.mark.parametrize("name", sorted(WRITTEN))
def test_every_written_column_has_a_unit_or_is_declared_unitless(name):
    assert_declared(units_table({name: WRITTEN[name]}))


def test_the_units_the_readme_named_only_in_prose():
    assert unit_of("heading")[0] == "rad" and unit_of("travel_time")[0] == "s" and unit_of("accel_cmd")[0] == "m/s^2"
    assert unit_of("min_ttc_ssm_V1_V2") == ("s", "SSM min TTC of V1_V2") and unit_of("kappa_V2")[0] == "1"
    assert unit_of("no_such_column") is None and unit_of("kappa_") is None


def test_units_csv_states_every_csv_of_a_folder_and_merges(tmp_path):
    pd.DataFrame({"time": [0.1], "heading": [1.0]}).to_csv(tmp_path / "trajectories.csv", index=False)
    pd.DataFrame({"time": [0.1], "compute_ms": [1.0]}).to_csv(tmp_path / "steps.csv.gz", index=False)
    write_units(tmp_path, csv_columns(tmp_path))
    write_units(tmp_path, {"sweep.csv": ["run_id", "mystery"]})
    units = pd.read_csv(tmp_path / UNITS_FILE, keep_default_na=False)
    assert list(units.columns) == ["file", "column", "unit", "meaning"]
    assert units[["file", "column", "unit"]].values.tolist() == [
        ["steps.csv.gz", "time", "s"], ["steps.csv.gz", "compute_ms", "ms"], ["trajectories.csv", "time", "s"],
        ["trajectories.csv", "heading", "rad"], ["sweep.csv", "run_id", "text"], ["sweep.csv", "mystery", "?"]]
