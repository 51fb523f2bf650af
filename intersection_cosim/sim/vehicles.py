"""What the simulator adapter knows of each vehicle it tracks, fixed when it departs."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class VehicleInfo:
    """Static facts about a vehicle the adapter tracks."""

    approach: str
    lane: str  # approach lane name
    movement: str
    kappa: float
    intended_path: str | None  # path id used until the vehicle is in the junction (None: resolved from
    #                            its lane and route when it reaches a managed approach, on any net)
    controlled: bool
    exit_lane: str | None = None  # exit lane to enforce at the junction entry (None: SUMO's)
    exit_fixed: bool = False  # the scenario fixes the exit lane: the controller may not choose
    exit_junction: str | None = None  # the managed junction whose controller chose exit_lane (None:
    #                                   every junction, a scenario's fixed exit); see exit_lane_at
    start_s: float | None = None  # [m] place here on insertion (vehicles that start in the junction)
    desired_speed: float | None = None  # [m/s] its own max speed (also SUMO's, once it drives itself)
    route: frozenset[str] = frozenset()  # edges of its route (to pick its movement at a managed junction)
    driver: str = "av"  # [-] "av" or "human" (a human is never controlled: SUMO's model drives it)
    vtype: str = "av"  # [-] its SUMO vType id (of the run's route file, or the user's own)

    def exit_lane_at(self, junction: str) -> str | None:
        """The exit lane to enforce at managed junction ``junction``: the one chosen for that
        junction (or fixed by the scenario), else None. A choice made at one junction says
        nothing of the next one's lanes, so it is not carried over."""
        if self.exit_junction is None or self.exit_junction == junction:
            return self.exit_lane
        return None
