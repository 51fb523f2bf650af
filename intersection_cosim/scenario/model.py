"""Typed scenario objects, validated at load time (see ``scenario/load.py``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from intersection_cosim.control.safety.onboard import OnboardSettings
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.spec import JUNCTION_TYPES
from intersection_cosim.settings import non_negative, positive
from intersection_cosim.v2x.settings import V2XSettings


@dataclass(frozen=True)
class ScenarioSettings:
    """The ``[scenario]`` table."""

    name: str = "scenario"  # [-] used in output folder names
    begin: float | None = None  # [s] SUMO's clock when the run starts (None: the [network] sumocfg's
    #                             begin, else 0); route files with real clock times run unchanged
    duration: float = 60.0  # [s] demand window counted from ``begin``: flows generate vehicles and
    #                         a route file's vehicles depart within [begin, begin + duration)
    #                         (default with a sumocfg: its end - begin)
    keep_all_demand: bool = False  # [-] true: every vehicle of a [network] route file departs as
    #                               written, also after the window (SUMO skips those before begin)
    drain: float = 60.0  # [s] after ``duration`` the run goes on this long for vehicles to leave;
    #                      it ends as soon as every vehicle has left
    step_length: float = 0.05  # [s] SUMO step; the control period is a multiple of it
    seed: int = 42  # [-] SUMO's --seed and the seed of every random draw (flows, kappa)
    junction_type: str = "priority"  # [-] SUMO node type of the centre for the sumo controller
    exit_distance: float = 50.0  # [m] past the junction where vehicles arrive (leave the network)
    deadlock_time: float = 120.0  # [s] end the run once every vehicle in the network has stood still
    #                              (< 0.1 m/s) this long: a deadlock (experiments/deadlock.py); 0: never
    memory_limit: float = 8.0  # [GB] end the run once its process holds more (SUMO's SSM device grows
    #                            with long queues; experiments/memory_guard.py); 0: never
    ssm: bool = True  # [-] SUMO's SSM device on every vehicle: ssm.xml and pairs.csv's min_ttc_ssm and
    #                   pet_ssm; false drops its cost (in a jam most of SUMO's step) and its memory

    def check(self) -> list[tuple[str, str]]:
        problems = positive(self, "duration", "step_length", "exit_distance")
        if self.begin is not None and (isinstance(self.begin, bool) or not isinstance(self.begin, (int, float))
                                       or not math.isfinite(self.begin) or self.begin < 0):
            problems.append(("begin", "must be a number >= 0 [s]"))
        problems += non_negative(self, "drain", "deadlock_time", "memory_limit")
        if self.junction_type not in JUNCTION_TYPES:
            problems.append(("junction_type", f"must be one of {', '.join(JUNCTION_TYPES)}"))
        if self.seed < 0:
            problems.append(("seed", "must be >= 0"))
        return problems


@dataclass(frozen=True)
class ControllerSettings:
    """The ``[controller]`` table: which controller drives the AVs and its timing."""

    kind: str = "sumo"  # [-] registry name, see intersection_cosim.control
    period: float = 0.1  # [s] control period; a multiple of the SUMO step
    budget_ms: float = 100.0  # [ms] time budget of one control step (HIL deadline)
    work_clock_ms: float = 0.0  # [ms] > 0: keep budget_ms by a work clock, this much per QP solve
    #                             (an emulated box; the same run on any machine); 0: the wall clock
    etm: bool = True  # [-] event-triggered mechanism on (games only for risky pairs)
    realtime: bool = False  # [-] pace the simulation to the wall clock
    # [controller.onboard]: every commanded vehicle's own guard behind the vehicle ahead, whatever the
    # controller (control/safety/onboard.py)
    onboard: OnboardSettings = field(default_factory=OnboardSettings)

    def check(self) -> list[tuple[str, str]]:
        return positive(self, "period", "budget_ms") + non_negative(self, "work_clock_ms")


DRIVERS = ("av", "human")  # [-] who drives a vehicle: the controller (av) or SUMO's own model (human)
HUMAN_MODELS = ("Krauss", "IDM")  # [-] SUMO car-following models a human may drive by


@dataclass(frozen=True)
class HumanDriverSettings:
    """The ``[human]`` table: the SUMO vType ``human`` of every human-driven vehicle.

    A human is driven by SUMO's own car-following model and right of way at every junction and is
    never commanded by the controller. The defaults are SUMO's own defaults for a passenger car.
    """

    model: str = "Krauss"  # [-] SUMO carFollowModel: "Krauss" or "IDM"
    accel: float = 2.6  # [m/s^2] maximum acceleration
    decel: float = 4.5  # [m/s^2] comfortable deceleration
    emergency_decel: float = 9.0  # [m/s^2] hardest braking SUMO allows it
    sigma: float = 0.5  # [-] Krauss driver imperfection (0 = perfect; unused by IDM)
    tau: float = 1.0  # [s] desired time headway
    min_gap: float = 2.5  # [m] standstill gap to the leader
    delta: float = 4.0  # [-] IDM acceleration exponent (unused by Krauss)
    speed_factor: float = 1.0  # [-] its desired speed / the lane's speed limit (capped by the model's v_max)

    def check(self) -> list[tuple[str, str]]:
        problems = positive(self, "accel", "decel", "emergency_decel", "tau", "delta", "speed_factor")
        problems += non_negative(self, "min_gap")
        if self.model not in HUMAN_MODELS:
            problems.append(("model", f"must be one of {', '.join(HUMAN_MODELS)}"))
        if not 0.0 <= self.sigma <= 1.0:
            problems.append(("sigma", "must be in [0, 1]"))
        if self.emergency_decel < self.decel:
            problems.append(("emergency_decel", "must be >= decel"))
        return problems


@dataclass(frozen=True)
class VehicleType:
    """A ``[[vtype]]`` table: a class of vehicles with its own body, limits and driver.

    ``None`` fields take the run's default (the ``av`` vType's): the model's vehicle_length /
    vehicle_width / v_max, the game's a_max and -a_min for accel / decel. Its vehicles get the SUMO
    vType of the same id; an AV-type vehicle drawn human by a flow's ``av_share`` (or given
    ``driver = "human"``) gets ``<id>.human``: the same body and limits, driven by the [human]
    table's car-following model.
    """

    id: str  # [-] the type's id, which vehicles and flows name in their vtype key
    length: float | None = None  # [m] bumper to bumper (None: ModelSettings.vehicle_length)
    width: float | None = None  # [m] (None: ModelSettings.vehicle_width)
    accel: float | None = None  # [m/s^2] strongest acceleration; caps its planned a (None: the game's a_max)
    decel: float | None = None  # [m/s^2] comfortable (planned) braking, > 0 (None: the game's -a_min)
    max_speed: float | None = None  # [m/s] its maximum speed (None: ModelSettings.v_max)
    kappa: float | None = None  # [-] kappa of its vehicles that give none (None: they must give one)
    driver: str = "av"  # [-] "av" (av_share of a flow applies) or "human" (every vehicle of it is human)
    color: tuple[int, ...] = ()  # [-] SUMO colour r, g, b (0-255); () = SUMO's default
    min_gap: float | None = None  # [m] SUMO's standstill gap (None: 2.0 for AVs, [human] min_gap for humans)
    from_routes: bool = False  # [-] a vType of the [network] routes file (not written again; not a TOML key)

    def check(self) -> list[tuple[str, str]]:
        problems = []
        for name in ("length", "width", "accel", "decel", "max_speed"):
            value = getattr(self, name)
            if value is not None and not (isinstance(value, (int, float)) and not isinstance(value, bool)
                                          and math.isfinite(value) and value > 0):
                problems.append((name, "must be a finite number > 0"))
        if self.min_gap is not None and not (isinstance(self.min_gap, (int, float)) and not isinstance(self.min_gap, bool)
                                             and math.isfinite(self.min_gap) and self.min_gap >= 0):
            problems.append(("min_gap", "must be a finite number >= 0"))
        if self.kappa is not None and not (isinstance(self.kappa, (int, float)) and not isinstance(self.kappa, bool)
                                           and 0.0 <= self.kappa <= 1.0):
            problems.append(("kappa", "must be a number in [0, 1]"))
        if self.driver not in DRIVERS:
            problems.append(("driver", f"must be one of {', '.join(DRIVERS)}"))
        if self.color and (len(self.color) not in (3, 4) or any(not 0 <= c <= 255 for c in self.color)):
            problems.append(("color", "must be [r, g, b] (or [r, g, b, a]), each 0-255"))
        return problems


PAPER_JUNCTION = "C"  # the generated net's centre node (network/build.py)
SIGNALS = ("off", "on")  # [network] signals: traffic lights of managed junctions switched off / kept
DESIRED_SPEEDS = ("road", "v_max")  # [network] desired_speed: of the user's route-file vehicles


@dataclass(frozen=True)
class NetworkSettings:
    """The ``[network]`` table: the SUMO net a run drives on and the junctions the controller manages.

    ``file`` None is the generated paper net (built per ``scenario.junction_type``); then the other
    fields keep their defaults. Paths are stored resolved: absolute, ``$VARS`` and ``~`` expanded.
    """

    file: str | None = None  # [-] absolute path of a SUMO .net.xml; None = the generated paper net
    junctions: tuple[str, ...] = (PAPER_JUNCTION,)  # [-] ids of the net's junctions the controller manages
    signals: str = "off"  # [-] traffic-light junctions among them: "off" = run unsignalized, "on" = keep the lights
    control_range: float = 100.0  # [m] upstream of a junction where the controller takes a vehicle over
    desired_speed: str = "road"  # [-] what a vehicle of the user's route files desires (J_e, Eq. 24): "road" = the
    #                              speed limit of its lane into each managed junction, at most its vType's maxSpeed,
    #                              as SUMO's drivers; "v_max" = [model] v_max everywhere (decision records 047, 050)
    routes: tuple[str, ...] = ()  # [-] absolute paths of the user's own SUMO route files, in SUMO's order
    sumocfg: str | None = None  # [-] absolute path of the user's .sumocfg the other fields came from (None: none)
    additional: tuple[str, ...] = ()  # [-] absolute paths of SUMO additional files (detectors, programmes)
    sumocfg_begin: float | None = None  # [s] the sumocfg's begin (None: no sumocfg, or it gives none)
    sumocfg_end: float | None = None  # [s] the sumocfg's end (None: no sumocfg, or it gives none)
    sumocfg_loading: tuple[tuple[str, str], ...] = ()  # [-] the sumocfg's XML-validation options, passed on

    @property
    def generated(self) -> bool:
        """True on the generated paper net (no ``file``)."""
        return self.file is None


@dataclass(frozen=True)
class VehicleSpec:
    """One hand-placed vehicle (a ``[[vehicle]]`` table), resolved onto a movement path.

    On a net given by ``[network] file`` (``route`` not None) there is no paper movement:
    ``approach``, ``movement`` and ``path_id`` are "", ``lane`` is the SUMO lane id it starts on,
    ``s0`` = ``depart_pos`` and ``x``, ``y`` are in the net's frame.
    """

    id: str
    approach: str  # arm it comes from: north / east / south / west ("" on a generic net)
    lane: str  # inner / middle / outer (the SUMO lane id on a generic net)
    movement: str  # left / straight / right ("" on a generic net)
    path_id: str  # the movement path it starts on (see network/paths.py; "" on a generic net)
    s0: float  # [m] start arc length along that path (front bumper; along its lane on a generic net)
    x: float  # [m] start position in the paper frame (on the path; the net's frame on a generic net)
    y: float  # [m]
    speed: float  # [m/s] start speed
    kappa: float  # [-] aggressiveness in [0, 1]
    depart: float = 0.0  # [s] insertion time
    exit_lane: str | None = None  # preferred exit lane (None: the movement's default)
    in_junction: bool = False  # starts on the junction-internal lane
    desired_speed: float | None = None  # [m/s] its own desired / max speed (J_e, Eq. 24); None: model v_max
    route: tuple[str, ...] | None = None  # [-] edge ids it drives, first = where it starts (None: paper forms)
    depart_lane: int | None = None  # [-] SUMO lane index on route[0] (None: paper forms)
    depart_pos: float | None = None  # [m] front bumper along that lane (None: paper forms)
    driver: str = "av"  # [-] "av" (the controller drives it) or "human" (SUMO's model, never commanded)
    vtype: str | None = None  # [-] its [[vtype]] id (None: the default vType of its driver)


@dataclass(frozen=True)
class KappaDistribution:
    """Aggressiveness of a flow's vehicles: a fixed value or a seeded draw, clipped to [0, 1]."""

    dist: str = "fixed"  # fixed / uniform / normal
    value: float = 0.5  # [-] for fixed
    low: float = 0.0  # [-] for uniform
    high: float = 1.0  # [-] for uniform
    mean: float = 0.5  # [-] for normal
    std: float = 0.1  # [-] for normal


@dataclass(frozen=True)
class FlowSpec:
    """A ``[[flow]]`` table: Poisson arrivals on one approach and movement, or on one ``route``.

    On a net given by ``[network] file`` (``route`` not None) ``approach`` and ``movement`` are ""
    and ``lane``, ``speed``, ``distance`` keep their defaults; ``depart_lane``, ``depart_speed``
    and ``depart_pos`` say how SUMO inserts the vehicles.
    """

    id: str
    approach: str  # arm the vehicles come from ("" on a generic net)
    movement: str  # left / straight / right ("" on a generic net)
    rate: float  # [veh/h]
    kappa: KappaDistribution
    begin: float = 0.0  # [s]
    end: float = 3600.0  # [s]
    lane: str | None = None  # approach lane; None = any lane that allows the movement
    speed: float = 10.0  # [m/s] insertion speed
    distance: float | None = None  # [m] from the stop line at insertion; None = arm's start
    route: tuple[str, ...] | None = None  # [-] edge ids the vehicles drive (None: paper forms)
    depart_lane: str = "best"  # [-] SUMO departLane: "best", "random", "free", "first", "allowed" or an index
    depart_speed: str = "max"  # [m/s] SUMO departSpeed: a number, "max", "desired", "speedLimit" or "random"
    depart_pos: float | None = None  # [m] departPos along route[0]; None = "base" (its start)
    av_share: float = 1.0  # [-] probability that an inserted vehicle is an AV (else a human), seeded
    vtype: str | None = None  # [-] the [[vtype]] id of its vehicles (None: the default vType of their driver)


@dataclass(frozen=True)
class Scenario:
    source: str  # the file it came from (for messages)
    scenario: ScenarioSettings
    controller: ControllerSettings
    model: ModelSettings
    controller_settings: object = None  # the controller's validated [controller.*] settings (None: takes none)
    controller_tables: dict = field(default_factory=dict)  # the raw sub-tables, re-validated on --controller
    vehicles: tuple[VehicleSpec, ...] = ()
    flows: tuple[FlowSpec, ...] = ()
    network: NetworkSettings = NetworkSettings()  # the [network] table (default: the generated paper net)
    v2x: V2XSettings = V2XSettings()  # the [v2x] table (default: perfect information, no channel)
    human: HumanDriverSettings = HumanDriverSettings()  # the [human] table: how SUMO drives humans
    vtypes: tuple[VehicleType, ...] = ()  # the [[vtype]] tables, in file order

    def vtype(self, vid: str | None) -> VehicleType | None:
        """The [[vtype]] of id ``vid`` (None for None)."""
        return None if vid is None else next(t for t in self.vtypes if t.id == vid)
