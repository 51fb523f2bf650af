"""The onboard guard of :mod:`~intersection_cosim.control.safety.onboard`, sensed in SUMO.

Every SUMO step the adapter asks SUMO for the nearest vehicle ahead of each commanded vehicle
(``vehicle.getLeader``: along the vehicle's own lanes and the lanes it drives next, through
junctions, within the sensor range), whatever drives that vehicle, and caps the speed command by
:func:`~intersection_cosim.control.safety.onboard.guard_speed`. SUMO measures the leader's
distance from the vehicle's front plus its minGap to the leader's rear; the guard adds the minGap
back, so its gap is bumper to bumper.

It then holds the vehicle out of a crossing inside the next junction that a road user no controller
commands is driving through (:mod:`~intersection_cosim.control.safety.crossing_sense`: SUMO's
internal foe lanes of the vehicle's lanes there, their centre lines' crossing points, the road users
on them).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import ModuleType
from typing import Collection, Mapping

import libsumo

from intersection_cosim.control.safety.crossing_sense import (Crossing, clearance, crossing, ego_occupation,
                                                              foe_occupation, overlaps)
from intersection_cosim.control.safety.onboard import OnboardSettings, guard_speed

Body = tuple[float, float, float, float, float]  # length [m], width [m], accel, decel, emergency decel [m/s^2]


@dataclass
class OnboardGuard:
    """The guard of every commanded vehicle; ``caps`` counts the SUMO steps x vehicles in which
    it lowered a command."""

    api: ModuleType  # libsumo or traci
    settings: OnboardSettings
    step_length: float  # [s] the guard's reaction time: one SUMO step
    caps: int = 0  # [-]
    crossing_caps: int = 0  # [-] of them: held out of a crossing (crossing_sense.py)
    _lanes: dict = field(default_factory=dict)  # lane id -> (length [m], shape, internal foes, links)
    _crossings: dict = field(default_factory=dict)  # (lane, foe lane) -> Crossing | None
    _on_lane: dict = field(default_factory=dict)  # this step's vehicles per foe lane
    _top: dict = field(default_factory=dict)  # vehicle -> its top speed [m/s]

    def begin_step(self) -> None:
        """Forget the road users on the lanes read in the previous SUMO step."""
        self._on_lane.clear()

    def speed(self, vid: str, v: float, target: float, states: Mapping[str, dict], bodies: Mapping[str, Body],
              min_gaps: Mapping[str, float], commanded: Collection[str] = (), tracked: Collection[str] = ()) -> float:
        """[m/s] the speed vehicle ``vid`` at ``v`` [m/s], commanded to ``target`` [m/s], drives
        over the next SUMO step: ``target`` held out of a crossing a road user that no controller
        commands (``commanded``) or tracks (``tracked``: on a managed movement path, whose
        crossings the safety filter orders) is driving through or approaching with the right of way,
        then capped behind the vehicle ahead (``states``: each vehicle's subscription results as
        last read, ``bodies`` per vehicle as read at departure, ``min_gaps`` [m] SUMO's minGap
        per vehicle)."""
        asked = target  # [m/s]
        if self.settings.crossing:
            target = self._crossing_speed(vid, v, target, states, bodies, commanded, tracked)
            self.crossing_caps += target < asked
        lead = self.api.vehicle.getLeader(vid, self.settings.sensor_range)
        if not lead or not lead[0]:
            self.caps += target < asked
            return target
        lid, dist = lead
        own, other = bodies[vid], bodies.get(lid)
        v_lead = states[lid][libsumo.VAR_SPEED] if lid in states else self.api.vehicle.getSpeed(lid)  # [m/s]
        lead_decel = other[3] if other is not None else self.api.vehicle.getDecel(lid)  # [m/s^2]
        gap = dist + min_gaps.get(vid, 0.0)  # [m] bumper to bumper
        capped = guard_speed(v, target, gap, v_lead, own[3], lead_decel, max(own[4], own[3]), self.step_length,
                             self.settings.margin)
        self.caps += capped < asked
        return capped

    def _lane(self, lane: str) -> tuple:
        """(length [m], centre line, internal foe lanes, links) of ``lane``, read once."""
        if lane not in self._lanes:
            api = self.api.lane
            foes = api.getInternalFoes(lane) if lane.startswith(":") else ()
            self._lanes[lane] = (api.getLength(lane), api.getShape(lane), foes, api.getLinks(lane))
        return self._lanes[lane]

    def _crossing(self, lane: str, foe: str) -> Crossing | None:
        key = (lane, foe)
        if key not in self._crossings:
            self._crossings[key] = crossing(list(self._lane(lane)[1]), list(self._lane(foe)[1]))
        return self._crossings[key]

    def junction_lanes(self, vid: str, reach: float) -> list[tuple[str, float]]:
        """The lanes inside the next junction on ``vid``'s route, each with the distance [m] from
        its front to the lane's start (negative: it is on it); none if the junction is farther
        than ``reach`` [m]."""
        veh = self.api.vehicle
        lane, pos = veh.getLaneID(vid), veh.getLanePosition(vid)
        if lane.startswith(":"):
            chain = [(lane, -pos)]
        else:
            links = veh.getNextLinks(vid)
            start = self._lane(lane)[0] - pos  # [m]
            if not links or not links[0][4] or start > reach:
                return []
            chain = [(links[0][4], start)]
        while len(chain) < 8:
            last, start = chain[-1]
            via = [link[4] for link in self._lane(last)[3] if link[4]]
            if not via:
                break
            chain.append((via[0], start + self._lane(last)[0]))
        return chain

    def _crossing_speed(self, vid: str, v: float, target: float, states: Mapping[str, dict],
                        bodies: Mapping[str, Body], commanded: Collection[str], tracked: Collection[str]) -> float:
        """``target`` held so that ``vid`` stops before a crossing that a road user no controller
        commands is driving through, or approaching with the right of way over ``vid``
        (control/safety/crossing_sense.py)."""
        own = bodies[vid]
        s = self.settings
        reach = v * v / (2.0 * own[3]) + v * s.crossing_buffer + s.crossing_lookahead  # [m]
        chain = dict(self.junction_lanes(vid, reach))
        if not chain:
            return target
        foes = [f for f in self.api.vehicle.getJunctionFoes(vid, reach) if f[0] not in commanded and f[0] not in tracked]
        waits = {f[0] for f in foes if f[8]}  # SUMO's right of way: they must let vid pass
        gaps = [self._inside(vid, v, lane, start, foe, other, states, bodies, other in waits)
                for lane, start in chain.items() for foe in self._lane(lane)[2]
                for other in self._vehicles_on(foe) if other != vid and other not in commanded and other not in tracked]
        gaps += [self._approaching(vid, v, chain, f, states, bodies) for f in foes if f[7]]  # vid must let them pass
        for gap in gaps:
            if gap is None:
                continue
            capped = guard_speed(v, target, gap, 0.0, own[3], own[3], max(own[4], own[3]), self.step_length, s.margin)
            target = min(target, capped)
        return target

    def _vehicles_on(self, lane: str) -> tuple[str, ...]:
        if lane not in self._on_lane:
            self._on_lane[lane] = self.api.lane.getLastStepVehicleIDs(lane)
        return self._on_lane[lane]

    def _body(self, vid: str, bodies: Mapping[str, Body]) -> tuple:
        """(length [m], width [m], accel [m/s^2], ...) of a road user, as read at departure."""
        return bodies.get(vid) or (self.api.vehicle.getLength(vid), self.api.vehicle.getWidth(vid),
                                   self.api.vehicle.getAccel(vid))

    def _max_speed(self, vid: str) -> float:
        """[m/s] the road user's own top speed (its vType's), read once."""
        if vid not in self._top:
            self._top[vid] = self.api.vehicle.getMaxSpeed(vid)
        return self._top[vid]

    def _inside(self, vid: str, v: float, lane: str, start: float, foe: str, other: str,
                states: Mapping[str, dict], bodies: Mapping[str, Body], waits: bool) -> float | None:
        """:meth:`_yield_gap` for ``other`` on the internal lane ``foe`` whose centre line crosses
        ``lane``, which starts ``start`` [m] ahead of ``vid``'s front (``waits``: SUMO has it
        yield to ``vid``, so standing it stays)."""
        cr = self._crossing(lane, foe)
        if cr is None:
            return None
        own, body = bodies[vid], self._body(other, bodies)
        c = clearance(own[1], body[1], cr.angle)  # [m]
        pos = self.api.vehicle.getLanePosition(other)  # [m] its front on the foe lane
        return self._yield_gap(vid, v, start + cr.s_ego - c, 2.0 * c + own[0], other, cr.s_foe - c - pos,
                               cr.s_foe + c + body[0] - pos, states, bodies, waits)

    def _to_lane_start(self, vid: str, lane: str) -> float | None:
        """[m] from ``vid``'s front to the start of ``lane`` (negative: on it), if it is on it or on
        a normal lane just before it; None otherwise."""
        on, pos = self.api.vehicle.getLaneID(vid), self.api.vehicle.getLanePosition(vid)
        if on == lane:
            return -pos
        return None if on.startswith(":") else self._lane(on)[0] - pos

    def _approaching(self, vid: str, v: float, chain: Mapping[str, float], foe: tuple, states: Mapping[str, dict],
                     bodies: Mapping[str, Body]) -> float | None:
        """:meth:`_yield_gap` for a junction foe of SUMO's (``vehicle.getJunctionFoes``: id,
        distances [m] of both to the conflict's entry and exit, both lanes, ...), whose conflict
        area is widened to the bodies' where the centre lines cross."""
        other, ego_dist, foe_dist, ego_exit, foe_exit, ego_lane, foe_lane = foe[:7]
        own, body = bodies[vid], self._body(other, bodies)
        entry, leave = ego_dist, ego_exit + own[0]  # [m] vid's front reaching it, rear leaving it
        f_entry, f_leave = foe_dist, foe_exit + body[0]  # [m] the foe's
        cr = self._crossing(ego_lane, foe_lane) if ego_lane in chain else None
        if cr is not None:
            c = clearance(own[1], body[1], cr.angle)  # [m]
            entry = min(entry, chain[ego_lane] + cr.s_ego - c)
            leave = max(leave, chain[ego_lane] + cr.s_ego + c + own[0])
            start = self._to_lane_start(other, foe_lane)
            if start is not None:
                f_entry = min(f_entry, start + cr.s_foe - c)
                f_leave = max(f_leave, start + cr.s_foe + c + body[0])
        return self._yield_gap(vid, v, entry, leave - entry, other, f_entry, f_leave, states, bodies)

    def _yield_gap(self, vid: str, v: float, to_entry: float, through: float, other: str, foe_to_entry: float,
                   foe_to_exit: float, states: Mapping[str, dict], bodies: Mapping[str, Body],
                   waits: bool = False) -> float | None:
        """[m] ``to_entry``, the distance from ``vid``'s front to a crossing's entry, if ``vid``
        must stop before it for ``other`` (whose front is ``foe_to_entry`` [m] from it and whose
        rear leaves it after ``foe_to_exit`` [m]); None if their occupations do not overlap or
        ``vid`` can no longer stop before it (``through`` [m]: from the entry until its rear leaves;
        ``waits``: a standing ``other`` that SUMO has yield to ``vid`` is taken to stay)."""
        own = bodies[vid]
        hardest = max(own[4], own[3])  # [m/s^2]
        if to_entry < v * v / (2.0 * hardest):
            return None  # it cannot stop before the crossing any more: it is committed too
        v_other = states[other][libsumo.VAR_SPEED] if other in states else self.api.vehicle.getSpeed(other)
        accel = 0.0 if waits and v_other < 0.1 else self._body(other, bodies)[2]  # [m/s^2]
        theirs = foe_occupation(foe_to_entry, foe_to_exit, v_other, accel, self._max_speed(other))
        mine = ego_occupation(to_entry, through, v, own[2], self.settings.crossing_speed)
        return to_entry if overlaps(mine, theirs, self.settings.crossing_buffer) else None
