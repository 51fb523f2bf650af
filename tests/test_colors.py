"""The kappa colour scale shared by the live GUI and the animation."""

import pytest

from intersection_cosim.colors import GAME, KAPPA_STOPS, UNCONTROLLED, kappa_color


def test_kappa_scale_runs_blue_to_red_through_its_stops():
    assert kappa_color(0.0) == (40, 90, 210)
    assert kappa_color(0.5) == (150, 60, 170)
    assert kappa_color(1.0) == (215, 30, 30)
    assert kappa_color(0.25) == (95, 75, 190)  # halfway between the first two stops
    assert [kappa_color(k) for k, _ in KAPPA_STOPS] == [c for _, c in KAPPA_STOPS]


@pytest.mark.parametrize("kappa, clipped", [(-0.3, 0.0), (1.7, 1.0)])
def test_kappa_outside_its_range_is_clipped(kappa, clipped):
    assert kappa_color(kappa) == kappa_color(clipped)


def test_red_grows_and_blue_falls_with_kappa_and_no_kappa_looks_grey_or_amber():
    colours = [kappa_color(k / 20) for k in range(21)]
    assert all(a[0] <= b[0] and a[2] >= b[2] for a, b in zip(colours, colours[1:]))
    assert UNCONTROLLED not in colours and GAME not in colours
