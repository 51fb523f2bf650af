"""The ``[controller.signals]`` table of the signal baselines (``sumo-actuated``, ``max-pressure``)."""

from __future__ import annotations

from dataclasses import dataclass

from intersection_cosim.settings import positive


@dataclass(frozen=True)
class SignalSettings:
    """Timing of the signal baselines. Actuated: SUMO's defaults (netconvert's tls.min-dur 5 s and
    tls.max-dur 50 s, the actuated programme's max-gap 3 s and detector-gap 2 s). Max-pressure:
    sumo-rl's defaults (a choice every delta_time 5 s, min_green 5 s) with a 3 s yellow."""

    min_green: float = 5.0  # [s] shortest green (actuated: where the net gives no minDur)
    max_green: float = 50.0  # [s] actuated: longest green where the net gives no maxDur
    max_gap: float = 3.0  # [s] actuated: a green ends once the gap between vehicles at its detectors exceeds this
    detector_gap: float = 2.0  # [s] actuated: SUMO places its detectors this far (in driving time) before the stop line
    decision_interval: float = 5.0  # [s] max-pressure: time between two phase choices
    yellow: float = 3.0  # [s] max-pressure: yellow shown to links losing their green at a change

    def check(self) -> list[tuple[str, str]]:
        problems = positive(self, "min_green", "max_green", "max_gap", "detector_gap", "decision_interval", "yellow")
        if self.max_green < self.min_green:
            problems.append(("max_green", "must be >= min_green"))
        return problems
