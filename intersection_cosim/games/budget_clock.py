"""The clock a control step's budget is kept by: the wall clock, or the work clock of an emulated box.

The anytime schedule, the equilibrium solvers' iteration deadlines and the step scheduler's
deadline check all read :func:`now`. By default it is ``time.perf_counter`` [s], so a binding
budget measures the host machine and its load: two runs of one seed can defer different work.
Inside :func:`work_clock` it counts the thread's QP solves since the clock was entered, times
``qp_s``: a box that spends ``qp_s`` [s] per QP solve, all the rest of a step's work included,
so the same budget defers the same work on any machine and a run is the same on every one.
Counting from the entry (once per control step) keeps the clock's values, and the round-off of
their differences, independent of what the process solved before.
"""

from __future__ import annotations

import threading
import time
from contextlib import contextmanager
from typing import Iterator

from intersection_cosim.games.qp import solve_count

_local = threading.local()


def now() -> float:
    """[s] the budget clock of this thread: ``time.perf_counter()``, or inside :func:`work_clock`
    the QPs solved so far times the box's seconds per QP."""
    qp_s = getattr(_local, "qp_s", None)
    return time.perf_counter() if qp_s is None else (solve_count() - _local.base) * qp_s


@contextmanager
def work_clock(qp_s: float | None) -> Iterator[None]:
    """While active, :func:`now` is 0 at entry and advances ``qp_s`` [s] per QP solve of this
    thread; None keeps the wall clock. Restores the clock it found on exit."""
    before = getattr(_local, "qp_s", None), getattr(_local, "base", 0)
    _local.qp_s, _local.base = qp_s, solve_count()
    try:
        yield
    finally:
        _local.qp_s, _local.base = before
