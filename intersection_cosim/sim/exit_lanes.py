"""Exit-lane choices and switches inside a managed junction: the choices a controller sends, each
for its own junction; a vehicle moved onto the internal lane of the connection to the exit lane
its controller chose, and the end of such a vehicle's trip at the routes' arrival position
(which SUMO forgets on the move). ``sim`` is the running
:class:`~intersection_cosim.sim.sumo.SumoSimulation`.
"""

from __future__ import annotations

import libsumo

from intersection_cosim.control.safety.exit_room import exit_lane_id
from intersection_cosim.network.by_junction import path_junction

LANE_CHANGE_ROOM = 25.0  # [m] an edge shorter than this leaves no room to change lanes at speed: a
#                          lane leads on along a route only if the lane it links to on such an edge does
LOOK_AHEAD_EDGES = 3  # [-] short edges looked through after the exit edge


def take_exit_choices(sim, decisions) -> None:
    """Record each exit lane of ``decisions`` (a Decisions) for the managed junction whose path the
    vehicle is on (never a human's): taken only from that junction's controller, not from one the
    vehicle has left (a choice late over V2X), and enforced only there (VehicleInfo.exit_lane_at)."""
    for vid, lane in decisions.exit_lane.items():
        info, pid = sim.vehicles.get(vid), sim.current_path.get(vid)
        if info is None or info.driver == "human" or pid is None:
            continue
        here = path_junction(sim.movements, pid)
        if decisions.owner.get(vid) in (None, here):
            info.exit_lane, info.exit_junction = lane, here


def route_exit_options(sim, vid: str, pid: str, options: tuple[str, ...]) -> tuple[str, ...]:
    """The exit lanes of ``options`` (the movement's, preferred first) from which ``vid``'s route
    goes on: those with a link to the route's edge after the exit edge. All of them where none
    has one or the route ends on the exit edge (the paper's nets, a trip's last junction).

    An exit lane that does not lead on along the route must be left by a lane change; on a short
    exit edge (InTAS Ingolstadt feeds its 7-arm cluster by a 4.5 m edge with one lane per next
    edge) there is no room for one, and SUMO stops the vehicle at the lane's end for good. The
    same holds one edge further: a lane that links only to a lane of a short next edge from
    which the route does not go on leads nowhere either (``LANE_CHANGE_ROOM``)."""
    if len(options) < 2:
        return options
    leads_on = _leading_on(sim, vid, pid, options)
    if leads_on is None:
        return options
    keep = tuple(o for o, ok in zip(options, leads_on) if ok)
    return keep or options


def route_continues(sim, vid: str, pid: str) -> bool:
    """Whether ``vid``'s route goes on from an exit lane of path ``pid``'s movement (or ends on its
    exit edge): at a lane split the lane a SUMO driver takes is one from which its route goes on."""
    leads_on = _leading_on(sim, vid, pid, sim.movements.options(pid))
    return leads_on is None or any(leads_on)


def _leading_on(sim, vid: str, pid: str, options: tuple[str, ...]) -> list[bool] | None:
    """Per exit lane of ``options`` (of path ``pid``'s movement), whether ``vid``'s route goes on
    from it without a lane change on an edge too short for one (:func:`_goes_on`); None where the
    route ends on the exit edge (or does not hold it)."""
    exit_lanes = [exit_lane_id(sim.movements, pid, o) for o in options]
    route = _route_ahead(sim, vid)
    edge = exit_lanes[0].rsplit("_", 1)[0]
    at = route.index(edge) if edge in route else len(route)
    if at + 1 >= len(route):
        return None
    ahead = route[at + 1:at + 2 + LOOK_AHEAD_EDGES]
    return [_goes_on(sim, lane, ahead) for lane in exit_lanes]


def _goes_on(sim, lane: str, ahead: list[str]) -> bool:
    """Whether ``lane`` links to ``ahead[0]`` (the route's next edge), and, where that edge is
    shorter than ``LANE_CHANGE_ROOM``, a lane it links to there goes on along ``ahead[1:]``."""
    targets = [(t, length) for t, length in _next_lanes(sim, lane) if t.rsplit("_", 1)[0] == ahead[0]]
    if not targets:
        return False
    if len(ahead) < 2 or targets[0][1] >= LANE_CHANGE_ROOM:
        return True
    return any(_goes_on(sim, t, ahead[1:]) for t, _length in targets)


def split_choice(sim, vid: str, lane: str, candidates: list[str]) -> str:
    """The path of ``candidates`` (paths from approach lane ``lane`` whose exit edge ``vid``'s route
    holds) it takes: where they start from several stop-line lanes (a lane split ahead), the first
    from which its route goes on (:func:`route_continues`), read once per vehicle and lane
    (``sim.split_paths``); else the first."""
    if len({sim.paths[c].lanes[sim.paths[c].stop_index - 1] for c in candidates}) < 2:
        return candidates[0]
    known = sim.split_paths.setdefault(vid, {})
    if lane not in known:
        known[lane] = next((c for c in candidates if route_continues(sim, vid, c)), candidates[0])
    return known[lane]


def _route_ahead(sim, vid: str) -> list[str]:
    """``vid``'s route (read from SUMO) from the edge it is on now."""
    route, index = sim.api.vehicle.getRoute(vid), sim.api.vehicle.getRouteIndex(vid)
    return list(route[max(index, 0):])


def _next_lanes(sim, lane: str) -> tuple[tuple[str, float], ...]:
    """The lanes ``lane``'s links lead onto, each with its length [m] (read from SUMO once per
    lane)."""
    if lane not in sim.lane_links:
        sim.lane_links[lane] = tuple((link[0], sim.api.lane.getLength(link[0])) for link in sim.api.lane.getLinks(lane))
    return sim.lane_links[lane]


def switch_exit_lane(sim, vid: str, lane: str, pid: str, exit_lane: str) -> None:
    """Put a vehicle that entered the junction on path ``pid`` on the internal lane of the
    connection to its chosen ``exit_lane``; where its approach lane has no such connection it
    drives on along ``pid``.

    The internal lanes of one approach lane's connections start at the same point, so the
    move changes only which connection the vehicle follows (a SUMO-documented use of moveTo).
    """
    target_id = sim.movements.siblings.get((pid, exit_lane))
    if target_id is None:
        sim.current_path[vid] = pid
        return
    info = sim.vehicles[vid]
    old, target = sim.paths[pid], sim.paths[target_id]
    s = sim.arc(old, lane, sim.api.vehicle.getLanePosition(vid))
    new_lane, new_pos = sim.lane_position(target, min(s, target.s_exit - 0.01))
    sim.api.vehicle.moveTo(vid, new_lane, new_pos)
    if info.intended_path is not None:
        # a route of the generated net ends exit_distance into the exit lane, which moveTo
        # forgets; a route on a net file ends where the user's route does, which it keeps
        sim.switched.add(vid)
    sim.current_path[vid] = target_id
    sim.states[vid] = sim.read_state(vid)


def arrive_switched(sim) -> None:
    """End the trip of vehicles whose connection was switched, at the routes' arrivalPos.

    SUMO 1.28 resets a vehicle's arrival position to the end of its route when moveTo puts
    it on another junction-internal lane (checked with setRoute, changeTarget and
    setParameter, none of which restores it), so the adapter applies the same rule itself:
    the vehicle arrives once its front is ``exit_distance`` into the exit lane. SUMO then
    writes its tripinfo as for any arrival.
    """
    for vid in list(sim.switched):
        st = sim.states.get(vid)
        if st is None:
            sim.switched.discard(vid)
            continue
        on_exit = st[libsumo.VAR_LANE_ID] == sim.paths[sim.current_path[vid]].lanes[-1]
        if on_exit and st[libsumo.VAR_LANEPOSITION] >= sim.exit_distance:
            sim.api.vehicle.unsubscribe(vid)  # a removed vehicle's subscription fails the next step
            sim.api.vehicle.remove(vid, libsumo.REMOVE_ARRIVED)
            sim.arrived[vid] = sim.time
            sim.states.pop(vid, None)
            sim.commands.pop(vid, None)
            sim.switched.discard(vid)
