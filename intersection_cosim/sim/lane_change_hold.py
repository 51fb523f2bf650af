"""No lane change of a taken-over vehicle while its body is in a managed junction, or into a
place beside it that another body takes.

SUMO changes lanes in one step (its default lane-change model has no lateral motion), and it may
do so as soon as a vehicle's front is on the lane after a junction, with its rear still inside:
the rear then jumps a lane width sideways across the paths of the junction's other movements.
SUMO never changes lanes on a junction's internal lanes; this extends that to the whole body for
the vehicles a controller has taken over: from the junction's internal lanes on (SUMO changes
lanes in the very step a vehicle moves onto the next lane) and on the first lane after it, lane
changes are off until the rear is ``LANE_CHANGE_CLEARANCE`` past that lane's start; then the
controlled vehicles' lane-change mode applies again. A lane after a junction shorter than a body
cannot be left with the rear clear; there the hold ends ``LANE_END_ROOM`` before the lane's end,
so a vehicle that must change lanes to follow its route does not stand there for ever.

Invariant: a taken-over vehicle changes lanes only into a place its body reaches without touching
another body. SUMO's own gap check looks along lanes and misses a body that hangs back onto the
target lane from the junction ahead (its front already on an internal lane); the place beside is
therefore checked in the plane (models/bodies.py: :func:`beside_occupied`, with
``LANE_CHANGE_MARGIN`` at both ends and one step's driving of both vehicles). A vehicle whose
place beside is taken on one side keeps its lane-change mode only if its route's lanes lie on the
other side (holding it would lock two vehicles that each wait for the other to move over).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import libsumo
import numpy as np

from intersection_cosim.models.bodies import beside_occupied

LANE_CHANGE_CLEARANCE = 1.0  # [m] past the lane's start the rear must be before a lane change
LANE_END_ROOM = 1.0  # [m] on a lane shorter than a body, the hold ends this far before its end: a
#                      vehicle that must change lanes there to follow its route is not locked
LANE_CHANGE_MARGIN = 1.0  # [m] free space the place beside needs ahead of and behind the body
NO_LANE_CHANGE = 0  # SUMO lane-change mode: no change of its own


@dataclass
class LaneChangeHold:
    """Which vehicles have their lane changes held, for one run."""

    exit_lanes: Mapping[str, float]  # [m] the first lane after each managed junction (the paths' exit
    #                                  lanes) and its length
    inside_lanes: frozenset[str]  # the managed junctions' internal lanes (the hold starts there: SUMO
    #                               changes lanes in the very step a vehicle moves onto the next lane)
    mode: int  # [-] the lane-change mode a controlled vehicle has outside the hold
    step_length: float = 0.1  # [s] SUMO's step: how far both vehicles drive before a change
    held: set[str] = field(default_factory=set)
    _lanes: dict[str, tuple[int, int, float]] = field(default_factory=dict)  # lane -> index, count, width [m]
    _route_side: dict[tuple[str, str], int] = field(default_factory=dict)  # (vehicle, lane) -> side of its route's lanes

    def update(self, api, states, bodies, controlled) -> None:
        """Hold or free each vehicle of ``controlled`` (ids ever taken over): ``states`` as read
        this step (SUMO subscription results), ``bodies`` per vehicle (length, width [m] first)."""
        hold, free = set(), []
        for vid in controlled:
            st = states.get(vid)
            if st is None:
                continue
            lane = st[libsumo.VAR_LANE_ID]
            length = self.exit_lanes.get(lane)  # [m]
            if lane in self.inside_lanes or (length is not None and st[libsumo.VAR_LANEPOSITION] < min(
                    bodies[vid][0] + LANE_CHANGE_CLEARANCE, length - LANE_END_ROOM)):
                hold.add(vid)
            elif not lane.startswith(":"):
                free.append(vid)
        hold |= self._beside_taken(api, states, bodies, free)
        for vid in hold - self.held:
            api.vehicle.setLaneChangeMode(vid, NO_LANE_CHANGE)
        for vid in self.held - hold:
            if vid in states:
                api.vehicle.setLaneChangeMode(vid, self.mode)
        self.held = hold

    def _lane(self, api, lane: str) -> tuple[int, int, float]:
        """(index, number of lanes of its edge, width [m]) of ``lane``, read once."""
        if lane not in self._lanes:
            edge, index = lane.rsplit("_", 1)
            self._lanes[lane] = (int(index), api.edge.getLaneNumber(edge), api.lane.getWidth(lane))
        return self._lanes[lane]

    def _beside_taken(self, api, states, bodies, free: list[str]) -> set[str]:
        """The vehicles of ``free`` that must not change lanes this step: the place beside them
        on a side with a lane is taken, and their route does not lead only to the other side."""
        sides = []  # (row of the vehicle, index into free, shift [m]: left positive)
        for k, vid in enumerate(free):
            index, count, width = self._lane(api, states[vid][libsumo.VAR_LANE_ID])
            sides += [(k, width)] if index < count - 1 else []
            sides += [(k, -width)] if index > 0 else []
        if not sides:
            return set()
        ids = list(states)
        row = {vid: r for r, vid in enumerate(ids)}
        pos = np.array([states[v][libsumo.VAR_POSITION] for v in ids], float).reshape(len(ids), 2)
        heading = np.radians(90.0 - np.array([states[v][libsumo.VAR_ANGLE] for v in ids], float))
        speed = np.array([states[v][libsumo.VAR_SPEED] for v in ids], float)
        body = np.array([bodies[v][:2] for v in ids], float).reshape(len(ids), 2)
        who = np.array([row[free[k]] for k, _ in sides], np.intp)
        shift = np.array([s for _, s in sides], float)
        taken = beside_occupied(pos[:, 0], pos[:, 1], heading, body[:, 0], body[:, 1], speed, who, shift,
                                LANE_CHANGE_MARGIN, self.step_length)
        blocked: dict[str, set[int]] = {}
        for (k, s), t in zip(sides, taken):
            if t:
                blocked.setdefault(free[k], set()).add(1 if s > 0 else -1)
        return {vid for vid, dirs in blocked.items()
                if not self._wants_other_only(api, vid, states[vid][libsumo.VAR_LANE_ID], dirs)}

    def _wants_other_only(self, api, vid: str, lane: str, blocked: set[int]) -> bool:
        """Whether the lanes of ``vid``'s route lie only to a side not in ``blocked`` (1 left, -1
        right) of ``lane``: SUMO's best-lane offset, read once per vehicle and lane."""
        key = (vid, lane)
        if key not in self._route_side:
            offset = next((best[3] for best in api.vehicle.getBestLanes(vid) if best[0] == lane), 0)
            self._route_side[key] = int(np.sign(offset))
        side = self._route_side[key]
        return side != 0 and side not in blocked
