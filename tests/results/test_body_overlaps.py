"""The geometric collision check on recorded trajectories."""

import math

import pandas as pd

from intersection_cosim.results.metrics import body_overlaps
from intersection_cosim.results.sumo_outputs import read_ssm


def _traj(rows):
    return pd.DataFrame(rows, columns=["time", "vehicle", "x", "y", "heading"])


def test_crossing_bodies_overlap_and_separated_ones_do_not():
    rows = [
        # t=0: A heading east with its front at (0, 0) covers x in [-4.5, 0]; B heading north with
        # its front at (-2, 1.5) covers y in [-3, 1.5] at x = -2: they overlap.
        (0.0, "A", 0.0, 0.0, 0.0), (0.0, "B", -2.0, 1.5, math.pi / 2),
        # t=1: B's rear is 0.5 m beyond A's side (y >= 1.4 vs A's edge at 0.9): clear.
        (1.0, "A", 0.0, 0.0, 0.0), (1.0, "B", -2.0, 5.9, math.pi / 2),
        # t=2: same lane, 0.2 m bumper to bumper: clear; t=3: 0.5 m overlap: caught.
        (2.0, "A", 0.0, 0.0, 0.0), (2.0, "B", -4.7, 0.0, 0.0),
        (3.0, "A", 0.0, 0.0, 0.0), (3.0, "B", -4.0, 0.0, 0.0),
    ]
    assert body_overlaps(_traj(rows), 4.5, 1.8) == [(0.0, "A", "B"), (3.0, "A", "B")]


def test_sumo_sentinel_values_are_not_measurements(tmp_path):
    (tmp_path / "ssm.xml").write_text(
        '<SSMLog><conflict begin="1" end="2" ego="a" foe="b">'
        '<minTTC time="1.5" value="NA"/><PET time="1.8" value="-1.79769e+308"/>'
        '<maxDRAC time="1.6" value="2.5"/></conflict></SSMLog>')
    row = read_ssm(tmp_path / "ssm.xml").iloc[0]
    assert math.isnan(row["min_ttc"]) and math.isnan(row["pet"]) and row["max_drac"] == 2.5
