"""Waiting positions inside the junction (MovementPath.s_wait) and what SUMO watches from them."""

import math

from intersection_cosim.network.waiting import waiting_watches


def test_the_inner_left_turns_wait_for_the_opposing_approach_and_nothing_else_waits(paths, movements):
    """On the generated net the inner-lane left turns from the north and the south have a
    waiting position 6.7 m (to the inner exit) or 8.2 m (to the middle one) past their stop line,
    the end of their first internal lane, and its
    internal junction watches the opposing approach's three lanes; no straight or right turn
    waits inside the junction."""
    watches = waiting_watches(movements)
    waiting = {pid for pid, p in paths.items() if math.isfinite(p.s_wait)}
    assert waiting == set(watches) and len(waiting) == 4
    for pid in waiting:
        p = paths[pid]
        assert p.movement == "left" and p.lane == "inner"
        assert 6.0 < p.s_wait - p.s_stop < 10.0
        opposing = {"north": "south", "south": "north"}[p.approach]
        assert watches[pid] == {f"{opposing}_in_{n}" for n in range(3)}
