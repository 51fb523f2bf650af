"""``sumo``: SUMO's own driver model and right of way, the baseline every controller is compared to.

It commands nothing; SUMO's car-following model (Krauss) and the junction logic of the net's
junction type resolve the conflicts.
"""

from __future__ import annotations

from dataclasses import dataclass

from intersection_cosim.control.base import ControlContext, Decisions, Diagnostics, World


@dataclass
class SumoController:
    junction_type: str = "priority"
    controls_vehicles: bool = False
    yields_to_pedestrians: bool = True  # SUMO's drivers

    def setup(self, context: ControlContext) -> None:
        self.context = context

    def decide(self, world: World, deadline: float) -> Decisions:
        return Decisions()

    def fallback(self, world: World) -> Decisions:
        return Decisions(fallback=True)

    def diagnostics(self) -> Diagnostics:
        """SUMO drives: no games, no safety filter."""
        return Diagnostics()
