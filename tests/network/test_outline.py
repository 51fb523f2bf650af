"""The net's drawable outline read with sumolib (lanes, junction, internal lanes)."""

import numpy as np
import pytest

from intersection_cosim.network.outline import lane_polygon, read_outline


def test_outline_has_every_lane_and_the_junction_in_the_paper_frame(net_file):
    outline = read_outline(net_file)
    assert len(outline.lanes) == 24  # 4 arms x (3 in + 3 out)
    assert len(outline.internal) > 12  # at least one internal lane per incoming lane
    points = np.vstack(outline.lanes)
    assert points.min(axis=0) == pytest.approx([-150.0, -150.0], abs=0.01)
    assert points.max(axis=0) == pytest.approx([150.0, 150.0], abs=0.01)
    centre = [j for j in outline.junctions if (np.abs(j) < 20).all()]
    assert len(centre) == 1 and np.ptp(centre[0], axis=0) == pytest.approx([24.0, 24.0], abs=0.5)


def test_lane_polygon_is_width_wide_around_the_centre_line():
    poly = lane_polygon(np.array([[0.0, 0.0], [10.0, 0.0]]), 3.2)
    assert np.allclose(poly, [[0.0, 1.6], [10.0, 1.6], [10.0, -1.6], [0.0, -1.6]])
