"""Typed scenario objects, validated at load time (see ``scenario/load.py``)."""

from __future__ import annotations

from dataclasses import dataclass, field

from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.spec import JUNCTION_TYPES
from intersection_cosim.settings import non_negative, positive


@dataclass(frozen=True)
class ScenarioSettings:
    """The ``[scenario]`` table."""

    name: str = "scenario"  # [-] used in output folder names
    duration: float = 60.0  # [s] demand is generated up to this time
    drain: float = 60.0  # [s] after ``duration`` the run goes on this long for vehicles to leave;
    #                      it ends as soon as every vehicle has left
    step_length: float = 0.05  # [s] SUMO step; the control period is a multiple of it
    seed: int = 42  # [-] SUMO's --seed and the seed of every random draw (flows, kappa)
    junction_type: str = "priority"  # [-] SUMO node type of the centre for the sumo controller
    exit_distance: float = 50.0  # [m] past the junction where vehicles arrive (leave the network)

    def check(self) -> list[tuple[str, str]]:
        problems = positive(self, "duration", "step_length", "exit_distance")
        problems += non_negative(self, "drain")
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
    budget_ms: float = 100.0  # [ms] wall-time budget of one control step (HIL deadline)
    etm: bool = True  # [-] event-triggered mechanism on (games only for risky pairs)
    realtime: bool = False  # [-] pace the simulation to the wall clock

    def check(self) -> list[tuple[str, str]]:
        return positive(self, "period", "budget_ms")


@dataclass(frozen=True)
class VehicleSpec:
    """One hand-placed vehicle (a ``[[vehicle]]`` table), resolved onto a movement path."""

    id: str
    approach: str  # arm it comes from: north / east / south / west
    lane: str  # inner / middle / outer
    movement: str  # left / straight / right
    path_id: str  # the movement path it starts on (see network/paths.py)
    s0: float  # [m] start arc length along that path (front bumper)
    x: float  # [m] start position in the paper frame (on the path)
    y: float  # [m]
    speed: float  # [m/s] start speed
    kappa: float  # [-] aggressiveness in [0, 1]
    depart: float = 0.0  # [s] insertion time
    exit_lane: str | None = None  # preferred exit lane (None: the movement's default)
    in_junction: bool = False  # starts on the junction-internal lane
    desired_speed: float | None = None  # [m/s] its own desired / max speed (J_e, Eq. 24); None: model v_max


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
    """A ``[[flow]]`` table: Poisson arrivals on one approach and movement."""

    id: str
    approach: str
    movement: str
    rate: float  # [veh/h]
    kappa: KappaDistribution
    begin: float = 0.0  # [s]
    end: float = 3600.0  # [s]
    lane: str | None = None  # approach lane; None = any lane that allows the movement
    speed: float = 10.0  # [m/s] insertion speed
    distance: float | None = None  # [m] from the stop line at insertion; None = arm's start


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
