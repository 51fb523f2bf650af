"""``max-pressure``: the signal baseline of the RL signal-control literature (RESCO, sumo-rl).

Every ``decision_interval`` [s], once the current green has lasted ``min_green`` [s], each
traffic light of the junction shows the green phase of the net's programme with the largest
pressure: over the links that phase gives green, the vehicles on their incoming lanes minus those
on their outgoing lanes (counted among the vehicles the World shows: those on the junction's
paths, within its control range). A change shows ``yellow`` [s] to the links losing their green
first. Ties keep the current green. It commands no vehicle: SUMO's drivers obey the lights.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

from intersection_cosim.control.base import ControlContext, Decisions, Diagnostics, World
from intersection_cosim.control.baselines.signal_settings import SignalSettings
from intersection_cosim.network.signal_programmes import SignalPlan, junction_signals

GREEN = "Gg"  # SUMO's link states that let a vehicle go


@dataclass
class _Light:
    """One traffic light's timing: its green, since when [s], and a change under way."""

    current: int | None = None  # [-] index of the green phase shown (None: not chosen yet)
    since: float = -math.inf  # [s] when the current green began
    next_choice: float = -math.inf  # [s] the next time a phase is chosen
    pending: int | None = None  # [-] the green that follows the yellow being shown
    yellow_end: float = math.inf  # [s] when that yellow ends


def pressure(plan: SignalPlan, green: str, counts: Counter) -> int:
    """[veh] the pressure of phase state ``green``: over its green links, vehicles on the incoming
    lane minus vehicles on the outgoing lane."""
    return sum(counts[plan.links[i][0]] - counts[plan.links[i][1]]
               for i, c in enumerate(green) if c in GREEN and i < len(plan.links))


def yellow_between(current: str, following: str) -> str:
    """The state shown between two greens: 'y' on every link green now and not in ``following``."""
    return "".join("y" if c in GREEN and n not in GREEN else c for c, n in zip(current, following))


@dataclass
class MaxPressureController:
    settings: SignalSettings = field(default_factory=SignalSettings)
    junction_type: str = "traffic_light"
    controls_vehicles: bool = False
    yields_to_pedestrians: bool = True  # SUMO's drivers

    def setup(self, context: ControlContext) -> None:
        self.plans = junction_signals(context.net_file, context.movements.junctions[0])
        self.lights = {plan.tls: _Light() for plan in self.plans}

    def decide(self, world: World, deadline: float) -> Decisions:
        counts = Counter(world.lanes)
        signals = {}
        for plan in self.plans:
            state = self._step(plan, self.lights[plan.tls], world.time, counts)
            if state is not None:
                signals[plan.tls] = state
        return Decisions(signals=signals)

    def _step(self, plan: SignalPlan, light: _Light, time: float, counts: Counter) -> str | None:
        """The state to show now at ``plan``'s light (None: keep what it shows)."""
        s = self.settings
        if light.pending is not None:
            if time < light.yellow_end - 1e-9:
                return None
            light.current, light.pending, light.since = light.pending, None, time
            return plan.greens[light.current]
        if time < light.next_choice - 1e-9 or time - light.since < s.min_green - 1e-9:
            return None
        light.next_choice = time + s.decision_interval
        scores = [pressure(plan, green, counts) for green in plan.greens]
        best = max(range(len(scores)), key=lambda k: (scores[k], k == light.current, -k))
        if light.current is None:
            light.current, light.since = best, time
            return plan.greens[best]
        if best == light.current:
            return None
        light.pending, light.yellow_end = best, time + s.yellow
        return yellow_between(plan.greens[light.current], plan.greens[best])

    def fallback(self, world: World) -> Decisions:
        return Decisions(fallback=True)

    def diagnostics(self) -> Diagnostics:
        """SUMO drives: no games, no safety filter."""
        return Diagnostics()
