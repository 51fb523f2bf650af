"""What the simulator adapter reads out of SUMO's state for the controllers and the checks: the
World snapshot of the vehicles on managed paths, and the bodies of every vehicle in and around the
managed junctions (for our own collision check, results/overlaps.py)."""

from __future__ import annotations

import math
from typing import Mapping, NamedTuple

import libsumo
import numpy as np

from intersection_cosim.control.base import Guest, World
from intersection_cosim.network.by_junction import path_junction
from intersection_cosim.network.movements import OUTSIDE, READY, Movements
from intersection_cosim.sim.exit_lanes import route_exit_options


class Bodies(NamedTuple):
    """Vehicle bodies at one moment, aligned by index."""

    ids: list[str]
    x: np.ndarray  # [m] front bumper
    y: np.ndarray  # [m]
    heading: np.ndarray  # [rad] counter-clockwise from east
    length: np.ndarray  # [m]
    width: np.ndarray  # [m]
    lanes: list[str]
    commanded: np.ndarray  # bool: under a controller (sim.sumo.SumoSimulation.controlled)
    junctions: Mapping[str, frozenset[str]]  # lane -> the junctions its edge starts or ends at


def watched_lanes(api, movements: Movements) -> frozenset[str]:
    """The lanes in and around the managed junctions: every lane of a managed path, and every
    internal lane of a managed junction (SUMO's internal edges start and end at their junction)."""
    lanes = {lane for path in movements.paths.values() for lane in path.lanes}
    managed = set(movements.junctions)
    for lane in api.lane.getIDList():
        if lane.startswith(":") and api.edge.getFromJunction(api.lane.getEdgeID(lane)) in managed:
            lanes.add(lane)
    return frozenset(lanes)


def lane_junctions(api, lanes) -> dict[str, frozenset[str]]:
    """Per lane of ``lanes``, the junctions its edge starts and ends at (one for an internal
    lane): two bodies on lanes with no junction in common cannot touch (a bridge over a road
    draws its lanes across the road's, with no junction between them)."""
    out = {}
    for lane in lanes:
        edge = api.lane.getEdgeID(lane)
        out[lane] = frozenset((api.edge.getFromJunction(edge), api.edge.getToJunction(edge)))
    return out


def junction_bodies(sim, watched: Mapping[str, frozenset[str]]) -> Bodies:
    """The bodies of every vehicle (whoever drives it) on a lane of ``watched`` (lane -> its
    junctions, :func:`lane_junctions`), as last read."""
    ids = [vid for vid, st in sim.states.items() if st[libsumo.VAR_LANE_ID] in watched]
    controlled = sim.controlled()
    n = len(ids)
    pos = np.array([sim.states[vid][libsumo.VAR_POSITION] for vid in ids], float).reshape(n, 2)
    angle = np.array([sim.states[vid][libsumo.VAR_ANGLE] for vid in ids], float)  # [deg] navigational
    body = np.array([sim.bodies[vid][:2] for vid in ids], float).reshape(n, 2)
    return Bodies(ids, pos[:, 0], pos[:, 1], np.radians(90.0 - angle), body[:, 0], body[:, 1],
                  [sim.states[vid][libsumo.VAR_LANE_ID] for vid in ids],
                  np.array([vid in controlled for vid in ids], bool), watched)


def _offset(from_path, to_path, lane: str) -> float:
    """[m] what to add to an arc length on ``from_path`` to get it on ``to_path``, over ``lane``,
    a lane both run along."""
    return to_path.lane_starts[to_path.lanes.index(lane)] - from_path.lane_starts[from_path.lanes.index(lane)]


GUEST_HOPS = 4  # [-] managed junctions ahead along a vehicle's route that may see it as a guest


def guests_of(sim, vid: str, s: float) -> list[Guest]:
    """The views other managed junctions have of vehicle ``vid`` at arc length ``s`` [m] of its
    current path P: each junction ahead on its route whose stop line is within the control range,
    reached over links from P's exit lane (the next junction's path Q that starts on it, then the
    path that starts on Q's exit lane, ...; up to ``GUEST_HOPS``), while the vehicle is not yet on
    the link into it; and the previous junction's path, while the vehicle is on the link it came
    over from it. A chain of boxes joined by links shorter than a stopping distance (a lane split
    before a large junction) so shows the last box every vehicle bound for it in time to hold it."""
    if len(sim.movements.junctions) < 2:
        return []
    paths, pid = sim.paths, sim.current_path[vid]
    path, lane = paths[pid], sim.states[vid][libsumo.VAR_LANE_ID]
    out = []
    before = sim.previous_path.get(vid)
    if before is not None and lane == paths[before].lanes[-1] and lane in path.lanes:
        out.append(Guest(vid, before, _offset(path, paths[before], lane), OUTSIDE))
    offset, seen = 0.0, {path_junction(sim.movements, pid)}  # offset [m]: from an arc length on P to one on ``path``
    for _hop in range(GUEST_HOPS):
        link = path.lanes[-1]
        nxt = None if lane == link else sim.approach_path(link, vid)
        if nxt is None or path_junction(sim.movements, nxt) in seen:
            break
        offset += _offset(path, paths[nxt], link)
        if paths[nxt].s_stop - (s + offset) > sim.control_range:
            break
        out.append(Guest(vid, nxt, offset, READY))
        seen.add(path_junction(sim.movements, nxt))
        path = paths[nxt]
    return out


def world_snapshot(sim) -> World:
    """A snapshot of every vehicle in the network, in the paper's frame."""
    ids = sorted(vid for vid in sim.states if vid in sim.current_path)
    n = len(ids)
    s = np.empty(n)
    arr = {k: np.empty(n) for k in ("v", "a", "x", "y", "heading", "kappa", "desired")}
    body = np.array([sim.bodies[vid] for vid in ids], float).reshape(n, 5)  # length, width, accel, decels
    human = np.zeros(n, bool)
    path_ids, roles, lanes = [], [], []
    exit_choices: dict[str, tuple[str, ...]] = {}
    for i, vid in enumerate(ids):
        st = sim.states[vid]
        pid = sim.current_path[vid]
        path = sim.paths[pid]
        lane = st[libsumo.VAR_LANE_ID]
        s[i] = (sim.arc(path, lane, st[libsumo.VAR_LANEPOSITION]) if lane in path.lanes
                else st[libsumo.VAR_LANEPOSITION])
        arr["v"][i] = st[libsumo.VAR_SPEED]
        arr["a"][i] = st[libsumo.VAR_ACCELERATION]
        arr["x"][i], arr["y"][i] = st[libsumo.VAR_POSITION]
        arr["heading"][i] = math.radians(90.0 - st[libsumo.VAR_ANGLE])
        info = sim.vehicles.get(vid)
        arr["kappa"][i] = info.kappa if info else 0.5
        desired = info.desired_at(path.speed_limits[path.stop_index - 1]) if info and path.speed_limits else (
            info.desired_speed if info else None)  # [m/s]
        arr["desired"][i] = desired if desired is not None else math.nan
        human[i] = info is not None and info.driver == "human"
        path_ids.append(pid)
        lanes.append(lane)
        # on its path's exit lane a vehicle has left its junction, though that lane may be
        # the next managed junction's approach (a corridor)
        role = OUTSIDE if lane == path.lanes[-1] else sim.movements.role(lane)
        if info is not None and role == READY and not info.exit_fixed and info.driver != "human":
            options = sim.movements.options(pid)  # given by approach and movement: its route ends there
            exit_choices[vid] = options if info.intended_path is not None else route_exit_options(sim, vid, pid, options)
        else:
            exit_choices[vid] = (path.exit_lane,)
        roles.append(role)
    return World(time=sim.time, ids=ids, path_ids=path_ids, s=s, v=arr["v"], a=arr["a"],
                 x=arr["x"], y=arr["y"], heading=arr["heading"], kappa=arr["kappa"], role=roles,
                 lanes=lanes, exit_choices=exit_choices, desired_speed=arr["desired"], human=human,
                 exit_free=_exit_free(sim, exit_choices, roles, ids), length=body[:, 0], width=body[:, 1],
                 accel=body[:, 2], decel=body[:, 3], emergency_decel=body[:, 4], walkers=sim.walkers(),
                 guests=tuple(g for i, vid in enumerate(ids) for g in guests_of(sim, vid, float(s[i]))))


def _exit_free(sim, exit_choices: dict[str, tuple[str, ...]], roles: list[str], ids: list[str]) -> dict:
    """Per exit lane (SUMO lane id) a READY vehicle may take: ([m] from the lane's start to the
    rear of the last vehicle on it, SUMO's whoever drives it, [m/s] that vehicle's speed); the
    lane's length and inf if it is empty."""
    lanes = {sim.paths[sim.movements.siblings.get((sim.current_path[vid], option), sim.current_path[vid])].lanes[-1]
             for vid, role in zip(ids, roles) if role == READY for option in exit_choices[vid]}
    free = {}
    veh = sim.api.vehicle
    for lane in sorted(lanes):
        rears = [(veh.getLanePosition(v) - veh.getLength(v), veh.getSpeed(v))
                 for v in sim.api.lane.getLastStepVehicleIDs(lane)]
        free[lane] = (max(0.0, min(rears)[0]), min(rears)[1]) if rears else (sim.api.lane.getLength(lane), math.inf)
    return free

