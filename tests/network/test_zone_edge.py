"""A crossing zone's sampled start may lie up to ZONE_RESOLUTION past where two bodies first touch;
a vehicle held at a zone's edge stops EDGE_CLEARANCE before it, clear of every body on the other
path (on 3 x 3 grid_high a vehicle held 0.05 m before its zone stood touching the side of a car
that passed in front of it)."""

import numpy as np
import pytest

from intersection_cosim.control.safety.context import EDGE_CLEARANCE
from intersection_cosim.models.bodies import bodies_overlap, body_corners
from intersection_cosim.network.conflict_zones import ZONE_RESOLUTION
from intersection_cosim.network.conflicts import KIND_CROSS

LENGTH, WIDTH = 4.5, 1.8  # [m] the conflict table's own body


def _bodies(path, fronts):
    """The rectangles of bodies on ``path`` with their fronts at ``fronts`` [m], headed as SUMO
    heads them (rear to front along the centre line)."""
    fronts = np.atleast_1d(np.asarray(fronts, float))
    xy, rear = path.point_at(fronts), path.point_at(fronts - LENGTH)
    heading = np.arctan2(xy[:, 1] - rear[:, 1], xy[:, 0] - rear[:, 0])
    n = len(fronts)
    return body_corners(xy[:, 0], xy[:, 1], heading, np.full(n, LENGTH), np.full(n, WIDTH))


def _touching(table, back):
    """The cross pairs (p, q) whose body on p, its front ``back`` [m] before its zone, overlaps a
    body anywhere on q's way through the junction."""
    found = []
    for p, q in np.argwhere(table.kind == KIND_CROSS):
        a, b = table.paths[table.ids[p]], table.paths[table.ids[q]]
        others = _bodies(b, np.arange(b.s_stop - 0.25, min(b.s_exit + LENGTH, b.length), 0.05))
        if bodies_overlap(_bodies(a, float(table.zone_in[p, q]) - back), others).any():
            found.append((table.ids[p], table.ids[q]))
    return found


def test_a_body_held_edge_clearance_before_its_zone_touches_nothing_on_the_other_path(conflict_table):
    """On the default net no body stopped EDGE_CLEARANCE before its zone overlaps one on the
    other path; 0.05 m before (the edge target until now) some do."""
    assert EDGE_CLEARANCE > ZONE_RESOLUTION
    assert _touching(conflict_table, EDGE_CLEARANCE) == []
    assert len(_touching(conflict_table, 0.05)) >= 1


def test_a_vehicle_that_can_only_stop_at_the_edge_stops_edge_clearance_before_it(paths, movements, conflict_table):
    """A vehicle in the junction too fast to stop ``margin`` before a zone but able to stop before
    its edge is held to stop EDGE_CLEARANCE before the zone's start."""
    from intersection_cosim.control.safety.context import GuardedJunction, StepContext
    from intersection_cosim.control.safety.settings import SafetySettings
    from intersection_cosim.games.settings import ProblemSettings
    from intersection_cosim.models.settings import ModelSettings
    from tests.control.conftest import make_world

    t = conflict_table
    p, q = np.argwhere(t.kind == KIND_CROSS)[0]
    pid, enter = t.ids[p], float(t.zone_in[p, q])
    problem, gs = ProblemSettings(), SafetySettings()
    v = 4.0  # [m/s]
    s = enter - 0.5 - v * v / (2.0 * -problem.a_min)  # [m] it can stop 0.5 m before, not 1 m
    world = make_world(paths, 0.0, [("A", pid, s, v)])
    junction = GuardedJunction(gs, problem, ModelSettings(), movements, t.s_stop, np.full(len(t.s_stop), np.inf),
                               {}, 0.1, 0.0)
    ctx = StepContext(junction, world, None, {}, {}, {}, None, None, frozenset(), {})
    a = ctx.stop_short_of(0, float(t.s_stop[p]), enter, gs.margin)
    assert a is not None
    stop = s + v * v / (2.0 * -a)  # [m]
    assert stop == pytest.approx(enter - EDGE_CLEARANCE, abs=1e-6)
