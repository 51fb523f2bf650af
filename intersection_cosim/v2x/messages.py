"""What travels over the link: a vehicle's state up, the controller's command down."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class StateMessage:
    """One vehicle's broadcast: its state at ``stamp`` as it sent it (noise and attacks included)."""

    sender: str
    stamp: float  # [s] the time of the state it carries (as the sender claims it)
    arrival: float  # [s] when it reaches the controller
    path_id: str  # the movement path the state is on
    s: float  # [m] front bumper along the path
    v: float  # [m/s]
    a: float  # [m/s^2]
    exit_choices: tuple[str, ...]  # exit lanes it may still take
    attacked: bool = False  # altered by a [[v2x.attack]] (bookkeeping only: the controller never reads it)


@dataclass(frozen=True)
class Command:
    """The controller's decision for one vehicle, on its way down."""

    vehicle: str
    arrival: float  # [s] when it reaches the vehicle
    accel: float | None  # [m/s^2] None: no acceleration in this decision
    exit_lane: str | None
    release: bool  # hand the vehicle back to SUMO's driver model
    owner: str | None = None  # the managed junction whose controller decided it (Decisions.owner)
