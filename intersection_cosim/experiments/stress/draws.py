"""The parameters of a stress run and the scenario variant they make.

A :class:`Space` is the list of parameters drawn for a scenario: one per axis of the ``[stress]``
table that is on and applies to it (scenario/stress_settings.py), and per flow for the per-flow
axes (``flow_scale.<flow id>``, ``vtype.<flow id>``). ``uturn_share`` moves that share of each
flow whose route enters a managed junction with a U-turn connection to a copy ``<flow id>_uturn``
routed back over it (network/junction_net.py's ``uturn_exits``); ``pedestrian_rate`` is written
by experiments/stress/people.py (a routes file, not a table). A draw is a dict parameter name -> value inside
its range. :func:`variant` writes a draw into a copy of the scenario's parsed TOML (the base,
prepared once by :func:`base_data`), so the variant is a plain scenario file with every drawn value
written out: the run's seed, rates, bursts, kappa, av_share, insertion speeds and V2X settings.
"""

from __future__ import annotations

import copy
import dataclasses
from pathlib import Path

import numpy as np

from intersection_cosim.experiments.stress import people
from intersection_cosim.network.junction_net import uturn_exits
from intersection_cosim.scenario.model import Scenario
from intersection_cosim.scenario.network import read_net
from intersection_cosim.scenario.stress_settings import StressSettings

PER_FLOW = ("flow_scale", "vtype")  # axes drawn once per flow
V2X_AXES = ("latency", "loss", "position_noise", "speed_noise")
DECIMALS = 4  # [-] drawn values are rounded to this many decimals before they are written
MAX_SEED = 2**31 - 1  # [-] a run's scenario seed is drawn in [0, MAX_SEED)
PATH_KEYS = ("file", "routes")  # [network] keys holding file paths


@dataclasses.dataclass(frozen=True)
class Param:
    """One drawn parameter: ``name`` (an axis, or ``axis.<flow id>``) and its range [low, high]."""

    name: str
    low: float
    high: float

    @property
    def axis(self) -> str:
        return self.name.split(".", 1)[0]


def space(scn: Scenario, settings: StressSettings) -> tuple[Param, ...]:
    """The parameters drawn for ``scn``: the axes that are on and apply to it (no flow axes
    without flows, no vtype axis without [[vtype]] tables)."""
    params = []
    for name, (low, high) in settings.axes:
        if name in PER_FLOW:
            if name == "vtype" and not [vt for vt in scn.vtypes if not vt.from_routes]:
                continue
            params += [Param(f"{name}.{f.id}", low, high) for f in scn.flows]
        elif name == "uturn_share":
            if uturn_routes(scn):
                params.append(Param(name, low, high))
        elif name == people.AXIS:
            if people.walks(scn):
                params.append(Param(name, low, high))
        elif name in V2X_AXES or scn.flows:
            params.append(Param(name, low, high))
    return tuple(params)


def uturn_routes(scn: Scenario) -> dict[str, tuple[str, ...]]:
    """Flow id -> the route of its U-turn: its route up to the first edge into a managed junction
    that has a U-turn connection (and that the flow drives through), then the edge it turns back
    onto. Only flows on a net file that reach such a junction; none on the generated net."""
    if scn.network.file is None:
        return {}
    back = uturn_exits(str(scn.network.file), tuple(scn.network.junctions))
    out = {}
    for f in scn.flows:
        route = tuple(f.route or ())
        k = next((k for k, edge in enumerate(route[:-1]) if edge in back), None)
        if k is not None:
            out[f.id] = route[:k + 1] + (back[route[k]],)
    return out


def uniform_draw(params: tuple[Param, ...], rng: np.random.Generator) -> dict[str, float]:
    """One draw, every parameter uniform in its range (rounded to DECIMALS)."""
    return {p.name: round(float(rng.uniform(p.low, p.high)), DECIMALS) for p in params}


def _absolute_paths(data: dict, folder: Path) -> None:
    """[network] file paths made absolute against ``folder`` (``$VAR`` and ``~`` paths are kept)."""
    network = data.get("network")
    if not isinstance(network, dict):
        return
    for key in PATH_KEYS:
        value = network.get(key)
        if isinstance(value, str) and not value.startswith(("$", "~")) and not Path(value).is_absolute():
            network[key] = str((folder / value).resolve())


def base_data(data: dict, scn: Scenario, source: Path) -> dict:
    """The scenario's parsed TOML ready for variants: no [stress] table, absolute file paths and
    every flow's id written out (so a variant that drops a flow keeps the others' vehicle ids)."""
    data = copy.deepcopy(data)
    data.pop("stress", None)
    _absolute_paths(data, source.resolve().parent)
    for table, flow in zip(data.get("flow", []), scn.flows, strict=True):
        table["id"] = flow.id
    return data


def _speed_limits(scn: Scenario) -> dict[str, float]:
    """[m/s] the highest insertion speed of each flow's vehicles: their vType's maximum speed (the
    model's v_max unless their [[vtype]] sets one) and, on a net file, the first edge's limit."""
    net = read_net(scn.network.file) if scn.network.file is not None else None
    limits = {}
    for f in scn.flows:
        vt = scn.vtype(f.vtype)
        limit = vt.max_speed if vt is not None and vt.max_speed is not None else scn.model.v_max
        if net is not None and f.route:
            limit = min(limit, net.getEdge(f.route[0]).getSpeed())
        limits[f.id] = limit
    return limits


def _flows(data: dict, scn: Scenario, draw: dict[str, float], duration: float) -> list[dict]:
    """The variant's [[flow]] tables: rates scaled, bursts added, kappa, av_share, speed, vtype."""
    vtypes = [vt.id for vt in scn.vtypes if not vt.from_routes]
    limits = _speed_limits(scn)
    uturns = uturn_routes(scn) if "uturn_share" in draw else {}
    flows, bursts, turned = [], [], []
    for table, spec in zip(data.get("flow", []), scn.flows, strict=True):
        t = dict(table)
        rate = float(t["rate"]) * draw.get("demand_scale", 1.0) * draw.get(f"flow_scale.{spec.id}", 1.0)
        if spec.id in uturns:
            share = draw["uturn_share"]
            turned.append((spec.id, round(rate * share, 3)))
            rate *= 1.0 - share
        t["rate"] = round(rate, 3)
        if "kappa_center" in draw or "kappa_spread" in draw:
            c, s = draw.get("kappa_center", 0.5), draw.get("kappa_spread", 0.0)
            t["kappa"] = {"dist": "uniform", "low": round(max(0.0, c - s / 2), DECIMALS),
                          "high": round(min(1.0, c + s / 2), DECIMALS)}
        if "av_share" in draw:
            t["av_share"] = draw["av_share"]
        if "insertion_speed" in draw:
            t["speed"] = round(min(draw["insertion_speed"], limits[spec.id]), DECIMALS)
        if f"vtype.{spec.id}" in draw and vtypes:
            t["vtype"] = vtypes[min(int(draw[f"vtype.{spec.id}"] * len(vtypes)), len(vtypes) - 1)]
        flows.append(t)
        if (burst := _burst(t, spec, draw, duration)) is not None:
            bursts.append(burst)
    by_id = {t["id"]: t for t in flows}
    back = [{**{k: v for k, v in by_id[fid].items() if k not in ("from", "to")}, "id": f"{fid}_uturn",
             "route": list(uturns[fid]), "rate": rate} for fid, rate in turned if rate > 0]
    return flows + bursts + back


def _burst(table: dict, spec, draw: dict[str, float], duration: float) -> dict | None:
    """A copy of a flow over the burst window at burst_scale times its rate (None: no burst)."""
    scale = draw.get("burst_scale", 0.0)
    begin = max(spec.begin, round(draw.get("burst_start", 0.0) * duration, 2))
    end = min(spec.end, duration, round(begin + draw.get("burst_length", 0.0), 2))
    if scale <= 0 or end <= begin or table["rate"] <= 0:
        return None
    return {**table, "id": f"{spec.id}_burst", "rate": round(table["rate"] * scale, 3), "begin": begin, "end": end}


def variant(base: dict, scn: Scenario, draw: dict[str, float], seed: int, duration: float,
            settings: StressSettings) -> dict:
    """The scenario dict of one run: ``base`` with ``draw`` written in, its own ``seed`` and
    demand window ``duration`` [s], the stress drain and work clock."""
    data = copy.deepcopy(base)
    data["scenario"] = {**data.get("scenario", {}), "seed": int(seed), "duration": float(duration),
                        "drain": float(settings.drain)}
    if settings.work_clock_ms > 0 and "work_clock_ms" not in data.get("controller", {}):
        data["controller"] = {**data.get("controller", {}), "work_clock_ms": float(settings.work_clock_ms)}
    if scn.flows:
        data["flow"] = _flows(base, scn, draw, duration)
    v2x = {k: draw[k] for k in V2X_AXES if k in draw}
    if v2x:
        data["v2x"] = {**data.get("v2x", {}), **v2x}
    return data


def run_seed(rng: np.random.Generator) -> int:
    """A run's scenario seed (SUMO's and the demand's), drawn from the search's ``rng``."""
    return int(rng.integers(MAX_SEED))
