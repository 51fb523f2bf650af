"""The step scheduler of a run with one controller per junction.

Every control step it splits the World by junction (``control.per_junction.PerJunction``) and
runs each junction's controller through its own :class:`~intersection_cosim.sim.scheduler.StepScheduler`:
each junction has the whole budget to itself (``budget_ms`` per junction, so a step of a net of n
junctions may take up to n budgets of wall time, as n boxes side by side would), and a junction
that overruns gets its own fallback while the others keep their decisions. It returns the merged
Decisions and one StepRecord per junction (its ``junction`` column in steps.csv).
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

from intersection_cosim.control.base import Decisions, World
from intersection_cosim.control.per_junction import PerJunction, merge_decisions
from intersection_cosim.sim.scheduler import StepRecord, StepScheduler


class NetworkStep(NamedTuple):
    decisions: Decisions  # every junction's, merged
    records: list[StepRecord]  # one per junction, in the movements' junction order
    pair_junctions: list[str]  # the junction of each of ``decisions.pairs``


class NetworkScheduler:
    """``controller`` must be set up before the first :meth:`step` (its parts exist then)."""

    def __init__(self, controller: PerJunction, budget_ms: float, realtime: bool = False,
                 work_clock_ms: float = 0.0):
        self.controller = controller
        self.budget_ms = budget_ms  # [ms] per junction and control step
        self.work_clock_ms = work_clock_ms  # [ms] per QP solve; 0: the wall clock (sim.scheduler)
        self._pacer = StepScheduler(controller, budget_ms, realtime)
        self._schedulers: dict[str, StepScheduler] = {}

    def step(self, world: World) -> NetworkStep:
        if not self._schedulers:
            self._schedulers = {j: StepScheduler(part, self.budget_ms, work_clock_ms=self.work_clock_ms) for j, part in self.controller.parts.items()}
        worlds = self.controller.split(world)
        parts, records, pair_junctions = {}, [], []
        for j, sub in worlds.items():
            decisions, record = self._schedulers[j].step(sub)
            parts[j] = decisions
            records.append(dataclasses.replace(record, junction=j))
            pair_junctions.extend(j for _ in decisions.pairs)
        return NetworkStep(merge_decisions(parts, worlds), records, pair_junctions)

    def pace(self, sim_time: float) -> None:
        """With ``realtime``, sleep until the wall clock has caught up with ``sim_time`` [s]."""
        self._pacer.pace(sim_time)
