"""A run's inputs: its controller, the net and the movements of its managed junctions, the
vehicles drawn from the scenario's flows, and the SUMO files (net, routes, config) written from
them; and what the simulation is given of each vehicle."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Mapping, NamedTuple

import numpy as np

from intersection_cosim.control import registry
from intersection_cosim.control.base import Controller
from intersection_cosim.errors import InputError
from intersection_cosim.experiments.files import ROUTE_FILE, SIGNALS_FILE, SUMOCFG_FILE, write_routes, write_sumocfg
from intersection_cosim.experiments.route_window import write_window
from intersection_cosim.network.build import NET_FILE
from intersection_cosim.network.cache import cached_net
from intersection_cosim.network.junction_net import junction_table, load_movements
from intersection_cosim.network.movements import Movements, paper_movements
from intersection_cosim.network.path_id import PathId
from intersection_cosim.network.paths import MovementPath
from intersection_cosim.network.spec import IntersectionSpec
from intersection_cosim.network.xml_files import copy_plain
from intersection_cosim.scenario.draws import draw_drivers, generate_flow_vehicles
from intersection_cosim.scenario.load import default_exit_lane
from intersection_cosim.scenario.model import Scenario
from intersection_cosim.scenario.network import route_file_persons
from intersection_cosim.scenario.vtypes import sumo_type


class RunInputs(NamedTuple):
    """A run's controller and the inputs its SUMO files were written from."""

    controller: Controller
    net: Path  # the cached net file (copied into the run's folder)
    movements: Movements  # the managed junctions' movement paths
    flow_vehicles: list[dict]  # the vehicles drawn from the scenario's flows

    @property
    def paths(self) -> Mapping[str, MovementPath]:
        return self.movements.paths


def write_inputs(scn: Scenario, folder: Path) -> RunInputs:
    """Create the run's controller and write its SUMO inputs (net, routes, config) into ``folder``."""
    s = scn.scenario
    controller = registry.create_per_junction(scn.controller.kind, scn.controller_settings, s.junction_type)
    net, movements = _movements(scn, controller)
    copy_plain(net, folder / NET_FILE)  # a gzipped net is written out plain
    rng = np.random.default_rng(s.seed)
    flow_vehicles = draw_drivers(scn, generate_flow_vehicles(scn, rng))
    _check_attacked(scn, flow_vehicles)
    write_routes(folder / ROUTE_FILE, scn, movements.paths, flow_vehicles)
    write_sumocfg(folder / SUMOCFG_FILE, NET_FILE, scn, write_window(scn, folder),
                  _signal_additional(scn, controller, net, folder))
    return RunInputs(controller, net, movements, flow_vehicles)


def _signal_additional(scn: Scenario, controller: Controller, net: Path, folder: Path) -> tuple[str, ...]:
    """The signal programme file a signal controller has SUMO load (SIGNALS_FILE in ``folder``), as
    the names of the additional files to add; () for other controllers."""
    make = getattr(controller, "signal_additional", None)
    if make is None:
        return ()
    root = make(str(net), tuple(scn.network.junctions) if not scn.network.generated else tuple(_net_junctions(net)))
    ET.indent(root)
    ET.ElementTree(root).write(folder / SIGNALS_FILE, encoding="UTF-8", xml_declaration=True)
    return (SIGNALS_FILE,)


def _net_junctions(net: Path) -> list[str]:
    """The ids of the traffic-light junctions of the generated net."""
    table = junction_table(net, all_junctions=True)
    return [str(j) for j in table.loc[table["type"].str.startswith("traffic_light"), "id"]]


def _check_attacked(scn: Scenario, flow_vehicles: list[dict]) -> None:
    """An attack on a flow's vehicle that this seed's draw does not insert is an InputError (the
    loader has checked the id's form; only the draw knows which ``<flow id>.<k>`` exist)."""
    drawn = {fv["id"] for fv in flow_vehicles}
    flow_ids = {f.id for f in scn.flows}
    for i, attack in enumerate(scn.v2x.attack):
        head = attack.vehicle.rpartition(".")[0]
        if head in flow_ids and attack.vehicle not in drawn and attack.vehicle not in {v.id for v in scn.vehicles}:
            raise InputError(scn.source, f"v2x.attack[{i}].vehicle", attack.vehicle,
                             f"flow {head!r} inserts {sum(fv['flow'] == head for fv in flow_vehicles)} vehicles "
                             f"with seed {scn.scenario.seed} (ids {head}.0 ...)")


def _movements(scn: Scenario, controller: Controller) -> tuple[Path, Movements]:
    """The net the run drives on and the movements of its managed junctions: the generated paper
    net (built for the controller's junction type), or the scenario's own net file."""
    if scn.network.generated:
        net = cached_net(IntersectionSpec(junction_type=controller.junction_type))
        return net, paper_movements(net)
    if controller.junction_type == "allway_stop":
        raise InputError(scn.source, "controller.kind", scn.controller.kind,
                         "an all-way stop needs the generated net (a net file keeps its own junction types)")
    net = Path(scn.network.file)
    movements = load_movements(net, scn.network.junctions, scn.network.control_range)
    if scn.network.signals == "on" and controller.controls_vehicles:
        _refuse_kept_lights(scn, net)
    with_people = [path for path in scn.network.routes if route_file_persons(path)]
    if with_people and not controller.yields_to_pedestrians:
        raise InputError(scn.source, "network.routes", with_people[0],
                         f"has pedestrians (person / personFlow): {scn.controller.kind} does not see them and "
                         "would drive through their crossings; leave them out, or run nash, stackelberg or a "
                         "sumo-* controller")
    return net, movements


def _refuse_kept_lights(scn: Scenario, net: Path) -> None:
    """An InputError if a managed junction keeps its traffic light (``signals = "on"``) for a
    controller that drives its vehicles through the junction: they would run its lights."""
    table = junction_table(net, all_junctions=True)
    lit = table.loc[table["id"].isin(scn.network.junctions) & table["type"].str.startswith("traffic_light"), "id"]
    if len(lit):
        raise InputError(scn.source, "network.signals", "on",
                         f"{scn.controller.kind} drives the vehicles through its junctions and would run the "
                         f"lights of {', '.join(lit)}: use 'off', or sumo-tls for the signal programme")


def vehicle_specs(scn: Scenario, flow_vehicles: list[dict], controlled: bool) -> dict[str, dict]:
    """The keyword arguments of each vehicle's ``sim.sumo.VehicleInfo``, by id: the scenario's
    vehicles, then those of its flows. On a net file a vehicle has no intended path: the adapter
    picks it from the vehicle's lane and route when it reaches a managed junction. A human driver
    is never controlled, whatever the controller. A vehicle of a [[vtype]] with a ``max_speed``
    [m/s] and no ``desired_speed`` of its own desires that speed."""
    specs: dict[str, dict] = {}
    for v in scn.vehicles:
        vt = scn.vtype(v.vtype)
        typed = dict(vtype=sumo_type(vt, v.driver), desired_speed=_desired(v.desired_speed, vt))
        if v.route is not None:
            specs[v.id] = dict(approach="", lane="", movement="", kappa=v.kappa, intended_path=None,
                               controlled=controlled and v.driver == "av",
                               route=frozenset(v.route), driver=v.driver, **typed)
            continue
        specs[v.id] = dict(approach=v.approach, lane=v.lane, movement=v.movement, kappa=v.kappa,
                           intended_path=v.path_id, controlled=controlled and v.driver == "av", driver=v.driver,
                           exit_lane=v.exit_lane, exit_fixed=v.exit_lane is not None,
                           start_s=v.s0 if v.in_junction else None, **typed)
    for fv in flow_vehicles:
        driver = fv.get("driver", "av")
        vt = scn.vtype(fv.get("vtype"))
        typed = dict(vtype=sumo_type(vt, driver), desired_speed=_desired(None, vt))
        if fv.get("route") is not None:
            specs[fv["id"]] = dict(approach="", lane="", movement="", kappa=fv["kappa"], intended_path=None,
                                   controlled=controlled and driver == "av", route=frozenset(fv["route"]),
                                   driver=driver, **typed)
            continue
        pid = str(PathId(fv["approach"], fv["lane"], fv["movement"], default_exit_lane(fv["lane"], fv["movement"])))
        specs[fv["id"]] = dict(approach=fv["approach"], lane=fv["lane"], movement=fv["movement"],
                               kappa=fv["kappa"], intended_path=pid, controlled=controlled and driver == "av",
                               driver=driver, **typed)
    return specs


def _desired(own: float | None, vt) -> float | None:
    """[m/s] a vehicle's desired speed: its own, else its vtype's max_speed (None: the model's v_max)."""
    if own is not None or vt is None or vt.max_speed is None:
        return own
    return vt.max_speed


def control_period_steps(scn: Scenario) -> int:
    """Simulation steps per control period; an InputError unless the period is a whole number of them."""
    s = scn.scenario
    period_steps = max(1, int(round(scn.controller.period / s.step_length)))
    if abs(period_steps * s.step_length - scn.controller.period) > 1e-9:
        raise InputError(scn.source, "controller.period", scn.controller.period,
                         f"must be a multiple of scenario.step_length ({s.step_length:g} s)")
    return period_steps
