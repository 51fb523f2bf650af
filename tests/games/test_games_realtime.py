"""A real-time Stackelberg iteration: one leader step per control step and the follower's last
answer kept (``stackelberg_max_iter`` 1, ``polish_follower`` off), continued from its own plans
along a receding horizon, tracks the full solve of the same problems with fewer QPs."""

from __future__ import annotations

import dataclasses

import numpy as np

from intersection_cosim.games import shift_plans, stackelberg_equilibrium
from intersection_cosim.games.battery import advance


def test_a_real_time_stackelberg_iteration_tracks_the_full_solve(pair_battery, gs, ms):
    rt = dataclasses.replace(gs, solver=dataclasses.replace(gs.solver, stackelberg_max_iter=1, polish_follower=False))
    gaps, qps_rt, qps_full, statuses = [], 0, 0, set()
    for problem in pair_battery[:8]:
        result = stackelberg_equilibrium(problem, gs, ms)  # a pair's first solve runs in full
        for _ in range(15):  # 1.5 s along the real-time plans
            problem = advance(problem, result.plans)
            warm = shift_plans(result)
            full = stackelberg_equilibrium(problem, gs, ms, warm_start=warm)
            result = stackelberg_equilibrium(problem, rt, ms, warm_start=warm)
            assert result.iterations <= 1 and result.status in ("converged", "iteration cap")
            statuses.add(result.status)
            qps_rt, qps_full = qps_rt + result.qp_count, qps_full + full.qp_count
            gaps.append(max(abs(p.accelerations[0] - q.accelerations[0]) for p, q in zip(result.plans, full.plans)))
    gaps = np.array(gaps)  # [m/s^2] first accelerations, real-time against full
    assert len(gaps) == 120 and float(np.median(gaps)) < 1e-3 and float(gaps.max()) < 0.05
    assert statuses == {"converged", "iteration cap"}  # an unsettled follower is not polished
    assert qps_rt < qps_full
