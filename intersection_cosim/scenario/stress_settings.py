"""The ``[stress]`` table of a scenario file: which scenario axes ``intersection-cosim stress`` draws
and over which ranges, with how the runs are judged and shrunk.

Each axis key takes ``[low, high]`` (both ends included) or ``false`` (the axis is off: the
scenario's own value is kept). A run of a scenario with a ``[stress]`` table ignores the table;
only ``stress`` reads it.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from intersection_cosim.errors import InputError

# name -> (default range, unit, what it sets); None: off by default
AXIS_DEFAULTS: dict[str, tuple[tuple[float, float] | None, str, str]] = {
    "demand_scale": ((0.5, 2.0), "-", "multiplies every flow's rate (total demand)"),
    "flow_scale": ((0.5, 1.5), "-", "multiplies each flow's rate on its own (the movement mix)"),
    "burst_scale": ((0.0, 3.0), "-", "extra rate, times the flow's, in one burst window per flow"),
    "burst_start": ((0.0, 1.0), "-", "start of the burst window, as a share of the demand window"),
    "burst_length": ((5.0, 30.0), "s", "length of the burst window"),
    "av_share": ((0.5, 1.0), "-", "every flow's av_share"),
    "kappa_center": ((0.1, 0.9), "-", "centre of every flow's uniform kappa draw"),
    "kappa_spread": ((0.0, 0.4), "-", "width of every flow's uniform kappa draw"),
    "insertion_speed": ((4.0, 10.0), "m/s", "every flow's insertion speed (capped at its vType's maximum speed "
                        "and the first edge's limit)"),
    "latency": ((0.0, 0.3), "s", "v2x.latency"),
    "loss": ((0.0, 0.2), "-", "v2x.loss"),
    "position_noise": ((0.0, 1.0), "m", "v2x.position_noise"),
    "speed_noise": ((0.0, 0.5), "m/s", "v2x.speed_noise"),
    "vtype": ((0.0, 1.0), "-", "which [[vtype]] each flow drives (a share of the list; only with vtypes)"),
    "uturn_share": ((0.0, 0.3), "-", "share of each flow's vehicles that turn back at the first managed junction "
                    "of its route with a U-turn connection (only on nets that have one there)"),
    "pedestrian_rate": ((0.0, 400.0), "persons/h", "people walking over each crossing of the managed junctions, "
                        "half each way (only where they have crossings and the controller yields to them)"),
}
AXIS_BOUNDS = {"av_share": (0.0, 1.0), "kappa_center": (0.0, 1.0), "kappa_spread": (0.0, 1.0),
               "loss": (0.0, 1.0), "burst_start": (0.0, 1.0), "vtype": (0.0, 1.0),
               "uturn_share": (0.0, 1.0)}  # hard limits of a range


@dataclasses.dataclass(frozen=True)
class StressSettings:
    """The ``[stress]`` table (module docstring); ``axes`` maps each axis that is on to its range."""

    axes: tuple[tuple[str, tuple[float, float]], ...] = tuple(
        (name, rng) for name, (rng, _unit, _what) in AXIS_DEFAULTS.items() if rng is not None)  # [-] each axis
    #   that is on, by name, with its [low, high] range in the axis's unit (AXIS_DEFAULTS, docs/stress.md)
    work_clock_ms: float = 0.5  # [ms] per QP solve: the runs keep their budget by a work clock, so a
    #                             failure replays the same on any machine; 0: the wall clock
    drain: float = 60.0  # [s] every run's drain after the demand window (vehicles still in: never arrived)
    time_gap_floor: float = 1.0  # [m/s] a follower slower than this gives no time gap to its leader
    stuck_time: float = 30.0  # [s] a vehicle not arrived that stood still this long before the run ended
    #                           never arrives (one still driving only ran out of drain time)
    hard_braking_tolerance: float = 0.5  # [m/s^2] braking harder than emergencyDecel by more than this is a
    #   hard_braking failure; harder than decel by more than this, an emergency_braking near miss
    emergency_braking_fails: bool = False  # [-] true: an emergency_braking near miss (braking between decel
    #   and emergencyDecel, which the safety rules command by design) also counts as a failure
    cem_generations: int = 4  # [-] generations of --search cem (the runs split evenly among them)
    cem_elite: float = 0.25  # [-] share of a generation that the next one is fitted to
    cem_min_std: float = 0.05  # [-] least std of a parameter, as a share of its range
    shrink_attempts: int = 3  # [-] smaller variants tried per failure by --shrink
    shrink_pad: float = 10.0  # [s] a shrunk window ends this long after the failure it keeps

    def axis(self, name: str) -> tuple[float, float] | None:
        return dict(self.axes).get(name)


SCALARS = {f.name: f for f in dataclasses.fields(StressSettings) if f.name != "axes"}


def _range(src: str, name: str, value: Any) -> tuple[float, float] | None:
    field = f"stress.{name}"
    if value is False:
        return None
    if not (isinstance(value, list) and len(value) == 2
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)):
        raise InputError(src, field, value, "must be [low, high] (two numbers) or false (axis off)")
    low, high = float(value[0]), float(value[1])
    if low > high:
        raise InputError(src, field, value, f"low {low:g} is above high {high:g}")
    lo, hi = AXIS_BOUNDS.get(name, (0.0, math.inf))
    if low < lo or high > hi:
        bound = f"[{lo:g}, {hi:g}]" if math.isfinite(hi) else f">= {lo:g}"
        raise InputError(src, field, value, f"must lie in {bound}")
    return low, high


def _scalar(src: str, name: str, value: Any) -> float | int | bool:
    field = f"stress.{name}"
    if SCALARS[name].type in ("bool", bool):
        if not isinstance(value, bool):
            raise InputError(src, field, value, "must be true or false")
        return value
    want_int = SCALARS[name].type in ("int", int)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or (want_int and not isinstance(value, int)):
        raise InputError(src, field, value, "must be an integer" if want_int else "must be a number")
    if not math.isfinite(value) or value < 0:
        raise InputError(src, field, value, "must be a finite number >= 0")
    if name == "cem_elite" and not 0 < value <= 1:
        raise InputError(src, field, value, "must be in (0, 1]")
    if name == "cem_generations" and value < 1:
        raise InputError(src, field, value, "must be >= 1")
    return value if want_int else float(value)


def stress_settings(src: str, table: Any) -> StressSettings:
    """Validate a ``[stress]`` table (None: every default)."""
    if table is None:
        return StressSettings()
    if not isinstance(table, dict):
        raise InputError(src, "stress", table, "must be a table")
    axes = dict(StressSettings().axes)
    scalars = {}
    for key, value in table.items():
        if key in AXIS_DEFAULTS:
            rng = _range(src, key, value)
            if rng is None:
                axes.pop(key, None)
            else:
                axes[key] = rng
        elif key in SCALARS:
            scalars[key] = _scalar(src, key, value)
        else:
            known = ", ".join([*AXIS_DEFAULTS, *SCALARS])
            raise InputError(src, f"stress.{key}", value, f"unknown key (known: {known})")
    ordered = tuple((name, axes[name]) for name in AXIS_DEFAULTS if name in axes)
    return StressSettings(axes=ordered, **scalars)
