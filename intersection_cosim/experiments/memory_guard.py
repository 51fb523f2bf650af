"""A closed-loop run's memory bound: end the run before the machine runs out.

SUMO's SSM device (our independent TTC / PET measurement) keeps every encounter of two vehicles
within its range, step by step, until they part; in a queue that never clears this grows without
bound: at bench_scale's 9000 veh/h demand the process held 0.3 GB after 50 s and 1.85 GB after
230 s simulated, at 12000 veh/h 3.7 GB after two minutes of wall time, and a gridlocked 600 s compare run 24 GB. Past
``memory_limit`` GB of peak resident memory the run ends (the vehicles still in the network
count as not arrived) and summary.json's ``ended_early`` says so, instead of the operating
system killing the run and, with it, everything it measured.

The peak is read at most once per ``CHECK_INTERVAL`` of simulated time: inside a running
co-simulation ``getrusage`` takes 1-4 ms (against well under 0.1 ms in an idle process), as much
as SUMO's own step, and memory grows over minutes, not within a second.
"""

from __future__ import annotations

import sys
from typing import NamedTuple

try:
    import resource
except ImportError:  # Windows: no getrusage, no guard
    resource = None

_KB_PER_GB = 1024.0 * 1024.0
# ru_maxrss is in bytes on macOS, in kilobytes on Linux
_MAXRSS_UNIT_GB = 1.0 / (1024.0 * _KB_PER_GB) if sys.platform == "darwin" else 1.0 / _KB_PER_GB
CHECK_INTERVAL = 1.0  # [s] simulated time between two reads of the peak (module docstring)


def peak_memory_gb() -> float | None:
    """[GB] this process's peak resident memory so far, None where the platform does not say."""
    if resource is None:
        return None
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * _MAXRSS_UNIT_GB


class MemoryLimit(NamedTuple):
    """The run ended at ``time`` [s] with ``peak_gb`` [GB] of peak resident memory, over ``limit_gb``."""

    time: float
    peak_gb: float
    limit_gb: float
    reason: str = "memory"

    def message(self) -> str:
        return (f"t={self.time:.1f} s: the run holds {self.peak_gb:.1f} GB, over scenario.memory_limit "
                f"({self.limit_gb:g} GB; SUMO's SSM device grows with long queues); the run ends here")


class MemoryGuard:
    """Ends a run past ``limit_gb`` [GB] of peak resident memory (module docstring); 0: never."""

    def __init__(self, limit_gb: float, interval: float = CHECK_INTERVAL):
        self.limit_gb = float(limit_gb)
        self.interval = float(interval)  # [s] simulated time between two reads of the peak
        self._next = -float("inf")  # [s] simulated time of the next read: the first call reads

    def check(self, time: float, sim) -> MemoryLimit | None:
        """The limit reached at ``time`` [s], or None (``sim`` is not needed: the process's own
        memory). Reads the peak only once per ``interval`` of simulated time."""
        if self.limit_gb <= 0.0 or time < self._next:
            return None
        self._next = time + self.interval
        peak = peak_memory_gb()
        if peak is None or peak <= self.limit_gb:
            return None
        return MemoryLimit(float(time), round(peak, 3), self.limit_gb)
