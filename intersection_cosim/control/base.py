"""What a controller sees (World) and what it returns (Decisions), and the Controller protocol.

The simulator adapter builds a World snapshot from SUMO each control period, the step scheduler
hands it to the controller, and the adapter writes the Decisions back. Controllers never import
the simulator.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Mapping, NamedTuple, Protocol

import numpy as np

from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.movements import Movements
from intersection_cosim.network.paths import MovementPath


class Walker(NamedTuple):
    """A pedestrian on, or walking towards, a crossing of a managed junction (network/crossings.py)."""

    id: str
    crossing: str  # SUMO lane id of the crossing
    position: float  # [m] on the crossing's axis, from its start (< 0 or > its length: still before it)
    direction: int  # +1 walking towards the axis' end, -1 towards its start
    speed: float  # [m/s]
    x: float = math.nan  # [m] where it is, in the net's frame
    y: float = math.nan  # [m]


class Guest(NamedTuple):
    """A vehicle on one managed junction's path that another managed junction must see too: one
    coming through the first junction towards the second's stop line within its control range,
    or one that has just left the first for the second (front on the link, rear maybe still in
    the first's box). The other junction sees it as a guest: never its player, a vehicle whose
    acceleration it may only cap (control/per_junction.py merges the caps into the owner's)."""

    vehicle: str  # vehicle id (its own row is on its owner's path)
    path: str  # the other junction's path the vehicle drives
    offset: float  # [m] its arc length on ``path`` less its arc length on its own path
    role: str  # "ready" (it comes towards the other junction) or "outside" (it has left it)


@dataclass
class World:
    """Snapshot of every vehicle in the network at ``time``; arrays are aligned with ``ids``."""

    time: float  # [s] simulation time
    ids: list[str]
    path_ids: list[str]  # movement path each vehicle is on (see network/paths.py)
    s: np.ndarray  # [m] arc length of the front bumper along its path
    v: np.ndarray  # [m/s] speed
    a: np.ndarray  # [m/s^2] acceleration over the last step
    x: np.ndarray  # [m] front-bumper position, paper frame
    y: np.ndarray  # [m]
    heading: np.ndarray  # [rad] counter-clockwise from east
    kappa: np.ndarray  # [-] aggressiveness
    role: list[str]  # ready / passing / outside (the conflict zone)
    lanes: list[str] = field(default_factory=list)  # SUMO lane id of each vehicle
    exit_choices: dict[str, tuple[str, ...]] = field(default_factory=dict)  # vehicle -> exit lanes it may still take
    desired_speed: np.ndarray | None = None  # [m/s] per vehicle (J_e, Eq. 24); NaN / None: ModelSettings.v_max
    exit_free: Mapping[str, tuple[float, float]] = field(default_factory=dict)  # per exit lane (SUMO id) a
    #   READY vehicle may take: ([m] free length from the lane's start to the rear of its last
    #   vehicle, [m/s] that vehicle's speed); (lane length, inf) if empty; a lane not in it is free
    human: np.ndarray | None = None  # [-] bool per vehicle: a human driver (SUMO drives it; never a player); None: none
    length: np.ndarray | None = None  # [m] per vehicle, bumper to bumper (its vType's); None: ModelSettings.vehicle_length
    width: np.ndarray | None = None  # [m] per vehicle (its vType's); None: ModelSettings.vehicle_width
    accel: np.ndarray | None = None  # [m/s^2] per vehicle, its vType's strongest acceleration; None: no own limit
    decel: np.ndarray | None = None  # [m/s^2] per vehicle, its vType's braking (> 0); None: no own limit
    emergency_decel: np.ndarray | None = None  # [m/s^2] per vehicle, its vType's hardest braking (> 0); None: unknown
    walkers: tuple[Walker, ...] = ()  # pedestrians on or walking onto a managed junction's crossings
    guests: tuple[Guest, ...] = ()  # vehicles other managed junctions must see too (the whole net's World)
    guest: np.ndarray | None = None  # [-] bool per vehicle: a guest row of a junction's World (None: none)

    def subset(self, keep: list[int]) -> "World":
        """The World of the vehicles at indices ``keep`` (in that order): every per-vehicle array
        and list indexed, every dict keyed by vehicle id filtered (in its own order), anything
        else (``time``, a dict keyed by lane such as ``exit_free``) kept whole. Generic over the
        fields, so a field added to World is split with the vehicles without its users knowing it."""
        return self.subsets([keep])[0]

    def subsets(self, keeps: list[list[int]]) -> list["World"]:
        """:meth:`subset` of each index list of ``keeps``; which fields are per vehicle is worked
        out once, so that splitting a city's World by junction costs each part its own size."""
        n, everyone = len(self.ids), set(self.ids)
        split = []  # (field name, kind, value)
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray) and value.ndim >= 1 and len(value) == n:
                split.append((f.name, "array", value))
            elif isinstance(value, list) and len(value) == n:
                split.append((f.name, "list", value))
            elif isinstance(value, dict) and value.keys() <= everyone:
                items = list(value.items())
                split.append((f.name, "dict", (items, {vid: i for i, (vid, _) in enumerate(items)})))
            else:
                split.append((f.name, "whole", value))
        parts = []
        for keep in keeps:
            idx, fields = np.asarray(keep, dtype=np.intp), {}
            for name, kind, value in split:
                if kind == "array":
                    fields[name] = value[idx]
                elif kind == "list":
                    fields[name] = [value[k] for k in keep]
                elif kind == "dict":
                    items, where = value
                    fields[name] = dict(items[i] for i in sorted(
                        {where[vid] for vid in (self.ids[k] for k in keep) if vid in where}))
                else:
                    fields[name] = value
            parts.append(dataclasses.replace(self, **fields))
        return parts

    def is_human(self, k: int) -> bool:
        """Whether vehicle k is a human driver (observed and predicted, never commanded)."""
        return self.human is not None and bool(self.human[k])

    def is_guest(self, k: int) -> bool:
        """Whether row k is a guest (another junction commands it; this one may only cap it)."""
        return self.guest is not None and bool(self.guest[k])

    def observed(self) -> np.ndarray | None:
        """(n,) bool: the vehicles this junction observes and never decides for (humans and
        guests); None when there are none."""
        if self.human is None and self.guest is None:
            return None
        n = len(self.ids)
        return ((np.zeros(n, bool) if self.human is None else self.human)
                | (np.zeros(n, bool) if self.guest is None else self.guest))

    def lengths(self, default: float) -> np.ndarray:
        """[m] (n,) every vehicle's length, ``default`` [m] where the World carries none."""
        return np.full(len(self.ids), float(default)) if self.length is None else self.length

    def widths(self, default: float) -> np.ndarray:
        """[m] (n,) every vehicle's width, ``default`` [m] where the World carries none."""
        return np.full(len(self.ids), float(default)) if self.width is None else self.width

    def desired_speed_of(self, k: int) -> float | None:
        """[m/s] vehicle k's own desired speed, None where the World carries none (then
        ModelSettings.v_max)."""
        if self.desired_speed is None or not math.isfinite(float(self.desired_speed[k])):
            return None
        return float(self.desired_speed[k])

    def length_of(self, k: int, default: float) -> float:
        """[m] vehicle k's length (``default`` [m] when the World carries none)."""
        return float(default) if self.length is None else float(self.length[k])

    def accel_limits(self, k: int, a_min: float, a_max: float) -> tuple[float, float]:
        """[m/s^2] (lowest, highest) acceleration vehicle k may plan: the model's [a_min, a_max]
        narrowed by its own vType's decel and accel where the World carries them."""
        lo = a_min if self.decel is None else max(a_min, -float(self.decel[k]))
        hi = a_max if self.accel is None else min(a_max, float(self.accel[k]))
        return lo, hi

    def emergency_brake(self, k: int, default: float) -> float:
        """[m/s^2] (< 0) the hardest braking vehicle k can do in an emergency: its vType's
        emergencyDecel where the World carries it, else ``default`` [m/s^2] (< 0)."""
        if self.emergency_decel is None or not math.isfinite(float(self.emergency_decel[k])):
            return default
        return -float(self.emergency_decel[k])

    def __len__(self) -> int:
        return len(self.ids)


@dataclass
class Decisions:
    """A controller's output for one control period."""

    accel: dict[str, float] = field(default_factory=dict)  # [m/s^2] per controlled vehicle
    exit_lane: dict[str, str] = field(default_factory=dict)  # chosen exit lane per vehicle
    release: list[str] = field(default_factory=list)  # vehicles handed back to SUMO's driver model
    caps: dict[str, float] = field(default_factory=dict)  # [m/s^2] upper bounds on guests' accelerations (World.guests)
    owner: dict[str, str] = field(default_factory=dict)  # per vehicle of ``accel`` and ``release``, the managed
    #   junction whose controller decided it (control/per_junction.py): the simulator adapter takes a
    #   command only while the vehicle is on that junction's paths (empty: the run's one junction)
    signals: dict[str, str] = field(default_factory=dict)  # [-] traffic light id -> SUMO state string to show
    #   from now on (signal controllers; empty: every light keeps what it shows)
    games: int = 0  # games played this step
    iterations: int = 0  # equilibrium iterations (summed over games)
    pairs: list[tuple[str, str]] = field(default_factory=list)  # pairs that played a game
    kept: list[tuple[str, str]] = field(default_factory=list)  # of ``pairs``, those whose game kept
    #                                                            its last equilibrium, unsolved
    deferred: int = 0  # games / solo solves left out to meet the budget (last plan kept, shifted)
    qp_solves: int = 0  # QPs solved for this step (the work, independent of the machine's load)
    fallback: bool = False  # the decisions are the scheduler's fallback
    note: str = ""  # why a fallback was used


@dataclass(frozen=True)
class ControlContext:
    """What a controller gets once, before the first step."""

    movements: Movements  # the managed junctions' movement paths and how they relate
    model: ModelSettings
    control_period: float  # [s]
    settings: object  # the controller's validated [controller.*] settings (None: its defaults)
    etm: bool  # event-triggered mechanism on
    bodies: tuple[tuple[float, float], ...] = ()  # [m] (length, width) of each of the run's vehicle
    #                                               types ((): every vehicle has ModelSettings' body)
    position_noise: float = 0.0  # [m] standard deviation of each vehicle position the controller sees
    #                              (a converged V2X track's, v2x/tracker.py; 0: exact)

    @property
    def touch_width(self) -> float:
        """[m] centre lines closer than this may carry touching bodies: the widest vehicle type's
        width (at least ModelSettings.vehicle_width); which paths conflict is decided with it."""
        return max([self.model.vehicle_width] + [w for _, w in self.bodies])

    @property
    def paths(self) -> Mapping[str, MovementPath]:
        return self.movements.paths

    @property
    def net_file(self) -> str:
        """The SUMO net the run uses (for the precomputed conflict table)."""
        return self.movements.net_file


@dataclass(frozen=True)
class Diagnostics:
    """What a controller reports about a run, beyond its Decisions (written by experiments.run_tables).

    ``convergence``: one record per game solved, in solve order, each with ``time`` [s],
    ``vehicle_a``, ``vehicle_b``, ``solver``, ``status`` and ``residuals`` (one per iteration,
    [m/s^2]): the rows of convergence.csv (the paper's Fig. 3). None for a controller that solves
    no games (then the run has no convergence.csv); an empty tuple for one that solved none.
    ``safety_interventions``: [-] commanded accelerations the safety filter lowered.
    ``box_rule_clearances``: [-] accelerations the safety filter raised so a vehicle clears a
    crossing it has entered (the box rule). ``pedestrian_holds``: [-] control steps x vehicles
    held back for a pedestrian at a crossing (control/safety/pedestrians.py). All three None for a
    controller without that filter (summary.json then records null). ``clusters``: one record per
    coupled cluster game (control/game/cluster_games.py ClusterRow: time [s], members, iterations,
    residual [m/s^2], status, equilibrium check), None for a controller that plays none by design.
    """

    convergence: tuple | None = None
    safety_interventions: int | None = None
    box_rule_clearances: int | None = None
    pedestrian_holds: int | None = None
    clusters: tuple | None = None


class Controller(Protocol):
    """A decision layer. A new controller is a new module plus a registry entry."""

    #: SUMO junction type of the net this controller runs on.
    junction_type: str
    #: True if the controller commands the vehicles (SUMO's own right of way is then switched off).
    controls_vehicles: bool
    #: True if its vehicles yield to pedestrians at the crossings (SUMO's drivers do; a controller
    #: that commands vehicles must see the persons itself, else a route file with persons is refused).
    yields_to_pedestrians: bool

    def setup(self, context: ControlContext) -> None: ...

    def decide(self, world: World, deadline: float) -> Decisions:
        """Decisions for the next period; ``deadline`` is a :func:`~intersection_cosim.games.budget_clock.now` value [s].
        On an empty World right after another it decides nothing and changes no state of its own
        (the network scheduler skips such a call, sim.network_scheduler)."""
        ...

    def fallback(self, world: World) -> Decisions:
        """Safe decisions when ``decide`` misses its deadline or fails."""
        ...

    def diagnostics(self) -> Diagnostics:
        """What the controller has to report about the run so far (see :class:`Diagnostics`)."""
        ...
