"""The closed loop of one run: SUMO (libsumo, or sumo-gui through TraCI with ``gui``) stepped on
the run's inputs, the controller deciding every control period, each step recorded.

With ``gui`` settings a :class:`~intersection_cosim.sim.gui.GuiView` draws each step's decisions;
the outputs are the same.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
from pathlib import Path
from typing import NamedTuple

import numpy as np

from intersection_cosim.control.base import ControlContext, Controller, World
from intersection_cosim.errors import InputError, RouteRefusal
from intersection_cosim.experiments.deadlock import StandstillWatch
from intersection_cosim.experiments.files import SUMOCFG_FILE, run_output_options
from intersection_cosim.experiments.memory_guard import MemoryGuard
from intersection_cosim.experiments.run_inputs import RunInputs, control_period_steps, vehicle_specs
from intersection_cosim.network.crossings import movement_crossings
from intersection_cosim.network.outline import junction_centre
from intersection_cosim.results.overlaps import OverlapLog
from intersection_cosim.scenario.model import Scenario
from intersection_cosim.v2x import Channel
from intersection_cosim.v2x.tracker import steady_sigma

log = logging.getLogger(__name__)


class Records(NamedTuple):
    """The rows the closed loop records, filled in step by step."""

    traj_rows: list[tuple]  # TRAJECTORY_COLUMNS, one per vehicle and control step
    step_rows: list[tuple]  # STEP_COLUMNS, one per control step
    game_rows: list[tuple]  # GAME_COLUMNS, one per game played
    game_steps: dict[tuple[str, str], int]  # (id, id) sorted -> control steps the pair played a game
    ended: list  # why the run ended early: at most one experiments.deadlock.Deadlock or
    #              experiments.memory_guard.MemoryLimit
    walker_rows: list[tuple]  # WALKER_COLUMNS, one per person near a crossing and control step
    overlaps: OverlapLog  # our own body-overlap check, every control step


class Simulated(NamedTuple):
    """What the simulation hands on: its vehicles, the recorded rows and where vehicles went."""

    infos: dict  # vehicle id -> sim.sumo.VehicleInfo
    records: Records
    final_paths: dict  # vehicle id -> the path it drove
    exit_lanes: dict  # vehicle id -> the exit lane it took
    v2x_counts: dict | None = None  # the V2X channel's message counts (None: perfect information)
    bodies: dict | None = None  # vehicle id -> (length, width) [m] of its SUMO vType (None: not read)
    collision_log: tuple = ()  # sim.collisions.CollisionRecord, SUMO's collisions step by step
    onboard_caps: int = 0  # [-] SUMO steps x vehicles in which the onboard guard lowered a command
    loaded: int = 0  # [-] vehicles SUMO loaded from the route files during the run (inserted or not)
    emission_classes: dict | None = None  # vType -> SUMO emission class of its vehicles
    onboard_crossing_caps: int = 0  # [-] of the onboard caps: held out of a crossing (control/safety/crossing_sense.py)


def simulate(scn: Scenario, folder: Path, inputs: RunInputs, gui=None) -> Simulated:
    """Run the closed loop in SUMO on the inputs in ``folder`` (libsumo; sumo-gui through TraCI
    with ``gui``); SUMO writes its own outputs there too."""
    # The simulator layer (libsumo) is loaded only by the process that runs a simulation, not by
    # a sweep's supervising process, which imports this module through experiments.executors.
    from intersection_cosim.sim.console import stderr_silenced
    from intersection_cosim.sim.gui import GuiView
    from intersection_cosim.sim.network_scheduler import NetworkScheduler
    from intersection_cosim.sim.sumo import LANE_CHANGE_MODE_STRATEGIC, LIBSUMO, SumoSimulation, VehicleInfo

    s, controller = scn.scenario, inputs.controller
    specs = vehicle_specs(scn, inputs.flow_vehicles, controller.controls_vehicles)
    infos = {vid: VehicleInfo(**spec) for vid, spec in specs.items()}
    m = scn.model
    bodies = tuple(sorted({(vt.length or m.vehicle_length, vt.width or m.vehicle_width) for vt in scn.vtypes}))  # [m]
    controller.setup(ControlContext(movements=inputs.movements, model=scn.model,
                                    control_period=scn.controller.period, settings=scn.controller_settings,
                                    etm=scn.controller.etm, bodies=bodies,
                                    position_noise=_seen_position_noise(scn)))
    scheduler = NetworkScheduler(controller, scn.controller.budget_ms, scn.controller.realtime,
                                 scn.controller.work_clock_ms)
    if gui is not None and not scn.network.generated:  # look at the managed junction, not the origin
        gui = dataclasses.replace(gui, centre=junction_centre(inputs.net, scn.network.junctions[0]))
    view = GuiView(gui, scn.model.vehicle_length) if gui is not None else None
    observers = [view.show] if view is not None else []  # called with each step's (World, Decisions)
    generic = {} if scn.network.generated else dict(
        lane_change_mode=LANE_CHANGE_MODE_STRATEGIC, adopt_controlled=controller.controls_vehicles,
        adopt_road_speed=scn.network.desired_speed == "road",
        control_range=scn.network.control_range,
        crossings=movement_crossings(inputs.movements), people_first=controller.controls_vehicles)
    sim = SumoSimulation(movements=inputs.movements, vehicles=infos, step_length=s.step_length,
                         exit_distance=s.exit_distance, backend=view.backend() if view is not None else LIBSUMO,
                         onboard=scn.controller.onboard if controller.controls_vehicles else None, **generic)
    # libsumo prints its warnings on the console besides sumo.log: they stay in the file
    with stderr_silenced() if view is None else contextlib.nullcontext():
        return _simulate(scn, folder, inputs, sim, scheduler, observers, view)


def _seen_position_noise(scn: Scenario) -> float:
    """[m] the standard deviation of the positions the controller sees: a converged V2X track's
    (v2x/tracker.py), 0 without a V2X link."""
    v = scn.v2x
    if not v.enabled:
        return 0.0
    return steady_sigma(v.position_noise, v.speed_noise, v.period or scn.controller.period, v.track_accel_noise)


def _simulate(scn: Scenario, folder: Path, inputs: RunInputs, sim, scheduler, observers: list, view) -> Simulated:
    """:func:`simulate`'s loop on the made ``sim`` (sim.sumo.SumoSimulation), closed at the end."""
    s = scn.scenario
    try:
        # SUMO resolves the config's paths against its folder; the run's own outputs are given on
        # the command line (the config's go to replay/)
        sim.start(str(folder / SUMOCFG_FILE), run_output_options(folder, s.ssm, s.duration + s.drain))
        if _signals_off(scn, inputs.controller):
            sim.switch_signals_off()
        if view is not None:
            view.attach(sim.api)
        channel = (Channel(scn.v2x, inputs.movements, scn.controller.period, s.seed)
                   if scn.v2x.enabled else None)
        try:
            end = (s.begin or 0.0) + s.duration + s.drain  # [s] SUMO's clock
            records = _closed_loop(sim, scheduler, observers, control_period_steps(scn), end, channel,
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
    return Simulated(infos, records, final_paths, exit_lanes, channel.counts if channel is not None else None,
                     {vid: body[:2] for vid, body in sim.bodies.items()} if scn.vtypes else None,
                     tuple(sim.collision_log), sim.guard.caps if sim.guard is not None else 0, sim.loaded,
                     dict(sim.emission_classes), sim.guard.crossing_caps if sim.guard is not None else 0)


def _route_error(scn: Scenario, exc: RouteRefusal) -> Exception:
    """The InputError of a route SUMO could not find in mid-run: one of the user's own route file
    (ours are checked when the scenario loads; anything else is a defect, raised as it is)."""
    routes = scn.network.routes
    if not routes:
        return RuntimeError(f"SUMO could not route a vehicle of the scenario's own demand {exc}")
    return InputError(scn.source, "network.routes", routes[0] if len(routes) == 1 else list(routes),
                      f"SUMO cannot route it {exc}")


def _signals_off(scn: Scenario, controller: Controller) -> bool:
    """Whether the managed junctions' lights go off: on a net file with ``signals = "off"``,
    for every controller but SUMO's own signal programme (``sumo-tls``)."""
    return not scn.network.generated and scn.network.signals == "off" and controller.junction_type != "traffic_light"


def _closed_loop(sim, scheduler, observers: list, period_steps: int, end_time: float, channel=None,
                 guards: tuple = ()) -> Records:
    """Step the started ``sim`` (sim.sumo.SumoSimulation) until ``end_time`` [s], no vehicle is
    left or one of ``guards`` ends the run (``check(time, sim)`` not None: experiments.deadlock,
    experiments.memory_guard); every ``period_steps`` steps read the world, let ``scheduler``
    (sim.network_scheduler's, one controller per junction) decide, command, show the step to
    ``observers`` and record it. Returns the recorded rows.

    With a ``channel`` (v2x.Channel) the vehicles send their states when it says so, the
    controller decides on the World the channel shows it, and its decisions reach SUMO when the
    channel delivers them (checked every step); the records keep SUMO's state."""
    records = Records([], [], [], {}, [], [], OverlapLog())
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
            records.overlaps.check(world.time, *sim.junction_bodies())
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


def _record_step(records: Records, world: World, step) -> None:
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
    records.step_rows.extend(record.row() for record in step.records)
    kept = set(decisions.kept)
    for (a, b), junction in zip(decisions.pairs, step.pair_junctions):
        records.game_rows.append((world.time, a, b, junction, (a, b) not in kept))
        key = (a, b) if a < b else (b, a)
        records.game_steps[key] = records.game_steps.get(key, 0) + 1
