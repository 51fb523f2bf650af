"""No lane change while a vehicle's body is still in a managed junction.

SUMO changes lanes in one step (its default lane-change model has no lateral motion), and it may
do so as soon as a vehicle's front is on the lane after a junction, with its rear still inside:
the rear then jumps a lane width sideways across the paths of the junction's other movements.
SUMO never changes lanes on a junction's internal lanes; this extends that to the whole body for
the vehicles a controller has taken over: from the junction's internal lanes on (SUMO changes
lanes in the very step a vehicle moves onto the next lane) and on the first lane after it, lane
changes are off until the rear is ``LANE_CHANGE_CLEARANCE`` past that lane's start; then the
controlled vehicles' lane-change mode applies again.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import libsumo

LANE_CHANGE_CLEARANCE = 1.0  # [m] past the lane's start the rear must be before a lane change
NO_LANE_CHANGE = 0  # SUMO lane-change mode: no change of its own


@dataclass
class LaneChangeHold:
    """Which vehicles have their lane changes held, for one run."""

    exit_lanes: frozenset[str]  # the first lane after each managed junction (the paths' exit lanes)
    inside_lanes: frozenset[str]  # the managed junctions' internal lanes (the hold starts there: SUMO
    #                               changes lanes in the very step a vehicle moves onto the next lane)
    mode: int  # [-] the lane-change mode a controlled vehicle has outside the hold
    held: set[str] = field(default_factory=set)

    def update(self, api, states, bodies, controlled) -> None:
        """Hold or free each vehicle of ``controlled`` (ids ever taken over): ``states`` as read
        this step (SUMO subscription results), ``bodies`` per vehicle (length [m] first)."""
        for vid in controlled:
            st = states.get(vid)
            if st is None:
                self.held.discard(vid)
                continue
            lane = st[libsumo.VAR_LANE_ID]
            inside = lane in self.inside_lanes or (
                lane in self.exit_lanes and st[libsumo.VAR_LANEPOSITION] < bodies[vid][0] + LANE_CHANGE_CLEARANCE)
            if inside and vid not in self.held:
                api.vehicle.setLaneChangeMode(vid, NO_LANE_CHANGE)
                self.held.add(vid)
            elif not inside and vid in self.held:
                api.vehicle.setLaneChangeMode(vid, self.mode)
                self.held.discard(vid)
