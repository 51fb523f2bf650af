"""The budget clock: the wall clock by default, QP solves times a box's cost on the work clock."""

import time

from intersection_cosim.games import budget_clock, nash_equilibrium, stackelberg_equilibrium
from intersection_cosim.games.problem import Interaction, Player, Problem
from intersection_cosim.games.qp import solve_count

PAIR = Problem((Player(0.0, 5.0, 0.5), Player(0.0, 5.0, 0.5)), (Interaction.cross(0, 1, 15.0, 14.0),))


def test_outside_a_work_clock_it_is_the_wall_clock():
    before, now, after = time.perf_counter(), budget_clock.now(), time.perf_counter()
    assert before <= now <= after


def test_the_work_clock_advances_exactly_its_cost_per_qp_and_is_restored(gs, ms):
    with budget_clock.work_clock(0.002):  # [s] per QP
        t0, q0 = budget_clock.now(), solve_count()
        assert t0 == 0.0  # counted from the entry
        time.sleep(0.02)  # wall time does not move it
        assert budget_clock.now() == t0
        result = nash_equilibrium(PAIR, gs, ms)
        assert result.qp_count == solve_count() - q0 > 0
        assert budget_clock.now() - t0 == 0.002 * result.qp_count
        with budget_clock.work_clock(None):  # nested: back on the wall clock, then restored
            assert abs(budget_clock.now() - time.perf_counter()) < 1.0
        assert budget_clock.now() - t0 == 0.002 * result.qp_count
    assert abs(budget_clock.now() - time.perf_counter()) < 1.0


def test_an_equilibrium_stops_at_a_work_deadline_after_the_same_qps_every_time(gs, ms):
    full = nash_equilibrium(PAIR, gs, ms)
    assert full.status == "converged" and full.iterations >= 2
    for solver in (nash_equilibrium, stackelberg_equilibrium):
        counts = []
        for _ in range(3):
            with budget_clock.work_clock(0.001):
                # room for the first iteration only: the second would pass the deadline
                res = solver(PAIR, gs, ms, deadline=budget_clock.now() + 0.001 * 3)
            assert res.status == "deadline"
            counts.append(res.qp_count)
        assert len(set(counts)) == 1 and counts[0] < full.qp_count
