"""The random draws of a scenario's demand: each flow's Poisson arrivals, with each vehicle's kappa
and (paper flows) lane, and each flow vehicle's driver (AV or human by the flow's ``av_share``).
Seeded from the scenario's seed, so a fixed seed gives the same vehicles."""

from __future__ import annotations

import numpy as np

from intersection_cosim.network.spec import LANE_USE, LANES
from intersection_cosim.scenario.model import FlowSpec, KappaDistribution, Scenario

DRIVER_STREAM = 16  # [-] second word of the seed of the drivers' draw (a stream apart from the arrivals')


def _draw_kappa(kd: KappaDistribution, rng: np.random.Generator) -> float:
    """One vehicle's kappa [-] from ``kd`` (one rng draw unless fixed), clipped to [0, 1]."""
    if kd.dist == "uniform":
        kappa = rng.uniform(kd.low, kd.high)
    elif kd.dist == "normal":
        kappa = rng.normal(kd.mean, kd.std)
    else:
        kappa = kd.value
    return float(np.clip(kappa, 0.0, 1.0))


def _flow_arrival(flow: FlowSpec, k: int, t: float, kappa: float, rng: np.random.Generator) -> dict:
    """The k-th vehicle of ``flow``, departing at ``t`` [s]; a paper flow draws its lane from ``rng``."""
    common = {"id": f"{flow.id}.{k}", "flow": flow.id, "approach": flow.approach, "movement": flow.movement,
              "depart": round(float(t), 2), "kappa": kappa, "distance": flow.distance, "vtype": flow.vtype}
    if flow.route is not None:
        return {**common, "lane": "", "route": flow.route, "depart_lane": flow.depart_lane,
                "speed": flow.depart_speed, "depart_pos": flow.depart_pos}
    lanes = [flow.lane] if flow.lane else [ln for ln in LANES if flow.movement in LANE_USE[ln]]
    return {**common, "lane": lanes[int(rng.integers(len(lanes)))], "speed": flow.speed, "route": None}


def generate_flow_vehicles(scn: Scenario, rng: np.random.Generator) -> list[dict]:
    """Poisson arrivals of every flow, drawn with ``rng`` (seeded from the scenario's seed).

    Returns one dict per vehicle, sorted by (depart, id): id, flow (its flow's id), approach, lane,
    movement, depart [s], kappa, speed [m/s], distance [m] to the stop line (None = start of the
    arm) and route (None). A flow on a ``[network] file`` net (``route`` not None) gives
    approach, movement and lane "", route (tuple of edge ids), depart_lane ("best" or an index as
    str), speed (SUMO's departSpeed, "max" or a number as str) and depart_pos [m] (None = "base").
    Per vehicle the draws are: headway, kappa (unless fixed), lane (paper flows only).
    """
    out: list[dict] = []
    for flow in scn.flows:
        if flow.rate <= 0:
            continue
        mean_headway = 3600.0 / flow.rate  # [s]
        t = flow.begin + rng.exponential(mean_headway)
        k = 0
        while t < min(flow.end, scn.scenario.duration):
            kappa = _draw_kappa(flow.kappa, rng)
            out.append(_flow_arrival(flow, k, t, kappa, rng))
            k += 1
            t += rng.exponential(mean_headway)
    out.sort(key=lambda d: (d["depart"], d["id"]))
    return out


def draw_drivers(scn: Scenario, flow_vehicles: list[dict]) -> list[dict]:
    """``flow_vehicles`` with each one's ``driver``: "av" with its flow's ``av_share``, else "human".

    One uniform draw per vehicle, in the order of ``flow_vehicles``, from a stream of its own
    (seeded with the scenario's seed and :data:`DRIVER_STREAM`): the arrivals, lanes and kappas do
    not depend on ``av_share``, and a vehicle that is human at one share is human at every lower
    share (the humans of 0.9 are among those of 0.5).
    """
    share = {f.id: f.av_share for f in scn.flows}
    u = np.random.default_rng((scn.scenario.seed, DRIVER_STREAM)).random(len(flow_vehicles))
    return [{**fv, "driver": "av" if u[n] < share[fv["flow"]] else "human"} for n, fv in enumerate(flow_vehicles)]
