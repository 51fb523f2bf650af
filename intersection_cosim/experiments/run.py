"""One run of one scenario: SUMO inputs -> closed loop through libsumo -> CSVs and summary.

With ``gui`` settings the same loop drives sumo-gui through TraCI instead, and a
:class:`~intersection_cosim.sim.gui.GuiView` draws each step's decisions; the outputs are the same.

Everything is written into a temporary folder beside the output folder and renamed into place
when the run has finished, so a crashed or interrupted run leaves no half-written results.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import os
import platform
import shutil
import tempfile
from pathlib import Path
from typing import Mapping, NamedTuple

import numpy as np
import pandas as pd

from intersection_cosim import __version__
from intersection_cosim.control import registry
from intersection_cosim.control.base import ControlContext, Controller, Diagnostics, World
from intersection_cosim.errors import InputError, RouteRefusal
from intersection_cosim.experiments.deadlock import StandstillWatch
from intersection_cosim.experiments.memory_guard import MemoryGuard
from intersection_cosim.experiments.files import (ROUTE_FILE, SUMOCFG_FILE, run_output_options, write_routes,
                                                  write_sumocfg)
from intersection_cosim.network.build import NET_FILE
from intersection_cosim.network.cache import cached_net, sumo_version
from intersection_cosim.network.conflicts import movement_conflicts
from intersection_cosim.network.crossings import movement_crossings
from intersection_cosim.network.junction_net import junction_table, load_movements
from intersection_cosim.network.outline import junction_centre
from intersection_cosim.network.path_id import PathId
from intersection_cosim.network.movements import Movements, paper_movements
from intersection_cosim.network.paths import MovementPath
from intersection_cosim.network.spec import IntersectionSpec
from intersection_cosim.network.xml_files import copy_plain
from intersection_cosim.results.layout import (COLLISIONS_FILE, CONVERGENCE_COLUMNS, CONVERGENCE_FILE, GAME_COLUMNS,
                                               GAMES_FILE, PAIRS_FILE,
                                               RUN_MARKER, SSM_FILE, STEP_COLUMNS, STEPS_FILE, TRAJECTORIES_FILE,
                                               TRAJECTORY_COLUMNS, TRIPINFO_FILE, VEHICLES_FILE, WALKER_COLUMNS,
                                               WALKERS_FILE)
from intersection_cosim.results.metrics import pair_table, vehicle_table
from intersection_cosim.results.sumo_outputs import PEDESTRIAN_COLLISIONS, read_collisions, read_ssm, read_tripinfo
from intersection_cosim.scenario.load import default_exit_lane, draw_drivers, generate_flow_vehicles
from intersection_cosim.scenario.vtypes import sumo_type
from intersection_cosim.scenario.model import Scenario
from intersection_cosim.scenario.network import route_file_persons
from intersection_cosim.settings import to_dict
from intersection_cosim.v2x import Channel

log = logging.getLogger(__name__)



def prepare_output(out: Path, force: bool = False) -> Path:
    """Check that ``out`` can be written and return the temporary folder to write into.

    ``out`` must be new, an empty folder or, with ``force``, a previous run's folder (replaced
    when the new run has finished); anything else is refused.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError("--out", "out", str(out), "is a file, not a folder")
    if (out / RUN_MARKER).is_file():
        if not force:
            raise InputError("--out", "out", str(out), f"holds a finished run ({RUN_MARKER}); use --force to "
                             "replace it, or another --out")
    elif out.is_dir() and any(out.iterdir()):
        raise InputError("--out", "out", str(out), "exists and is not a previous run's folder; not overwriting it")
    parent = out.parent if str(out.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=parent))
    except OSError as exc:
        raise InputError("--out", "out", str(out), f"cannot be written ({exc.strerror})") from None
    umask = os.umask(0)
    os.umask(umask)
    tmp.chmod(0o777 & ~umask)  # mkdtemp makes it private; a run folder is an ordinary folder
    return tmp


def finish_output(tmp: Path, out: Path) -> None:
    """Atomically put the finished run in place (replacing a previous run's folder)."""
    if out.exists():
        old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
        os.replace(out, old / "run")
        os.replace(tmp, out)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(tmp, out)


def resolved_settings(scn: Scenario) -> dict:
    """The settings a run of ``scn`` records in summary.json's ``settings`` (scenario, network,
    controller, model and the controller's [controller.*] tables after defaults and overrides):
    what makes two runs the same run."""
    return {"scenario": to_dict(scn.scenario), "network": to_dict(scn.network), "human": to_dict(scn.human),
            "controller": to_dict(scn.controller), "model": to_dict(scn.model), "v2x": to_dict(scn.v2x),
            "controller_settings": to_dict(scn.controller_settings)
            if dataclasses.is_dataclass(scn.controller_settings) else None,
            "vtypes": [to_dict(vt) for vt in scn.vtypes]}


def versions() -> dict[str, str]:
    """The versions a run records in summary.json (this package, SUMO, Python and the numerics)."""
    import osqp
    import scipy

    return {"intersection_cosim": __version__, "sumo": sumo_version(), "python": platform.python_version(),
            "numpy": np.__version__, "scipy": scipy.__version__, "pandas": pd.__version__,
            "osqp": getattr(osqp, "__version__", "unknown")}


def run_scenario(scn: Scenario, out: str | Path, *, force: bool = False, fail_hook=None, gui=None) -> dict:
    """Run ``scn`` and write its results into ``out``; return the summary dict.

    ``out`` holding a finished run is refused (InputError) unless ``force``, which replaces it.
    ``gui`` (a :class:`~intersection_cosim.sim.gui.GuiSettings`) shows the run live in sumo-gui;
    None (the default) runs headless through libsumo. ``fail_hook`` (tests only) is called after
    the simulation loop, before the rename, so tests can simulate a crash at the worst moment.
    """
    out = Path(out)
    if gui is not None:
        from intersection_cosim.sim.gui import check_display

        check_display()  # before anything is written
    tmp = prepare_output(out, force)
    try:
        summary = _run_into(scn, tmp, gui)
        if fail_hook is not None:
            fail_hook()
        finish_output(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return summary


class _Inputs(NamedTuple):
    """A run's controller and the inputs its SUMO files were written from."""

    controller: Controller
    net: Path  # the cached net file (copied into the run's folder)
    movements: Movements  # the managed junctions' movement paths
    flow_vehicles: list[dict]  # the vehicles drawn from the scenario's flows

    @property
    def paths(self) -> Mapping[str, MovementPath]:
        return self.movements.paths


class _Records(NamedTuple):
    """The rows the closed loop records, filled in step by step."""

    traj_rows: list[tuple]  # TRAJECTORY_COLUMNS, one per vehicle and control step
    step_rows: list[tuple]  # STEP_COLUMNS, one per control step
    game_rows: list[tuple]  # GAME_COLUMNS, one per game played
    game_steps: dict[tuple[str, str], int]  # (id, id) sorted -> control steps the pair played a game
    ended: list  # why the run ended early: at most one experiments.deadlock.Deadlock or
    #              experiments.memory_guard.MemoryLimit
    walker_rows: list[tuple]  # WALKER_COLUMNS, one per person near a crossing and control step


class _Simulated(NamedTuple):
    """What the simulation hands on: its vehicles, the recorded rows and where vehicles went."""

    infos: dict  # vehicle id -> sim.sumo.VehicleInfo
    records: _Records
    final_paths: dict  # vehicle id -> the path it drove
    exit_lanes: dict  # vehicle id -> the exit lane it took
    v2x_counts: dict | None = None  # the V2X channel's message counts (None: perfect information)
    bodies: dict | None = None  # vehicle id -> (length, width) [m] of its SUMO vType (None: not read)


class _Tables(NamedTuple):
    """A run's result tables."""

    traj: pd.DataFrame
    steps: pd.DataFrame
    tripinfo: pd.DataFrame
    collisions: pd.DataFrame
    vehicles: pd.DataFrame
    pairs: pd.DataFrame


def _run_into(scn: Scenario, folder: Path, gui=None) -> dict:
    """Run ``scn`` with every output written into ``folder``; return the summary dict."""
    inputs = _write_inputs(scn, folder)
    simulated = _simulate(scn, folder, inputs, gui)
    tables = _result_tables(scn, folder, inputs, simulated)
    diagnostics = inputs.controller.diagnostics()
    _write_tables(folder, tables, simulated.records, diagnostics)
    summary = _summary(scn, simulated.infos, tables, diagnostics, gui)
    ended = simulated.records.ended
    summary["ended_early"] = ended[0]._asdict() if ended else None
    if simulated.v2x_counts is not None:
        summary["v2x"] = dict(simulated.v2x_counts)
    with open(folder / RUN_MARKER, "w") as fh:
        json.dump(summary, fh, indent=2)
    return summary


def _write_inputs(scn: Scenario, folder: Path) -> _Inputs:
    """Create the run's controller and write its SUMO inputs (net, routes, config) into ``folder``."""
    s = scn.scenario
    controller = registry.create_per_junction(scn.controller.kind, scn.controller_settings, s.junction_type)
    net, movements = _movements(scn, controller)
    copy_plain(net, folder / NET_FILE)  # a gzipped net is written out plain
    rng = np.random.default_rng(s.seed)
    flow_vehicles = draw_drivers(scn, generate_flow_vehicles(scn, rng))
    _check_attacked(scn, flow_vehicles)
    write_routes(folder / ROUTE_FILE, scn, movements.paths, flow_vehicles)
    write_sumocfg(folder / SUMOCFG_FILE, NET_FILE, scn)
    return _Inputs(controller, net, movements, flow_vehicles)


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
    if scn.network.routes and not controller.yields_to_pedestrians and route_file_persons(scn.network.routes):
        raise InputError(scn.source, "network.routes", scn.network.routes,
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


def _vehicle_specs(scn: Scenario, flow_vehicles: list[dict], controlled: bool) -> dict[str, dict]:
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


def _period_steps(scn: Scenario) -> int:
    """Simulation steps per control period; an InputError unless the period is a whole number of them."""
    s = scn.scenario
    period_steps = max(1, int(round(scn.controller.period / s.step_length)))
    if abs(period_steps * s.step_length - scn.controller.period) > 1e-9:
        raise InputError(scn.source, "controller.period", scn.controller.period,
                         f"must be a multiple of scenario.step_length ({s.step_length:g} s)")
    return period_steps


def _simulate(scn: Scenario, folder: Path, inputs: _Inputs, gui=None) -> _Simulated:
    """Run the closed loop in SUMO on the inputs in ``folder`` (libsumo; sumo-gui through TraCI
    with ``gui``); SUMO writes its own outputs there too."""
    # The simulator layer (libsumo) is loaded only by the process that runs a simulation, not by
    # a sweep's supervising process, which imports this module through experiments.executors.
    from intersection_cosim.sim.gui import GuiView
    from intersection_cosim.sim.network_scheduler import NetworkScheduler
    from intersection_cosim.sim.sumo import LANE_CHANGE_MODE_STRATEGIC, LIBSUMO, SumoSimulation, VehicleInfo

    s, controller = scn.scenario, inputs.controller
    specs = _vehicle_specs(scn, inputs.flow_vehicles, controller.controls_vehicles)
    infos = {vid: VehicleInfo(**spec) for vid, spec in specs.items()}
    period_steps = _period_steps(scn)
    m = scn.model
    bodies = tuple(sorted({(vt.length or m.vehicle_length, vt.width or m.vehicle_width) for vt in scn.vtypes}))  # [m]
    controller.setup(ControlContext(movements=inputs.movements, model=scn.model,
                                    control_period=scn.controller.period, settings=scn.controller_settings,
                                    etm=scn.controller.etm, bodies=bodies,
                                    position_noise=scn.v2x.position_noise if scn.v2x.enabled else 0.0))
    scheduler = NetworkScheduler(controller, scn.controller.budget_ms, scn.controller.realtime,
                                 scn.controller.work_clock_ms)
    if gui is not None and not scn.network.generated:  # look at the managed junction, not the origin
        gui = dataclasses.replace(gui, centre=junction_centre(inputs.net, scn.network.junctions[0]))
    view = GuiView(gui, scn.model.vehicle_length) if gui is not None else None
    observers = [view.show] if view is not None else []  # called with each step's (World, Decisions)
    generic = {} if scn.network.generated else dict(
        lane_change_mode=LANE_CHANGE_MODE_STRATEGIC, adopt_controlled=controller.controls_vehicles,
        control_range=scn.network.control_range,
        crossings=movement_crossings(inputs.movements), people_first=controller.controls_vehicles)
    sim = SumoSimulation(movements=inputs.movements, vehicles=infos, step_length=s.step_length,
                         exit_distance=s.exit_distance, backend=view.backend() if view is not None else LIBSUMO,
                         **generic)
    try:
        # SUMO resolves the config's paths against its folder; the run's own outputs are given on
        # the command line (the config's go to replay/)
        sim.start(str(folder / SUMOCFG_FILE), run_output_options(folder, scn.scenario.ssm))
        if _signals_off(scn, controller):
            sim.switch_signals_off()
        if view is not None:
            view.attach(sim.api)
        channel = (Channel(scn.v2x, inputs.movements, scn.controller.period, s.seed)
                   if scn.v2x.enabled else None)
        try:
            records = _closed_loop(sim, scheduler, observers, period_steps, s.duration + s.drain, channel,
                                   (StandstillWatch(s.deadlock_time), MemoryGuard(s.memory_limit)))
        except RouteRefusal as exc:
            raise _route_error(scn, exc) from None
        final_paths = {**sim.left_paths, **sim.current_path}
        exit_lanes = dict(sim.exit_lane_taken)
        infos = dict(sim.vehicles)  # with the vehicles of the user's own route file
    finally:
        sim.close()
        if view is not None:
            view.close()
    return _Simulated(infos, records, final_paths, exit_lanes, channel.counts if channel is not None else None,
                      {vid: body[:2] for vid, body in sim.bodies.items()} if scn.vtypes else None)


def _route_error(scn: Scenario, exc: RouteRefusal) -> Exception:
    """The InputError of a route SUMO could not find in mid-run: one of the user's own route file
    (ours are checked when the scenario loads; anything else is a defect, raised as it is)."""
    if scn.network.routes is None:
        return RuntimeError(f"SUMO could not route a vehicle of the scenario's own demand {exc}")
    return InputError(scn.source, "network.routes", scn.network.routes, f"SUMO cannot route it {exc}")


def _signals_off(scn: Scenario, controller: Controller) -> bool:
    """Whether the managed junctions' lights go off: on a net file with ``signals = "off"``,
    for every controller but SUMO's own signal programme (``sumo-tls``)."""
    return not scn.network.generated and scn.network.signals == "off" and controller.junction_type != "traffic_light"


def _closed_loop(sim, scheduler, observers: list, period_steps: int, end_time: float, channel=None,
                 guards: tuple = ()) -> _Records:
    """Step the started ``sim`` (sim.sumo.SumoSimulation) until ``end_time`` [s], no vehicle is
    left or one of ``guards`` ends the run (``check(time, sim)`` not None: experiments.deadlock,
    experiments.memory_guard); every ``period_steps`` steps read the world, let ``scheduler``
    (sim.network_scheduler's, one controller per junction) decide, command, show the step to
    ``observers`` and record it. Returns the recorded rows.

    With a ``channel`` (v2x.Channel) the vehicles send their states when it says so, the
    controller decides on the World the channel shows it, and its decisions reach SUMO when the
    channel delivers them (checked every step); the records keep SUMO's state."""
    records = _Records([], [], [], {}, [], [])
    sim.advance()  # time 0: insert the vehicles that depart at once
    k = 0
    while sim.time < end_time - 1e-9 and (sim.remaining() > 0):
        control = k % period_steps == 0
        sends = channel is not None and channel.sends_at(sim.time)
        if control or sends:
            world = sim.world()  # read
        if sends:
            channel.uplink(world)
        if control:
            seen = world if channel is None else channel.observe(world)
            step = scheduler.step(seen)  # decide
            if channel is None:
                sim.command(step.decisions)
            else:
                channel.send(step.decisions, sim.time)
            for observe in observers:
                observe(world, step.decisions)
            _record_step(records, world, step)
            if (end := _early_end(guards, world.time, sim)) is not None:
                log.warning("%s", end.message())
                records.ended.append(end)
                break
        if channel is not None and (arrived := channel.deliver(sim.time)) is not None:
            sim.command(arrived)
        sim.write()  # write
        scheduler.pace(sim.time)
        sim.advance()  # step
        k += 1
    return records


def _early_end(guards: tuple, time: float, sim):
    """The first guard's reason to end the run at ``time`` [s], or None."""
    for guard in guards:
        if (end := guard.check(time, sim)) is not None:
            return end
    return None


def _record_step(records: _Records, world: World, step) -> None:
    """Append one control step (sim.network_scheduler's NetworkStep) to ``records``: a trajectory
    row per vehicle, each junction's StepRecord and a row per game, counting the steps each pair
    played."""
    decisions = step.decisions
    for i, vid in enumerate(world.ids):
        records.traj_rows.append((world.time, vid, world.x[i], world.y[i], world.v[i], world.a[i],
                                  world.heading[i], world.lanes[i], world.role[i],
                                  world.path_ids[i], world.s[i], decisions.accel.get(vid, np.nan)))
    records.walker_rows.extend((world.time, w.id, w.crossing, w.position, w.direction, w.speed, w.x, w.y)
                               for w in world.walkers)
    records.step_rows.extend(dataclasses.astuple(record) for record in step.records)
    kept = set(decisions.kept)
    for (a, b), junction in zip(decisions.pairs, step.pair_junctions):
        records.game_rows.append((world.time, a, b, junction, (a, b) not in kept))
        key = (a, b) if a < b else (b, a)
        records.game_steps[key] = records.game_steps.get(key, 0) + 1


def _result_tables(scn: Scenario, folder: Path, inputs: _Inputs, simulated: _Simulated) -> _Tables:
    """The run's tables, from the loop's records and the outputs SUMO wrote into ``folder``."""
    traj = pd.DataFrame(simulated.records.traj_rows, columns=TRAJECTORY_COLUMNS)
    steps = pd.DataFrame(simulated.records.step_rows, columns=STEP_COLUMNS)
    tripinfo = read_tripinfo(folder / TRIPINFO_FILE)
    ssm = read_ssm(folder / SSM_FILE)
    collisions = read_collisions(folder / COLLISIONS_FILE)
    vehicles = vehicle_table(_with_movements(simulated.infos, simulated.final_paths, inputs.paths), tripinfo,
                             simulated.exit_lanes, collisions)
    touch = max([scn.model.vehicle_width] + [vt.width for vt in scn.vtypes if vt.width is not None])  # [m]
    pairs = pair_table(traj, simulated.final_paths, inputs.paths, movement_conflicts(inputs.movements, touch),
                       scn.model, ssm, simulated.records.game_steps,
                       {vid: (info.driver, info.vtype) for vid, info in simulated.infos.items()}, simulated.bodies)
    return _Tables(traj, steps, tripinfo, collisions, vehicles, pairs)


def _with_movements(infos: dict, final_paths: dict[str, str], paths: Mapping[str, MovementPath]) -> dict:
    """``infos`` with the approach (edge) and movement of the path each vehicle without a named
    one took (on a net file vehicles are known by their routes)."""
    out = {}
    for vid, info in infos.items():
        pid = final_paths.get(vid)
        if not info.approach and pid in paths:
            info = dataclasses.replace(info, approach=paths[pid].approach, movement=paths[pid].movement)
        out[vid] = info
    return out


def _write_tables(folder: Path, tables: _Tables, records: _Records, diagnostics: Diagnostics) -> None:
    """Write the run's CSVs into ``folder`` (convergence.csv only for a controller that solves games,
    walkers.csv only for a run with people at its crossings)."""
    tables.traj.to_csv(folder / TRAJECTORIES_FILE, index=False, float_format="%.4f")
    if diagnostics.convergence is not None:
        rows = [(r.time, r.vehicle_a, r.vehicle_b, r.solver, r.status, m + 1, res)
                for r in diagnostics.convergence for m, res in enumerate(r.residuals)]
        pd.DataFrame(rows, columns=CONVERGENCE_COLUMNS).to_csv(folder / CONVERGENCE_FILE, index=False,
                                                               float_format="%.6g")
    tables.steps.to_csv(folder / STEPS_FILE, index=False, float_format="%.4f")
    pd.DataFrame(records.game_rows, columns=GAME_COLUMNS).to_csv(folder / GAMES_FILE, index=False, float_format="%.4f")
    if records.walker_rows:
        pd.DataFrame(records.walker_rows, columns=WALKER_COLUMNS).to_csv(folder / WALKERS_FILE, index=False,
                                                                         float_format="%.4f")
    tables.vehicles.to_csv(folder / VEHICLES_FILE, index=False, float_format="%.4f")
    tables.pairs.to_csv(folder / PAIRS_FILE, index=False, float_format="%.4f")


def _summary(scn: Scenario, infos: dict, tables: _Tables, diagnostics: Diagnostics, gui=None) -> dict:
    """The run's summary.json: what ran, with which settings and versions, counts and metrics."""
    s = scn.scenario
    tripinfo, collisions, steps = tables.tripinfo, tables.collisions, tables.steps
    vehicles, pairs = tables.vehicles, tables.pairs
    step_compute = steps.groupby("time", sort=False)["compute_ms"].sum()  # [ms]
    summary = {
        "scenario": s.name, "source": scn.source, "controller": scn.controller.kind, "seed": s.seed,
        "settings": resolved_settings(scn),
        "versions": versions(),
        "counts": {"vehicles": int(len(infos)), "departed": int(tripinfo["depart"].notna().sum()),
                   "arrived": int(tripinfo["arrival"].ge(0).sum()), "collisions": int(len(collisions)),
                   "control_steps": int(steps["time"].nunique()), "junction_steps": int(len(steps)),
                   "deadline_misses": int(steps["deadline_missed"].sum()),
                   "fallbacks": int(steps["fallback"].sum()),
                   "steps_with_deferred_work": int(steps["deferred"].gt(0).sum()),
                   "safety_interventions": diagnostics.safety_interventions,
                   "box_rule_clearances": diagnostics.box_rule_clearances,
                   "pedestrian_collisions": int(collisions["type"].isin(PEDESTRIAN_COLLISIONS).sum()),
                   "pedestrian_holds": diagnostics.pedestrian_holds},
        "metrics": {
            "mean_travel_time": _num(vehicles["travel_time"].mean()),
            "min_ttc": _num(pairs["min_ttc"].min()) if len(pairs) else None,
            "min_ttc_ssm": _num(pairs["min_ttc_ssm"].min()) if len(pairs) else None,
            # [ms] per control step, summed over the junctions' controllers
            "compute_ms_median": _num(step_compute.median()),
            "compute_ms_p95": _num(step_compute.quantile(0.95)),
        },
    }
    if gui is not None:
        summary["gui"] = {"simulator": "sumo-gui through TraCI", "delay_ms": gui.delay_ms}
    return summary


def _num(x) -> float | None:
    return None if x is None or (isinstance(x, float) and np.isnan(x)) else float(x)
