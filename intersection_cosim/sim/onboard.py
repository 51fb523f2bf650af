"""The onboard guard of :mod:`~intersection_cosim.control.safety.onboard`, sensed in SUMO.

Every SUMO step the adapter asks SUMO for the nearest vehicle ahead of each commanded vehicle
(``vehicle.getLeader``: along the vehicle's own lanes and the lanes it drives next, through
junctions, within the sensor range), whatever drives that vehicle, and caps the speed command by
:func:`~intersection_cosim.control.safety.onboard.guard_speed`. SUMO measures the leader's
distance from the vehicle's front plus its minGap to the leader's rear; the guard adds the minGap
back, so its gap is bumper to bumper. SUMO's query does not return a vehicle whose front has
turned onto an internal lane the vehicle does not take while its rear is still on the vehicle's
lane (a right turner just past the stop line, ahead of a vehicle going straight from the same
lane); the guard finds those rears itself, on the internal lanes leaving the vehicle's lane.

It then holds the vehicle out of a crossing inside the next junction that a road user no controller
commands is driving through (:mod:`~intersection_cosim.control.safety.crossing_sense`: SUMO's
internal foe lanes of the vehicle's lanes there, their centre lines' crossing points, the road users
on them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import ModuleType
from typing import Collection, Mapping

import libsumo

from intersection_cosim.control.safety.crossing_sense import (Crossing, clearance, crossing, ego_occupation,
                                                              foe_occupation, overlaps)
from intersection_cosim.control.safety.onboard import OnboardSettings, guard_speed

FEED = 100.0  # [m] how far upstream of a crossing a road user with the right of way is looked for
MAX_BODY = 25.0  # [m] the longest body whose rear can trail back over internal lanes onto the lane before
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
    _top: dict = field(default_factory=dict)  # vehicle -> its top speed [m/s]
    _into: dict | None = None  # lane -> the lanes whose links lead onto it (the net read backwards)
    _feed_of: dict = field(default_factory=dict)  # internal lane -> {lane: budget [m]}, see _feed
    _feeders: dict = field(default_factory=dict)  # internal lane -> its foes' feeds merged (_foes_feed)
    # this step: lane -> (road user, its position [m]) for the road users no controller commands or tracks
    _untracked: dict = field(default_factory=dict)
    _untracked_ids: set = field(default_factory=set)  # this step: those road users
    _internal: dict = field(default_factory=dict)  # this step: internal lane -> (vehicle, its position [m])

    def begin_step(self, states: Mapping[str, dict], tracked: Collection[str], commanded: Collection[str]) -> None:
        """This SUMO step's vehicles on internal lanes (whose rears :meth:`_rears_on_lane` looks
        for), and, with the crossing sense on, its road users that no controller commands
        (``commanded``) or tracks (``tracked``: on a managed movement path, whose crossings the
        safety filter orders), by lane; one pass over ``states``."""
        self._untracked, self._internal = {}, {}
        crossing = self.settings.crossing
        for vid, res in states.items():
            lane, pos = res[libsumo.VAR_LANE_ID], res[libsumo.VAR_LANEPOSITION]
            if lane.startswith(":"):
                self._internal.setdefault(lane, []).append((vid, pos))
            if crossing and vid not in tracked and vid not in commanded:
                self._untracked.setdefault(lane, []).append((vid, pos))
        self._untracked_ids = {vid for ids in self._untracked.values() for vid, _ in ids}

    def speed(self, vid: str, v: float, target: float, states: Mapping[str, dict], bodies: Mapping[str, Body],
              min_gaps: Mapping[str, float]) -> float:
        """[m/s] the speed vehicle ``vid`` at ``v`` [m/s], commanded to ``target`` [m/s], drives
        over the next SUMO step: ``target`` held out of a crossing a road user that no controller
        commands or tracks (:meth:`begin_step`) is driving through or approaching with the right of way,
        then capped behind the vehicle ahead (``states``: each vehicle's subscription results as
        last read, ``bodies`` per vehicle as read at departure, ``min_gaps`` [m] SUMO's minGap
        per vehicle)."""
        asked = target  # [m/s]
        if self.settings.crossing:
            target = self._crossing_speed(vid, v, target, states, bodies)
            self.crossing_caps += target < asked
        lead = self.api.vehicle.getLeader(vid, self.settings.sensor_range)
        ahead = [(lead[0], lead[1] + min_gaps.get(vid, 0.0))] if lead and lead[0] else []  # [m] bumper to bumper
        ahead += self._rears_on_lane(vid, states, bodies)
        if not ahead:
            self.caps += target < asked
            return target
        lid, gap = min(ahead, key=lambda a: a[1])
        own, other = bodies[vid], bodies.get(lid)
        v_lead = states[lid][libsumo.VAR_SPEED] if lid in states else self.api.vehicle.getSpeed(lid)  # [m/s]
        lead_decel = other[3] if other is not None else self.api.vehicle.getDecel(lid)  # [m/s^2]
        capped = guard_speed(v, target, gap, v_lead, own[3], lead_decel, max(own[4], own[3]), self.step_length,
                             self.settings.margin)
        self.caps += capped < asked
        return capped

    def _rears_on_lane(self, vid: str, states: Mapping[str, dict], bodies: Mapping[str, Body]) -> list[tuple[str, float]]:
        """(vehicle, gap [m] bumper to bumper) of each vehicle whose front is on an internal lane
        leaving ``vid``'s lane (or on the internal lane after it) while its rear is still on
        ``vid``'s lane, ahead of ``vid``: SUMO's leader query misses one that turns where ``vid``
        goes on."""
        lane, pos = states[vid][libsumo.VAR_LANE_ID], states[vid][libsumo.VAR_LANEPOSITION]
        to_end = self._lane(lane)[0] - pos  # [m] from vid's front to its lane's end
        out, frontier = [], [(link[4], 0.0) for link in self._lane(lane)[3] if link[4]]
        while frontier:
            via, start = frontier.pop()  # start [m]: where the internal lane begins, past the lane's end
            for uid, upos in self._internal.get(via, ()):
                rear = start + upos - (bodies[uid][0] if uid in bodies else self.api.vehicle.getLength(uid))
                if uid != vid and rear < 0.0:  # [m] its rear still on vid's lane
                    out.append((uid, to_end + rear))
            length = self._lane(via)[0]
            if start + length < MAX_BODY:  # a body this long may reach back over this internal lane
                frontier += [(link[4], start + length) for link in self._lane(via)[3] if link[4]]
        return out

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

    def junction_lanes(self, vid: str, lane: str, pos: float, reach: float) -> list[tuple[str, float]]:
        """The lanes inside the next junction on ``vid``'s route (it is at ``pos`` [m] on
        ``lane``), each with the distance [m] from its front to the lane's start (negative: it is
        on it); none if the junction is farther than ``reach`` [m]."""
        if lane.startswith(":"):
            chain = [(lane, -pos)]
        else:
            start = self._lane(lane)[0] - pos  # [m]
            if start > reach:
                return []
            links = self.api.vehicle.getNextLinks(vid)
            if not links or not links[0][4]:
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
                        bodies: Mapping[str, Body]) -> float:
        """``target`` held so that ``vid`` stops before a crossing that a road user no controller
        commands is driving through, or approaching with the right of way over ``vid``
        (control/safety/crossing_sense.py)."""
        own = bodies[vid]
        s = self.settings
        reach = v * v / (2.0 * own[3]) + v * s.crossing_buffer + s.crossing_lookahead  # [m]
        chain = dict(self.junction_lanes(vid, states[vid][libsumo.VAR_LANE_ID], states[vid][libsumo.VAR_LANEPOSITION],
                                         reach))
        near = self._untracked
        if not chain or not any(self._lane(f)[0] - pos <= budget for lane in chain
                                for f, budget in self._foes_feed(lane).items() for _, pos in near.get(f, ())):
            return target  # nobody untracked inside or on the way in: the common case, no more queries
        foes = [f for f in self.api.vehicle.getJunctionFoes(vid, reach) if f[0] in self._untracked_ids]
        waits = {f[0] for f in foes if f[8]}  # SUMO's right of way: they must let vid pass
        # a road user standing inside the junction that vid is in too waits for vid: SUMO holds a
        # driver at an internal stop for a vehicle on a foe lane inside the junction
        in_junction = states[vid][libsumo.VAR_LANE_ID].startswith(":")
        gaps = [self._inside(vid, v, lane, start, foe, other, pos, states, bodies, in_junction or other in waits)
                for lane, start in chain.items() for foe in self._lane(lane)[2] for other, pos in near.get(foe, ())]
        gaps += [self._approaching(vid, v, chain, f, states, bodies) for f in foes if f[7]]  # vid must let them pass
        for gap in gaps:
            if gap is None:
                continue
            capped = guard_speed(v, target, gap, 0.0, own[3], own[3], max(own[4], own[3]), self.step_length, s.margin)
            target = min(target, capped)
        return target

    def _foes_feed(self, lane: str) -> dict[str, float]:
        """The :meth:`_feed` of all internal foe lanes of ``lane`` in one (largest budget), read once."""
        if lane not in self._feeders:
            merged: dict[str, float] = {}
            for foe in self._lane(lane)[2]:
                for f, budget in self._feed(foe).items():
                    merged[f] = max(budget, merged.get(f, -math.inf))
            self._feeders[lane] = merged
        return self._feeders[lane]

    def _feed(self, lane: str) -> dict[str, float]:
        """Where a road user is on its way into internal lane ``lane``: ``lane`` itself (budget
        infinite) and every lane upstream within FEED [m], each with the budget [m] its road users'
        distance to that lane's end must be within; read once."""
        if lane not in self._feed_of:
            if self._into is None:
                self._into = {}
                for one in self.api.lane.getIDList():
                    for link in self._lane(one)[3]:
                        self._into.setdefault(link[4] or link[0], []).append(one)
            feed, todo = {lane: math.inf}, [(lane, 0.0)]
            while todo:
                at, dist = todo.pop()  # dist [m]: from at's start to lane's start
                for prev in self._into.get(at, ()):
                    if prev not in feed:
                        feed[prev] = FEED - dist
                        if dist + self._lane(prev)[0] < FEED:
                            todo.append((prev, dist + self._lane(prev)[0]))
            self._feed_of[lane] = feed
        return self._feed_of[lane]

    def _body(self, vid: str, bodies: Mapping[str, Body]) -> tuple:
        """(length [m], width [m], accel [m/s^2], ...) of a road user, as read at departure."""
        return bodies.get(vid) or (self.api.vehicle.getLength(vid), self.api.vehicle.getWidth(vid),
                                   self.api.vehicle.getAccel(vid))

    def _max_speed(self, vid: str) -> float:
        """[m/s] the road user's own top speed (its vType's), read once."""
        if vid not in self._top:
            self._top[vid] = self.api.vehicle.getMaxSpeed(vid)
        return self._top[vid]

    def _inside(self, vid: str, v: float, lane: str, start: float, foe: str, other: str, pos: float,
                states: Mapping[str, dict], bodies: Mapping[str, Body], waits: bool) -> float | None:
        """:meth:`_yield_gap` for ``other``, its front at ``pos`` [m] on the internal lane ``foe``
        whose centre line crosses ``lane``, which starts ``start`` [m] ahead of ``vid``'s front
        (``waits``: SUMO has it yield to ``vid``, so standing it stays)."""
        cr = self._crossing(lane, foe)
        if cr is None:
            return None
        own, body = bodies[vid], self._body(other, bodies)
        c = clearance(own[1], body[1], cr.angle)  # [m]
        return self._yield_gap(vid, v, start + cr.s_ego - c, 2.0 * c + own[0], other, cr.s_foe - c - pos,
                               cr.s_foe + c + body[0] - pos, states, bodies, waits)

    def _to_lane_start(self, vid: str, lane: str, states: Mapping[str, dict]) -> float | None:
        """[m] from ``vid``'s front to the start of ``lane`` (negative: on it), if it is on it or on
        a normal lane just before it; None otherwise (its lane and position as last read)."""
        on, pos = states[vid][libsumo.VAR_LANE_ID], states[vid][libsumo.VAR_LANEPOSITION]
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
            start = self._to_lane_start(other, foe_lane, states)
            if start is not None:
                f_entry = min(f_entry, start + cr.s_foe - c)
                f_leave = max(f_leave, start + cr.s_foe + c + body[0])
        # one standing before the junction waits for someone (it has the right of way over vid): SUMO's
        # drivers start only once the junction lets them, and then it is moving and counted
        outside = not states[other][libsumo.VAR_LANE_ID].startswith(":")
        return self._yield_gap(vid, v, entry, leave - entry, other, f_entry, f_leave, states, bodies, outside)

    def _yield_gap(self, vid: str, v: float, to_entry: float, through: float, other: str, foe_to_entry: float,
                   foe_to_exit: float, states: Mapping[str, dict], bodies: Mapping[str, Body],
                   waits: bool = False) -> float | None:
        """[m] ``to_entry``, the distance from ``vid``'s front to a crossing's entry, if ``vid``
        must stop before it for ``other`` (whose front is ``foe_to_entry`` [m] from it and whose
        rear leaves it after ``foe_to_exit`` [m]); None if their occupations do not overlap or
        ``vid`` can no longer stop before it (``through`` [m]: from the entry until its rear leaves;
        ``waits``: a standing ``other`` that waits, because SUMO has it yield to ``vid`` or because
        it stands before the junction, is taken to stay)."""
        own = bodies[vid]
        hardest = max(own[4], own[3])  # [m/s^2]
        if to_entry < v * v / (2.0 * hardest):
            return None  # it cannot stop before the crossing any more: it is committed too
        v_other = states[other][libsumo.VAR_SPEED]  # [m/s] (every untracked road user is in states)
        accel = 0.0 if waits and v_other < 0.1 else self._body(other, bodies)[2]  # [m/s^2]
        theirs = foe_occupation(foe_to_entry, foe_to_exit, v_other, accel, self._max_speed(other))
        mine = ego_occupation(to_entry, through, v, own[2], self.settings.crossing_speed)
        return to_entry if overlaps(mine, theirs, self.settings.crossing_buffer) else None
