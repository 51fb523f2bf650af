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

import contextlib
import io
import math
import re
import subprocess
from dataclasses import dataclass, field
from types import ModuleType
from typing import Mapping

import libsumo
import numpy as np

from intersection_cosim.control.base import Decisions, Walker, World
from intersection_cosim.errors import RouteRefusal
from intersection_cosim.network.crossings import PedestrianCrossing
from intersection_cosim.network.movements import OUTSIDE, PASSING, READY, Movements
from intersection_cosim.network.paths import MovementPath

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


def sumo_version() -> str:
    return libsumo.getVersion()[1]


@dataclass(frozen=True)
class SumoBackend:
    """Which module drives SUMO and which SUMO program it runs.

    ``module`` has libsumo's API (libsumo itself, or traci, which mirrors it over a socket);
    ``binary`` is the program traci starts (libsumo runs in-process and only reads the options).
    """

    module: ModuleType
    binary: str = "sumo"
    options: tuple[str, ...] = ()  # extra options for this program only (e.g. sumo-gui's --start)

    def start(self, args: list[str]) -> None:
        cmd = [self.binary, *args, *self.options]
        if self.module is libsumo:
            libsumo.start(cmd)
            return
        with contextlib.redirect_stdout(io.StringIO()):  # traci prints "Retrying" while the GUI opens
            self.module.start(cmd, stdout=subprocess.DEVNULL)


LIBSUMO = SumoBackend(libsumo)  # headless, in this process: every run but ``run --gui``


def traci_backend(binary: str, options: tuple[str, ...] = ()) -> SumoBackend:
    """A backend that starts ``binary`` (e.g. sumo-gui) and drives it through TraCI."""
    import traci

    return SumoBackend(traci, binary, tuple(options))


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
    start_s: float | None = None  # [m] place here on insertion (vehicles that start in the junction)
    desired_speed: float | None = None  # [m/s] its own max speed (also SUMO's, once it drives itself)
    route: frozenset[str] = frozenset()  # edges of its route (to pick its movement at a managed junction)
    driver: str = "av"  # [-] "av" or "human" (a human is never controlled: SUMO's model drives it)
    vtype: str = "av"  # [-] its SUMO vType id (of the run's route file, or the user's own)


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
    exit_lane_taken: dict[str, str] = field(default_factory=dict)
    departed: dict[str, float] = field(default_factory=dict)
    arrived: dict[str, float] = field(default_factory=dict)
    commands: dict[str, float] = field(default_factory=dict)  # [m/s^2] held accel per vehicle
    switched: set[str] = field(default_factory=set)  # vehicles moved onto another connection
    lane_change_mode: int = LANE_CHANGE_MODE_CONTROLLED  # of a controlled vehicle
    adopt_controlled: bool = True  # vehicles of the user's own route file are controlled
    control_range: float = math.inf  # [m] before the stop line where a vehicle without an intended path is taken over
    taken: set[str] = field(default_factory=set)  # vehicles whose speed the controller commands
    bodies: dict[str, tuple[float, float, float, float, float]] = field(default_factory=dict)  # per vehicle, read
    #   from its vType at departure: length [m], width [m], accel, decel, emergency decel [m/s^2]
    crossings: Mapping[str, PedestrianCrossing] = field(default_factory=dict)  # the crossings the paths run
    #   over, by lane id (network/crossings.py, movement_crossings); none: no person is read
    people_first: bool = False  # each person is told, at its departure, that vehicles yield to it
    #   (impatience 1: it does not wait for a gap); for controllers that command the vehicles with
    #   SUMO's right of way off, which SUMO's people would otherwise still count on
    _lane_to_paths: dict[str, list[str]] = field(default_factory=dict)
    _impatient_types: set[str] = field(default_factory=set)  # person vTypes set to impatience 1
    _walking_areas: dict[str, list[PedestrianCrossing]] = field(default_factory=dict)  # lane -> crossings at it
    _scale: dict[str, float] = field(default_factory=dict)  # lane -> its shape's length / SUMO's length (see arc)
    _approach_paths: dict[str, list[str]] = field(default_factory=dict)  # lane -> paths it approaches

    @property
    def paths(self) -> Mapping[str, MovementPath]:
        return self.movements.paths

    def start(self, sumocfg: str, extra: list[str] | None = None) -> None:
        for pid, p in self.paths.items():
            for lane in p.lanes[1:]:
                self._lane_to_paths.setdefault(lane, []).append(pid)
            for lane in p.lanes[:p.stop_index]:
                self._approach_paths.setdefault(lane, []).append(pid)
        for crossing in self.crossings.values():
            for area in crossing.walking_areas:
                self._walking_areas.setdefault(area, []).append(crossing)
        self.backend.start(["-c", sumocfg, "--no-step-log", "true", *(extra or [])])
        self._scale = self._lane_scales()

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
        if self.people_first and self.crossings:
            self._people_first()
        for vid in self.api.simulation.getDepartedIDList():
            self.departed[vid] = self.time - self.step_length
            self.api.vehicle.subscribe(vid, _VARS)
            info = self.vehicles.get(vid) or self._adopt(vid)
            veh = self.api.vehicle
            self.bodies[vid] = (veh.getLength(vid), veh.getWidth(vid), veh.getAccel(vid), veh.getDecel(vid),
                                veh.getEmergencyDecel(vid))
            if info.desired_speed is not None:
                self.api.vehicle.setMaxSpeed(vid, info.desired_speed)
            if info.intended_path is None:
                continue  # it is taken over when it reaches a managed approach
            self.current_path[vid] = info.intended_path
            self._take_over(vid, info)
            if info.start_s is not None:
                lane, pos = self.lane_position(self.paths[info.intended_path], info.start_s)
                self.api.vehicle.moveTo(vid, lane, pos)
                self.switched.add(vid)  # moveTo resets its arrival position (see _arrive_switched)
        for vid in self.api.simulation.getArrivedIDList():
            self.arrived[vid] = self.time
            self.states.pop(vid, None)
            self.commands.pop(vid, None)
        results = self.api.vehicle.getAllSubscriptionResults()
        for vid, res in results.items():
            self.states[vid] = res
            self._track_path(vid, res[libsumo.VAR_LANE_ID])
        self._arrive_switched()
        # Vehicles moved by moveTo report their new lane only after the next read; refresh them.
        for vid in self.api.simulation.getDepartedIDList():
            info = self.vehicles.get(vid)
            if info is not None and info.start_s is not None and vid in self.states:
                self.states[vid] = self._read(vid)
                self._track_path(vid, self.states[vid][libsumo.VAR_LANE_ID])

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
            if info.exit_lane is not None and self.paths[pid].exit_lane != info.exit_lane and info.driver != "human":
                self._switch_exit_lane(vid, lane, pid, info)
                return
            self.current_path[vid] = pid
            return
        if role == READY and info.intended_path is None:
            pid = self._approach_path(lane, info)
            if pid is not None and self._within_range(vid, lane, self.paths[pid]):
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

    def _approach_path(self, lane: str, info: VehicleInfo) -> str | None:
        """The path of a vehicle on approach lane ``lane`` whose route leaves by the path's exit
        edge: its chosen exit lane if it has one there, else the movement's preferred one."""
        for pid in self._approach_paths.get(lane, ()):
            if self.paths[pid].exit_arm in info.route:
                if info.exit_lane is not None:
                    return self.movements.siblings.get((pid, info.exit_lane), pid)
                return self.movements.sibling(pid, self.movements.preferred(pid))
        return None

    def _within_range(self, vid: str, lane: str, path: MovementPath) -> bool:
        """Whether ``vid`` on ``lane`` of ``path`` is within ``control_range`` of its stop line."""
        s = self.arc(path, lane, self.states[vid][libsumo.VAR_LANEPOSITION])  # [m]
        return path.s_stop - s <= self.control_range

    def _take_over(self, vid: str, info: VehicleInfo) -> None:
        """The controller commands ``vid`` from now on (a controlled vehicle, not yet taken)."""
        if info.controlled and vid not in self.taken:
            self.api.vehicle.setSpeedMode(vid, SPEED_MODE_CONTROLLED)
            self.api.vehicle.setLaneChangeMode(vid, self.lane_change_mode)
            self.taken.add(vid)

    def _adopt(self, vid: str) -> VehicleInfo:
        """A vehicle of the user's own route file: kappa from its ``kappa`` parameter (else 0.5),
        its route from SUMO, controlled like the scenario's vehicles."""
        veh = self.api.vehicle
        kappa = veh.getParameter(vid, "kappa") or "0.5"  # a <param key="kappa"> of the vehicle, else moderate
        info = VehicleInfo("", "", "", float(kappa), None, self.adopt_controlled,
                           route=frozenset(veh.getRoute(vid)), vtype=veh.getTypeID(vid))
        self.vehicles[vid] = info
        return info

    def _switch_exit_lane(self, vid: str, lane: str, pid: str, info: VehicleInfo) -> None:
        """Put a vehicle that entered the junction on the internal lane of its chosen connection.

        The internal lanes of one approach lane's connections start at the same point, so the
        move changes only which connection the vehicle follows (a SUMO-documented use of moveTo).
        """
        target_id = self.movements.siblings.get((pid, info.exit_lane))
        if target_id is None:
            return
        old, target = self.paths[pid], self.paths[target_id]
        s = self.arc(old, lane, self.api.vehicle.getLanePosition(vid))
        new_lane, new_pos = self.lane_position(target, min(s, target.s_exit - 0.01))
        self.api.vehicle.moveTo(vid, new_lane, new_pos)
        if info.intended_path is not None:
            # a route of the generated net ends exit_distance into the exit lane, which moveTo
            # forgets; a route on a net file ends where the user's route does, which it keeps
            self.switched.add(vid)
        self.current_path[vid] = target_id
        self.states[vid] = self._read(vid)

    def _arrive_switched(self) -> None:
        """End the trip of vehicles whose connection was switched, at the routes' arrivalPos.

        SUMO 1.28 resets a vehicle's arrival position to the end of its route when moveTo puts
        it on another junction-internal lane (checked with setRoute, changeTarget and
        setParameter, none of which restores it), so the adapter applies the same rule itself:
        the vehicle arrives once its front is ``exit_distance`` into the exit lane. SUMO then
        writes its tripinfo as for any arrival.
        """
        for vid in list(self.switched):
            st = self.states.get(vid)
            if st is None:
                self.switched.discard(vid)
                continue
            on_exit = st[libsumo.VAR_LANE_ID] == self.paths[self.current_path[vid]].lanes[-1]
            if on_exit and st[libsumo.VAR_LANEPOSITION] >= self.exit_distance:
                self.api.vehicle.unsubscribe(vid)  # a removed vehicle's subscription fails the next step
                self.api.vehicle.remove(vid, libsumo.REMOVE_ARRIVED)
                self.arrived[vid] = self.time
                self.states.pop(vid, None)
                self.commands.pop(vid, None)
                self.switched.discard(vid)

    # --- read ------------------------------------------------------------------------------
    def _read(self, vid: str) -> dict:
        """One vehicle's state read directly (not from this step's subscription)."""
        veh = self.api.vehicle
        get = {libsumo.VAR_POSITION: veh.getPosition, libsumo.VAR_SPEED: veh.getSpeed,
               libsumo.VAR_ACCELERATION: veh.getAcceleration, libsumo.VAR_ANGLE: veh.getAngle,
               libsumo.VAR_LANE_ID: veh.getLaneID, libsumo.VAR_LANEPOSITION: veh.getLanePosition}
        return {v: get[v](vid) for v in _VARS}

    def world(self) -> World:
        """A snapshot of every vehicle in the network, in the paper's frame."""
        ids = sorted(vid for vid in self.states if vid in self.current_path)
        n = len(ids)
        s = np.empty(n)
        arr = {k: np.empty(n) for k in ("v", "a", "x", "y", "heading", "kappa", "desired")}
        body = np.array([self.bodies[vid] for vid in ids], float).reshape(n, 5)  # length, width, accel, decels
        human = np.zeros(n, bool)
        path_ids, roles, lanes = [], [], []
        exit_choices: dict[str, tuple[str, ...]] = {}
        for i, vid in enumerate(ids):
            st = self.states[vid]
            pid = self.current_path[vid]
            path = self.paths[pid]
            lane = st[libsumo.VAR_LANE_ID]
            s[i] = (self.arc(path, lane, st[libsumo.VAR_LANEPOSITION]) if lane in path.lanes
                    else st[libsumo.VAR_LANEPOSITION])
            arr["v"][i] = st[libsumo.VAR_SPEED]
            arr["a"][i] = st[libsumo.VAR_ACCELERATION]
            arr["x"][i], arr["y"][i] = st[libsumo.VAR_POSITION]
            arr["heading"][i] = math.radians(90.0 - st[libsumo.VAR_ANGLE])
            info = self.vehicles.get(vid)
            arr["kappa"][i] = info.kappa if info else 0.5
            arr["desired"][i] = info.desired_speed if info and info.desired_speed is not None else math.nan
            human[i] = info is not None and info.driver == "human"
            path_ids.append(pid)
            lanes.append(lane)
            # on its path's exit lane a vehicle has left its junction, though that lane may be
            # the next managed junction's approach (a corridor)
            role = OUTSIDE if lane == path.lanes[-1] else self.movements.role(lane)
            if info is not None and role == READY and not info.exit_fixed and info.driver != "human":
                exit_choices[vid] = self.movements.options(pid)
            else:
                exit_choices[vid] = (path.exit_lane,)
            roles.append(role)
        return World(time=self.time, ids=ids, path_ids=path_ids, s=s, v=arr["v"], a=arr["a"],
                     x=arr["x"], y=arr["y"], heading=arr["heading"], kappa=arr["kappa"], role=roles,
                     lanes=lanes, exit_choices=exit_choices, desired_speed=arr["desired"], human=human,
                     exit_free=self._exit_free(exit_choices, roles, ids), length=body[:, 0], width=body[:, 1],
                     accel=body[:, 2], decel=body[:, 3], emergency_decel=body[:, 4], walkers=self.walkers())

    def _people_first(self) -> None:
        """Impatience 1 for the vType of each person that departed this step (set on its type:
        libsumo's person.setImpatience addresses vehicles), once per type."""
        for pid in self.api.simulation.getDepartedPersonIDList():
            vtype = self.api.person.getTypeID(pid)
            if vtype not in self._impatient_types:
                self.api.vehicletype.setImpatience(vtype, 1.0)
                self._impatient_types.add(vtype)

    def walkers(self) -> tuple[Walker, ...]:
        """The persons on a managed junction's crossing, and those on a walking area at one with
        that crossing as their next edge, walking or waiting at the kerb (SUMO's person steps out
        when its own gap model, blind to the controller's plans, says so); () without
        crossings. A person's axis position is its position projected onto the crossing's axis
        (in the axis' own metres, as the paths' crossing stretches are, whatever SUMO's length of
        the crossing lane), so on a walking area it lies before the axis' start or past its end."""
        if not self.crossings:
            return ()
        person, out = self.api.person, []
        for pid in person.getIDList():
            lane = person.getLaneID(pid)
            crossing = self.crossings.get(lane)
            if crossing is not None:
                angle = math.radians(person.getAngle(pid))  # navigational: 0 north, clockwise
                d = crossing.direction
                sign = 1 if math.sin(angle) * d[0] + math.cos(angle) * d[1] >= 0.0 else -1
                x, y = person.getPosition(pid)
                out.append(Walker(pid, lane, crossing.along(x, y), sign, person.getSpeed(pid), x, y))
                continue
            near = self._walking_areas.get(lane)
            if not near:
                continue
            nxt = person.getNextEdge(pid)
            for crossing in near:
                if crossing.edge == nxt:
                    x, y = person.getPosition(pid)
                    pos = crossing.along(x, y)
                    sign = 1 if pos < crossing.length / 2 else -1
                    out.append(Walker(pid, crossing.lane, pos, sign, person.getSpeed(pid), x, y))
        return tuple(out)

    def _exit_free(self, exit_choices: dict[str, tuple[str, ...]], roles: list[str], ids: list[str]) -> dict:
        """Per exit lane (SUMO lane id) a READY vehicle may take: ([m] from the lane's start to the
        rear of the last vehicle on it, SUMO's whoever drives it, [m/s] that vehicle's speed); the
        lane's length and inf if it is empty."""
        lanes = {self.paths[self.movements.siblings.get((self.current_path[vid], option), self.current_path[vid])].lanes[-1]
                 for vid, role in zip(ids, roles) if role == READY for option in exit_choices[vid]}
        free = {}
        veh = self.api.vehicle
        for lane in sorted(lanes):
            rears = [(veh.getLanePosition(v) - veh.getLength(v), veh.getSpeed(v))
                     for v in self.api.lane.getLastStepVehicleIDs(lane)]
            free[lane] = (max(0.0, min(rears)[0]), min(rears)[1]) if rears else (self.api.lane.getLength(lane), math.inf)
        return free

    # --- write -----------------------------------------------------------------------------
    def command(self, decisions: Decisions) -> None:
        """Take a controller's decisions: an acceleration held until the next decision, and exit lanes."""
        for vid, accel in decisions.accel.items():
            info = self.vehicles.get(vid)
            if vid in self.states and (info is None or info.driver != "human"):  # a human is never commanded
                self.commands[vid] = float(accel)
        for vid, lane in decisions.exit_lane.items():
            if vid in self.vehicles and self.vehicles[vid].driver != "human":
                self.vehicles[vid].exit_lane = lane
        # a commanded vehicle on no managed path is in no controller's World: SUMO's again
        lost = [vid for vid in self.commands if vid not in self.current_path]
        for vid in [*decisions.release, *lost]:
            if self.commands.pop(vid, None) is not None and vid in self.states:
                self.api.vehicle.setSpeed(vid, -1)  # SUMO's own driver model takes over again
                self.api.vehicle.setSpeedMode(vid, SPEED_MODE_SUMO)
            if self.vehicles.get(vid) is not None and self.vehicles[vid].intended_path is None:
                self.taken.discard(vid)  # on any net it may be taken over at the next managed junction

    def write(self) -> None:
        """Write this SUMO step's speed commands: v + a * step for every commanded vehicle.

        Controlled vehicles run with speed mode 0, so the speed SUMO realises at the end of the
        step is exactly the commanded one (setSpeed every step; tests check this).
        """
        for vid, accel in self.commands.items():
            v = self.states[vid][libsumo.VAR_SPEED]
            self.api.vehicle.setSpeed(vid, max(0.0, v + accel * self.step_length))

    def switch_signals_off(self) -> list[str]:
        """Switch off every traffic light that controls a link into a managed junction (its
        state becomes O / o: no signal, so SUMO's own vehicles follow the junction's priority
        rules); returns the programmes' ids."""
        off = []
        for tls in self.api.trafficlight.getIDList():
            links = self.api.trafficlight.getControlledLinks(tls)
            if any(link and self.movements.role(link[0][0]) != OUTSIDE for link in links):
                self.api.trafficlight.setProgram(tls, "off")
                off.append(tls)
        return off

    def collisions(self) -> list[tuple[str, str]]:
        return [(c.collider, c.victim) for c in self.api.simulation.getCollisions()]

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

