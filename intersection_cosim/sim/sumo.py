"""The SUMO adapter: with :mod:`intersection_cosim.sim.gui`, the only code that imports the simulator.

It drives SUMO through a module with libsumo's API, chosen by a :class:`SumoBackend`: libsumo
in-process for headless runs (the default), or TraCI to a sumo-gui it starts for ``run --gui``;
the same code reads, writes and steps either. It starts SUMO from a ``.sumocfg``, keeps the
explicit order of one simulation step in :meth:`SumoSimulation.advance`: read (one subscription
read per step) -> the caller decides -> write -> step, and turns SUMO's state into
:class:`~intersection_cosim.control.base.World` snapshots in the paper's frame.

libsumo runs one simulation per process; :meth:`SumoSimulation.close` is always called in a
``finally``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from types import ModuleType
from typing import Mapping

import libsumo

from intersection_cosim.control.base import Decisions, Walker, World
from intersection_cosim.control.safety.onboard import OnboardSettings
from intersection_cosim.errors import RouteRefusal
from intersection_cosim.network.by_junction import path_junction
from intersection_cosim.network.crossings import PedestrianCrossing
from intersection_cosim.network.movements import PASSING, READY, Movements
from intersection_cosim.network.paths import MovementPath
from intersection_cosim.sim.backend import LIBSUMO, SumoBackend, sumo_version, traci_backend
from intersection_cosim.sim.collisions import CollisionRecord, step_collisions
from intersection_cosim.sim.exit_lanes import arrive_switched, split_choice, switch_exit_lane, take_exit_choices
from intersection_cosim.sim.lane_change_hold import LaneChangeHold
from intersection_cosim.sim.onboard import OnboardGuard
from intersection_cosim.sim.people import CrossingPeople
from intersection_cosim.sim.signals import set_signal_states, switch_signals_off
from intersection_cosim.sim.snapshot import Bodies, junction_bodies, lane_junctions, watched_lanes, world_snapshot
from intersection_cosim.sim.vehicles import VehicleInfo, adopted

__all__ = ["LANE_CHANGE_MODE_STRATEGIC", "LIBSUMO", "SumoBackend", "SumoSimulation", "VehicleInfo", "sumo_version",
           "traci_backend"]

LENGTH_TOL = 0.01  # [m] a lane whose SUMO length differs from its shape's by less is taken as its shape
_VARS = (libsumo.VAR_POSITION, libsumo.VAR_SPEED, libsumo.VAR_ACCELERATION, libsumo.VAR_ANGLE,
         libsumo.VAR_LANE_ID, libsumo.VAR_LANEPOSITION)

SPEED_MODE_CONTROLLED = 0  # every SUMO check off: no safe speed, no right of way, no accel limits
LANE_CHANGE_MODE_CONTROLLED = 0  # SUMO makes no lane change of its own
# On any net: strategic lane changes only (to reach the lanes of its route), respecting others'
# gaps; a vehicle inserted on the wrong lane of a multi-lane approach could not turn otherwise
LANE_CHANGE_MODE_STRATEGIC = 0b1000000001
# SUMO's message when it cannot route a vehicle or person at its insertion
ROUTE_REFUSAL = re.compile(r"No connection (found )?between edge")
SPEED_MODE_SUMO = 31  # SUMO's default: every safety check on (for vehicles released from control)


@dataclass
class SumoSimulation:
    """One running SUMO instance, driven step by step."""

    movements: Movements  # the managed junctions' movement paths
    vehicles: dict[str, VehicleInfo]
    step_length: float  # [s]
    exit_distance: float = 50.0  # [m] past the junction where vehicles arrive (the routes' arrivalPos)
    backend: SumoBackend = LIBSUMO
    time: float = 0.0  # [s]
    states: dict[str, dict] = field(default_factory=dict)
    current_path: dict[str, str] = field(default_factory=dict)
    left_paths: dict[str, str] = field(default_factory=dict)  # the last path of vehicles that left every path
    previous_path: dict[str, str] = field(default_factory=dict)  # the path a vehicle drove before its current
    #   one, when it came straight over that path's exit lane (a link between two managed junctions)
    exit_lane_taken: dict[str, str] = field(default_factory=dict)
    departed: dict[str, float] = field(default_factory=dict)
    arrived: dict[str, float] = field(default_factory=dict)
    commands: dict[str, float] = field(default_factory=dict)  # [m/s^2] held accel per commanded vehicle
    owner: dict[str, str | None] = field(default_factory=dict)  # the junction whose controller commands
    #   each commanded vehicle (None: the run's one junction); a command never outlives it
    switched: set[str] = field(default_factory=set)  # vehicles moved onto another connection
    lane_links: dict[str, tuple] = field(default_factory=dict)  # lane -> (next lane, [m] length) (exit_lanes.py)
    lane_change_mode: int = LANE_CHANGE_MODE_CONTROLLED  # of a controlled vehicle
    adopt_controlled: bool = True  # vehicles of the user's own route file are controlled
    adopt_road_speed: bool = False  # they desire their roads' limits (network.desired_speed "road")
    control_range: float = math.inf  # [m] before the stop line where a vehicle without an intended path is taken over
    taken: set[str] = field(default_factory=set)  # vehicles whose speed the controller commands
    bodies: dict[str, tuple[float, float, float, float, float]] = field(default_factory=dict)  # per vehicle, read
    #   from its vType at departure: length [m], width [m], accel, decel, emergency decel [m/s^2]
    crossings: Mapping[str, PedestrianCrossing] = field(default_factory=dict)  # the crossings the paths run
    #   over, by lane id (network/crossings.py, movement_crossings); none: no person is read
    people_first: bool = False  # each person is told, at its departure, that vehicles yield to it
    #   (impatience 1: it does not wait for a gap); for controllers that command the vehicles with
    #   SUMO's right of way off, which SUMO's people would otherwise still count on
    onboard: OnboardSettings | None = None  # the onboard guard of every commanded vehicle (None: off)
    min_gaps: dict[str, float] = field(default_factory=dict)  # [m] SUMO's minGap per vehicle, read at departure
    collision_log: list[CollisionRecord] = field(default_factory=list)  # SUMO's collisions, step by step
    guard: OnboardGuard | None = None  # made by start() from ``onboard``
    loaded: int = 0  # [-] vehicles SUMO has loaded from the route files so far (inserted or not)
    emission_classes: dict[str, str] = field(default_factory=dict)  # vType -> its emission class (SUMO's HBEFA
    #   model computes each vehicle's fuel and CO2 with it)
    _lane_to_paths: dict[str, list[str]] = field(default_factory=dict)
    _people: CrossingPeople | None = None
    _watched: Mapping[str, frozenset[str]] = field(default_factory=dict)  # the lanes in and around the
    #   managed junctions, each with the junctions its edge starts and ends at
    _scale: dict[str, float] = field(default_factory=dict)  # lane -> its shape's length / SUMO's length (see arc)
    _approach_paths: dict[str, list[str]] = field(default_factory=dict)  # lane -> paths it approaches
    split_paths: dict[str, dict[str, str]] = field(default_factory=dict)  # vid -> {lane before a split: its path}
    _hold: LaneChangeHold | None = None  # no lane change with the body in a managed junction (made by start())
    _ever_taken: set[str] = field(default_factory=set)  # vehicles a controller has taken over

    @property
    def paths(self) -> Mapping[str, MovementPath]:
        return self.movements.paths

    def start(self, sumocfg: str, extra: list[str] | None = None) -> None:
        for pid, p in self.paths.items():
            for lane in p.lanes[1:]:
                self._lane_to_paths.setdefault(lane, []).append(pid)
            for lane in p.lanes[:p.stop_index]:
                self._approach_paths.setdefault(lane, []).append(pid)
        self.backend.start(["-c", sumocfg, "--no-step-log", "true", *(extra or [])])
        self._scale = self._lane_scales()
        self._people = CrossingPeople(self.api, self.crossings) if self.crossings else None
        self._watched = lane_junctions(self.api, watched_lanes(self.api, self.movements))
        if self.onboard is not None and self.onboard.enabled:
            self.guard = OnboardGuard(self.api, self.onboard, self.step_length)
        exits = {path.lanes[-1] for path in self.paths.values()}
        self._hold = LaneChangeHold({lane: self.api.lane.getLength(lane) for lane in exits},
                                    frozenset(lane for lane in self._watched if lane.startswith(":")),
                                    self.lane_change_mode, self.step_length)

    def _lane_scales(self) -> dict[str, float]:
        """Per path lane whose SUMO length differs from its shape's length (by ``LENGTH_TOL`` [m]
        or more; e.g. 239 lanes of SUMO's Braunschweig net, up to 1.1 m on a 15.5 m approach),
        the ratio of the two: SUMO measures positions in its length, the paths in their shapes'."""
        scale = {}
        for path in self.paths.values():
            ends = (*path.lane_starts[1:], path.length)
            for lane, start, end in zip(path.lanes, path.lane_starts, ends):
                length = self.api.lane.getLength(lane)  # [m] SUMO's
                if lane not in scale and length > 0 and abs((end - start) - length) >= LENGTH_TOL:
                    scale[lane] = (end - start) / length
        return scale

    def arc(self, path: MovementPath, lane: str, pos: float) -> float:
        """[m] arc length along ``path`` of SUMO lane position ``pos`` [m] on ``lane`` (one of its
        lanes). Where a lane's SUMO length is not its shape's, its positions are scaled to the
        shape, so that the arc length runs on without a jump from lane to lane (unscaled, a car
        crossing the stop line of a lane 1.1 m longer than its shape jumped 1.1 m back, and its
        follower, judging its gap across the line, ran into it)."""
        return path.lane_starts[path.lanes.index(lane)] + pos * self._scale.get(lane, 1.0)

    def lane_position(self, path: MovementPath, s: float) -> tuple[str, float]:
        """The SUMO lane and lane position [m] at arc length ``s`` [m] of ``path`` (:meth:`arc`'s inverse)."""
        lane, pos = path.lane_at(s)
        return lane, pos / self._scale.get(lane, 1.0)

    @property
    def api(self) -> ModuleType:
        """The module driving SUMO (libsumo or traci): for views that decorate the running simulation."""
        return self.backend.module

    # --- one step --------------------------------------------------------------------------
    def advance(self) -> None:
        """Step SUMO once, then register departures and arrivals and read every vehicle's state.
        A route SUMO cannot find for a vehicle or person it inserts ends the simulation: raised as
        :class:`~intersection_cosim.errors.RouteRefusal`."""
        try:
            self.api.simulationStep()
        except Exception as exc:  # libsumo's and traci's FatalTraCIError / TraCIException
            if ROUTE_REFUSAL.search(str(exc)):
                raise RouteRefusal(self.time + self.step_length, str(exc)) from None
            raise
        self.time = self.api.simulation.getTime()
        self.loaded += self.api.simulation.getLoadedNumber()
        self.collision_log += step_collisions(self.api, self.time, self.controlled())
        if self.people_first and self._people is not None:
            self._people.people_first()
        for vid in self.api.simulation.getDepartedIDList():
            self.departed[vid] = self.time - self.step_length
            self.api.vehicle.subscribe(vid, _VARS)
            info = self.vehicles.get(vid) or self._adopt(vid)
            veh = self.api.vehicle
            self.bodies[vid] = (veh.getLength(vid), veh.getWidth(vid), veh.getAccel(vid), veh.getDecel(vid),
                                veh.getEmergencyDecel(vid))
            self.min_gaps[vid] = veh.getMinGap(vid)
            vtype = veh.getTypeID(vid)
            if vtype not in self.emission_classes:
                self.emission_classes[vtype] = veh.getEmissionClass(vid)
            if info.desired_speed is not None:
                self.api.vehicle.setMaxSpeed(vid, info.desired_speed)
            if info.intended_path is None:
                continue  # it is taken over when it reaches a managed approach
            self.current_path[vid] = info.intended_path
            self._take_over(vid, info)
            if info.start_s is not None:
                lane, pos = self.lane_position(self.paths[info.intended_path], info.start_s)
                self.api.vehicle.moveTo(vid, lane, pos)
                self.switched.add(vid)  # moveTo resets its arrival position (see sim/exit_lanes.py)
        for vid in self.api.simulation.getArrivedIDList():
            self.arrived[vid] = self.time
            self.states.pop(vid, None)
            self.commands.pop(vid, None)
            self.owner.pop(vid, None)
            self.split_paths.pop(vid, None)
        results = self.api.vehicle.getAllSubscriptionResults()
        for vid, res in results.items():
            self.states[vid] = res
            self._track_path(vid, res[libsumo.VAR_LANE_ID])
        arrive_switched(self)
        # Vehicles moved by moveTo report their new lane only after the next read; refresh them.
        for vid in self.api.simulation.getDepartedIDList():
            info = self.vehicles.get(vid)
            if info is not None and info.start_s is not None and vid in self.states:
                self.states[vid] = self.read_state(vid)
                self._track_path(vid, self.states[vid][libsumo.VAR_LANE_ID])
        for vid in [vid for vid, junction in self.owner.items() if not self._ownable(vid, junction)]:
            self._release(vid)  # it left its owner's junction: SUMO drives it until another takes it
        self._ever_taken = {vid for vid in self._ever_taken | self.taken if vid in self.states}
        if self._hold is not None:
            self._hold.update(self.api, self.states, self.bodies, self._ever_taken)

    def _track_path(self, vid: str, lane: str) -> None:
        """Resolve the vehicle's movement path from its lane and enforce its exit lane.

        On the approach the path is the intended one (a vehicle without one: the path of its lane
        and route, see :meth:`_approach_path`); a junction-internal lane belongs to exactly one
        connection, so it fixes the path; on the exit lane the path stays as fixed; past it the
        vehicle has none (it is out of the World until it reaches the next managed approach).
        """
        info = self.vehicles.get(vid)
        if info is None:
            return
        role = self.movements.role(lane)
        if role == PASSING:
            pid = self._lane_to_paths[lane][0]
            exit_lane = info.exit_lane_at(path_junction(self.movements, pid))
            if exit_lane is not None and self.paths[pid].exit_lane != exit_lane and info.driver != "human":
                switch_exit_lane(self, vid, lane, pid, exit_lane)
                return
            self.current_path[vid] = pid
            return
        if role == READY and info.intended_path is None:
            pid = self._approach_path(lane, info, vid)
            if pid is not None and self._within_range(vid, lane, self.paths[pid]):
                before = self.current_path.get(vid)
                if before is not None and before != pid and lane == self.paths[before].lanes[-1]:
                    self.previous_path[vid] = before  # it came over a link from another managed junction
                self.current_path[vid] = pid
                self._take_over(vid, info)
                return
        current = self.current_path.get(vid)
        if current is None:
            return
        if lane == self.paths[current].lanes[-1]:
            if vid not in self.exit_lane_taken:
                self.exit_lane_taken[vid] = self.paths[current].exit_lane
        elif lane not in self.paths[current].lanes:
            self.left_paths[vid] = self.current_path.pop(vid)  # left the managed junction's paths

    def _approach_path(self, lane: str, info: VehicleInfo, vid: str) -> str | None:
        """The path from approach lane ``lane`` whose exit edge the route holds (before a lane split, of
        route-file vehicle ``vid``: exit_lanes.split_choice), to its chosen exit lane, else the preferred."""
        candidates = [pid for pid in self._approach_paths.get(lane, ()) if self.paths[pid].exit_arm in info.route]
        if not candidates:
            return None
        pid = candidates[0] if info.intended_path else split_choice(self, vid, lane, candidates)
        exit_lane = info.exit_lane_at(path_junction(self.movements, pid))
        if exit_lane is not None:
            return self.movements.siblings.get((pid, exit_lane), pid)
        return self.movements.sibling(pid, self.movements.preferred(pid))

    def _within_range(self, vid: str, lane: str, path: MovementPath) -> bool:
        """Whether ``vid`` on ``lane`` of ``path`` is within ``control_range`` of its stop line."""
        s = self.arc(path, lane, self.states[vid][libsumo.VAR_LANEPOSITION])  # [m]
        return path.s_stop - s <= self.control_range

    def _take_over(self, vid: str, info: VehicleInfo) -> None:
        """A controller may command ``vid`` from now on (a controlled vehicle, not yet taken): its
        lane changes are the controller's; its speed becomes the controller's with the first
        command a junction that owns it sends (:meth:`command`)."""
        if info.controlled and vid not in self.taken:
            self.api.vehicle.setLaneChangeMode(vid, self.lane_change_mode)
            self.taken.add(vid)

    def _ownable(self, vid: str, junction: str | None) -> bool:
        """Whether the controller of ``junction`` (None: the run's one junction) may command ``vid``
        now: an AV in the network on one of that junction's paths, short of the path's exit lane
        (there it has left the junction)."""
        info, pid = self.vehicles.get(vid), self.current_path.get(vid)
        if pid is None or vid not in self.states or (info is not None and info.driver == "human"):
            return False
        path = self.paths[pid]
        if self.states[vid][libsumo.VAR_LANE_ID] == path.lanes[-1]:
            return False
        return junction is None or path_junction(self.movements, pid) == junction

    def _release(self, vid: str) -> None:
        """SUMO's driver model drives ``vid`` again (its speed command and owner dropped)."""
        self.owner.pop(vid, None)
        if self.commands.pop(vid, None) is not None and vid in self.states:
            self.api.vehicle.setSpeed(vid, -1)
            self.api.vehicle.setSpeedMode(vid, SPEED_MODE_SUMO)
        if (info := self.vehicles.get(vid)) is not None and info.intended_path is None:
            self.taken.discard(vid)  # on any net it may be taken over at the next managed junction

    def _adopt(self, vid: str) -> VehicleInfo:
        """A vehicle of the user's own route file, controlled like the scenario's (sim/vehicles.py)."""
        self.vehicles[vid] = adopted(self.api, vid, self.adopt_controlled, self.adopt_road_speed)
        return self.vehicles[vid]

    # --- read ------------------------------------------------------------------------------
    def read_state(self, vid: str) -> dict:
        """One vehicle's state read directly (not from this step's subscription)."""
        veh = self.api.vehicle
        get = {libsumo.VAR_POSITION: veh.getPosition, libsumo.VAR_SPEED: veh.getSpeed,
               libsumo.VAR_ACCELERATION: veh.getAcceleration, libsumo.VAR_ANGLE: veh.getAngle,
               libsumo.VAR_LANE_ID: veh.getLaneID, libsumo.VAR_LANEPOSITION: veh.getLanePosition}
        return {v: get[v](vid) for v in _VARS}

    def world(self) -> World:
        """A snapshot of every vehicle on a managed path, in the paper's frame (sim/snapshot.py)."""
        return world_snapshot(self)

    def controlled(self) -> set[str]:
        """The vehicles under a controller now: commanded, or taken over on a managed approach and
        waiting for their owner's first command."""
        return set(self.commands) | self.taken

    def walkers(self) -> tuple[Walker, ...]:
        """The persons at the managed junctions' crossings (sim/people.py); () without crossings."""
        return self._people.walkers() if self._people is not None else ()

    def approach_path(self, lane: str, vid: str) -> str | None:
        """The managed path vehicle ``vid`` will take from approach lane ``lane`` (None: none)."""
        info = self.vehicles.get(vid)
        return None if info is None else self._approach_path(lane, info, vid)

    def junction_bodies(self) -> Bodies:
        """The bodies of every vehicle in and around the managed junctions (sim/snapshot.py)."""
        return junction_bodies(self, self._watched)

    # --- write -----------------------------------------------------------------------------
    def command(self, decisions: Decisions) -> None:
        """Take a controller's decisions: an acceleration held until the next decision, and exit
        lanes. A command is taken only from the junction that may command the vehicle now
        (``Decisions.owner``; :meth:`_ownable`): one that left that junction since (a decision
        late over a V2X link, or made before a handover) stays SUMO's or its new owner's."""
        for vid, accel in decisions.accel.items():
            junction = decisions.owner.get(vid)
            if not self._ownable(vid, junction):
                continue
            if vid not in self.commands:
                self.api.vehicle.setSpeedMode(vid, SPEED_MODE_CONTROLLED)  # the controller's from now on
            self.commands[vid] = float(accel)
            self.owner[vid] = junction
        take_exit_choices(self, decisions)
        set_signal_states(self.api, decisions.signals)
        for vid in decisions.release:
            if vid in self.owner and decisions.owner.get(vid, self.owner[vid]) == self.owner[vid]:
                self._release(vid)

    def write(self) -> None:
        """Write this SUMO step's speed commands: v + a * step for every commanded vehicle, capped
        by the onboard guard (sim/onboard.py) behind the vehicle ahead.

        Controlled vehicles run with speed mode 0, so the speed SUMO realises at the end of the
        step is exactly the commanded one (setSpeed every step; tests check this); a command is
        therefore held to what the vehicle can do: no braking harder than its vType's
        emergencyDecel.
        """
        if self.guard is not None:
            self.guard.begin_step(self.states, self.current_path, self.commands)
        for vid, accel in self.commands.items():
            v = self.states[vid][libsumo.VAR_SPEED]
            body = self.bodies.get(vid)
            hardest = max(body[4], body[3]) if body is not None else math.inf  # [m/s^2] its emergency braking
            target = max(0.0, v + max(accel, -hardest) * self.step_length)  # [m/s]
            if self.guard is not None:
                target = self.guard.speed(vid, v, target, self.states, self.bodies, self.min_gaps)
            self.api.vehicle.setSpeed(vid, target)

    def switch_signals_off(self) -> list[str]:
        """Switch off the traffic lights at the managed junctions (sim/signals.py); their ids."""
        return switch_signals_off(self.api, self.movements)

    def remaining(self) -> int:
        """Vehicles still in the network or waiting to be inserted."""
        return self.api.simulation.getMinExpectedNumber()

    def speeds(self) -> list[float]:
        """[m/s] the speed of every vehicle in the network (controlled or not), as last read."""
        return [res[libsumo.VAR_SPEED] for res in self.states.values()]

    def close(self) -> None:
        try:
            self.api.close()
        except Exception:  # closing a simulation that failed to start
            pass

