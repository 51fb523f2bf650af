"""The step scheduler of a run with one controller per junction.

Every control step it splits the World by junction (``control.per_junction.PerJunction``) and
runs each junction's controller through its own :class:`~intersection_cosim.sim.scheduler.StepScheduler`:
each junction has the whole budget to itself (``budget_ms`` per junction, so a step of a net of n
junctions may take up to n budgets of wall time, as n boxes side by side would), and a junction
that overruns gets its own fallback while the others keep their decisions. It returns the merged
Decisions and one StepRecord per junction (its ``junction`` column in steps.csv).

A junction with nothing to decide costs nothing: its controller is skipped (a record with
``skipped`` set and no compute) while its sub-World is empty and was empty at its last decided
step too, when the controller has already released every vehicle it had. So a controller must
decide nothing, and change nothing it keeps, on a second empty World in a row (the protocol's
contract, control.base.Controller).
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
        self._idle: set[str] = set()  # junctions whose controller last decided on an empty sub-World

    def step(self, world: World) -> NetworkStep:
        if not self._schedulers:
            self._schedulers = {j: StepScheduler(part, self.budget_ms, work_clock_ms=self.work_clock_ms) for j, part in self.controller.parts.items()}
        worlds = self.controller.split_occupied(world)
        parts, records, pair_junctions = {}, [], []
        for j, scheduler in self._schedulers.items():
            sub = worlds.get(j)
            if sub is None or not len(sub):
                if j in self._idle:
                    records.append(StepRecord(world.time, 0.0, 0, 0, False, False, junction=j, skipped=True))
                    continue
                sub = self._empty(world) if sub is None else sub
                self._idle.add(j)
            else:
                self._idle.discard(j)
            decisions, record = scheduler.step(sub)
            parts[j] = decisions
            records.append(dataclasses.replace(record, junction=j))
            pair_junctions.extend(j for _ in decisions.pairs)
        merged = merge_decisions(parts, worlds, alone=len(self._schedulers) == 1)
        return NetworkStep(merged, records, pair_junctions)

    @staticmethod
    def _empty(world: World) -> World:
        """The sub-World of a junction without any vehicle (``world``'s time, walkers and lane data)."""
        return dataclasses.replace(world.subset([]), guests=())

    def pace(self, sim_time: float) -> None:
        """With ``realtime``, sleep until the wall clock has caught up with ``sim_time`` [s]."""
        self._pacer.pace(sim_time)
