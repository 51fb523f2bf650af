"""Wall time of SUMO's own steps, for benchmarks that report it next to the controller's."""

from __future__ import annotations

import time
from contextlib import contextmanager
from typing import Iterator

from intersection_cosim.sim.sumo import SumoSimulation


@contextmanager
def sumo_step_timer(times: list[float] | None = None) -> Iterator[list[float]]:
    """While active, append the wall time [ms] of every SUMO step (one
    :meth:`SumoSimulation.advance`: simulationStep plus the subscription read) to the yielded
    list, and the simulation time [s] the step reached to ``times`` when given (same order, so
    a benchmark can take SUMO's steps of the window it measures the controller in); the adapter
    is restored on exit."""
    samples: list[float] = []
    original = SumoSimulation.advance

    def timed_advance(self) -> None:
        t0 = time.perf_counter()
        original(self)
        samples.append((time.perf_counter() - t0) * 1e3)
        if times is not None:
            times.append(float(self.time))

    SumoSimulation.advance = timed_advance
    try:
        yield samples
    finally:
        SumoSimulation.advance = original
