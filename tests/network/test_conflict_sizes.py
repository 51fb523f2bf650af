"""Conflict zones per pair of size classes (issue 16, vehicle types): a bus crossing a car uses
the bus's and the car's bodies."""

from __future__ import annotations

import pytest

CAR = (4.5, 1.8)  # [m] length, width: the model's body
BUS = (12.0, 2.5)  # [m]
A = "south_middle_straight_middle"  # northbound straight
B = "east_middle_straight_middle"  # westbound straight: crosses A at a right angle


def _span(zone):
    return zone[1] - zone[0]


def test_the_tables_own_body_gives_its_arrays(conflict_table):
    p, q = conflict_table.index[A], conflict_table.index[B]
    assert conflict_table.zone(p, q, CAR, CAR) == (conflict_table.zone_in[p, q], conflict_table.zone_out[p, q])


def test_a_bus_zone_is_longer_than_a_car_zone_by_the_bus_length(conflict_table):
    """On a right-angle crossing the front enters the other's swept strip at the same point
    whatever its own length, and the rear leaves it 7.5 m later for a 12 m bus than for a 4.5 m car."""
    p, q = conflict_table.index[A], conflict_table.index[B]
    car, bus = conflict_table.zone(p, q, CAR, CAR), conflict_table.zone(p, q, BUS, CAR)
    assert bus[0] == pytest.approx(car[0], abs=0.3)  # its width only adds 0.35 m either side of a square crossing
    assert _span(bus) - _span(car) == pytest.approx(BUS[0] - CAR[0], abs=0.6)
    assert bus[1] > car[1] + 7.0


def test_a_car_crossing_a_bus_meets_its_wider_swept_strip(conflict_table):
    """The bus sweeps a strip 0.7 m wider: the car's zone starts about 0.35 m earlier and ends
    about 0.35 m later, so it is longer by about the width difference (within the 0.25 m grid)."""
    p, q = conflict_table.index[A], conflict_table.index[B]
    car, against_bus = conflict_table.zone(p, q, CAR, CAR), conflict_table.zone(p, q, CAR, BUS)
    assert against_bus[0] < car[0]
    assert against_bus[1] > car[1]
    assert _span(against_bus) - _span(car) == pytest.approx(BUS[1] - CAR[1], abs=0.5)


def test_zones_of_other_bodies_are_cached(conflict_table):
    p, q = conflict_table.index[A], conflict_table.index[B]
    first = conflict_table.zone(p, q, BUS, BUS)
    assert conflict_table.zone(p, q, BUS, BUS) is first
    assert _span(first) > _span(conflict_table.zone(p, q, BUS, CAR))  # a wider strip to cross, too


def test_other_bodies_zones_match_the_full_scan(conflict_table, paths):
    """zone() of other bodies scans coarse to fine on a merged swept area; on every sampled
    cross pair it finds the full scan's zone to within one 0.25 m front step."""
    import numpy as np

    from intersection_cosim.network.conflicts import KIND_CODE
    from intersection_cosim.network.conflict_zones import conflict_zone, swept_area

    cross = np.argwhere(conflict_table.kind == KIND_CODE["cross"])
    assert len(cross) > 100
    for p, q in cross[::12]:
        a, b = paths[conflict_table.ids[p]], paths[conflict_table.ids[q]]
        for body_a, body_b in ((BUS, CAR), (CAR, BUS)):
            full = conflict_zone(a, b, *body_a, swept_area(b, *body_b))
            fast = conflict_table.zone(int(p), int(q), body_a, body_b)
            assert full is not None
            assert fast == pytest.approx(full, abs=0.26), (a.id, b.id, body_a, body_b)
