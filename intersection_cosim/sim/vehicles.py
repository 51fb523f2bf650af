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
    road_speed: float | None = None  # [m/s] a route-file vehicle's top speed (its vType's maxSpeed): it desires
    #                                  the limit of its lane into each managed junction, up to this (see
    #                                  desired_at); None: desired_speed, else the model's v_max
    route: frozenset[str] = frozenset()  # edges of its route (to pick its movement at a managed junction)
    driver: str = "av"  # [-] "av" or "human" (a human is never controlled: SUMO's model drives it)
    vtype: str = "av"  # [-] its SUMO vType id (of the run's route file, or the user's own)

    def desired_at(self, approach_limit: float) -> float | None:
        """[m/s] the speed it desires (J_e, Eq. 24) on a path whose lane into the junction is
        signed ``approach_limit`` [m/s]: its own desired speed, else (a vehicle of the user's route
        file) the road's limit up to its top speed, as SUMO's driver of it would; None: the
        model's v_max."""
        if self.desired_speed is not None or self.road_speed is None:
            return self.desired_speed
        return min(self.road_speed, approach_limit)

    def exit_lane_at(self, junction: str) -> str | None:
        """The exit lane to enforce at managed junction ``junction``: the one chosen for that
        junction (or fixed by the scenario), else None. A choice made at one junction says
        nothing of the next one's lanes, so it is not carried over."""
        if self.exit_junction is None or self.exit_junction == junction:
            return self.exit_lane
        return None


def adopted(api, vid: str, controlled: bool, road_speed: bool) -> VehicleInfo:
    """A vehicle of the user's own route file (``api``: libsumo or traci): kappa from its ``kappa``
    parameter (else 0.5), its route from SUMO; with ``road_speed`` it desires its roads' limits up to
    its vType's maxSpeed (:meth:`VehicleInfo.desired_at`), else the model's v_max."""
    veh = api.vehicle
    kappa = veh.getParameter(vid, "kappa") or "0.5"  # a <param key="kappa"> of the vehicle, else moderate
    return VehicleInfo("", "", "", float(kappa), None, controlled, route=frozenset(veh.getRoute(vid)),
                       vtype=veh.getTypeID(vid), road_speed=veh.getMaxSpeed(vid) if road_speed else None)
