"""The reservations of the ``fcfs`` controller (control/baselines/fcfs.py): its settings, the time a vehicle
needs to cover a distance, and the search for the first arrival whose occupancy of the conflict
points collides with no interval granted before. Pure numpy, no SUMO.

Units: arc lengths [m], speeds [m/s], accelerations [m/s^2], times [s] of simulation time.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from intersection_cosim.settings import positive


@dataclass(frozen=True)
class FcfsSettings:
    """Parameters of the ``fcfs`` controller (``[controller.solver]``)."""

    buffer: float = 0.5  # [s] least time between two vehicles' occupancies of one point
    comfort_accel: float = 2.0  # [m/s^2] acceleration of the target speed profile
    max_brake: float = 4.0  # [m/s^2] hardest braking (commitment test, Krauss' b, clip)
    follow_gap: float = 1.0  # [m] stop-line headway distance beyond L; stop this far before the line
    slot_step: float = 0.1  # [s] resolution of the arrival times tried
    max_delay: float = 120.0  # [s] latest arrival tried after the earliest one
    exit_room: bool = True  # [-] don't block the box: an uncommitted vehicle whose exit lane lacks
    #                         room is held at its stop line without a reservation (control/safety/exit_room.py)
    exit_min_gap: float = 2.5  # [m] standstill gap a vehicle needs on its exit lane (SUMO's minGap)
    standing_speed: float = 1.0  # [m/s] a vehicle inside the junction slower than this claims exit room;
    #                              a human slower than this short of its stop line reserves nothing
    human_slow_accel: float = 0.5  # [m/s^2] a human driver's slowest plausible start: its reservation
    #                                lasts until it could have cleared a point accelerating this gently
    safety_filter: bool = True  # [-] run the game controllers' safety rules (control/safety/, default
    #                             [controller.safety] settings) on every command (false: an ablation)

    def check(self) -> list[tuple[str, str]]:
        problems = positive(self, "comfort_accel", "max_brake", "slot_step", "max_delay")
        if not self.buffer >= 0:
            problems.append(("buffer", "must be >= 0"))
        if not self.follow_gap >= 0:
            problems.append(("follow_gap", "must be >= 0"))
        for name in ("exit_min_gap", "standing_speed", "human_slow_accel"):
            if not getattr(self, name) >= 0:
                problems.append((name, "must be >= 0"))
        return problems


def time_to_cover(d, v0, accel: float, v_max: float):
    """[s] time to cover ``d`` [m] (>= 0; negative counts as 0) from speed ``v0`` [m/s],
    accelerating at ``accel`` up to ``v_max``; vectorised (numpy broadcasting)."""
    d = np.maximum(np.asarray(d, float), 0.0)
    v0 = np.clip(np.asarray(v0, float), 0.0, v_max)
    d_acc = (v_max ** 2 - v0 ** 2) / (2.0 * accel)
    t_acc = (np.sqrt(v0 ** 2 + 2.0 * accel * np.minimum(d, d_acc)) - v0) / accel
    return t_acc + np.maximum(d - d_acc, 0.0) / v_max


def not_before_vehicle_ahead(world, past: np.ndarray, t_e: np.ndarray) -> np.ndarray:
    """``t_e`` [s] (earliest arrivals) with each approaching vehicle's arrival at least 1 ms after
    that of the vehicle ahead on its approach lane (a new array); ``world``: the step's World,
    ``past``: bool per vehicle, not approaching."""
    t_e = t_e.copy()
    by_lane: dict[str, list[int]] = {}
    for k in range(len(world)):
        if not past[k]:
            by_lane.setdefault(world.lanes[k] if world.lanes else world.path_ids[k], []).append(k)
    for ks in by_lane.values():
        ks.sort(key=lambda k: -world.s[k])
        for a, b in zip(ks, ks[1:]):
            t_e[b] = max(t_e[b], t_e[a] + 1e-3)
    return t_e


def free_slot(enter: np.ndarray, leave: np.ndarray, busy_in: np.ndarray, busy_out: np.ndarray,
              point: np.ndarray, busy_point: np.ndarray, buffer: float) -> int:
    """Index of the first candidate whose occupancies collide with no busy interval, or -1.

    ``enter``, ``leave``: (K, P) [s] occupancy of each of the vehicle's P points for each of K
    candidate arrival times; ``point`` (P,) the points' keys (ints). ``busy_in``, ``busy_out``
    (G,) [s] the granted intervals at points ``busy_point`` (G,). Two intervals collide when they
    come closer than ``buffer`` [s]. Pure numpy, no SUMO.
    """
    if busy_in.size == 0 or enter.shape[1] == 0:
        return 0
    same = point[:, None] == busy_point[None, :]  # (P, G)
    p_idx, g_idx = np.nonzero(same)
    if p_idx.size == 0:
        return 0
    e, l_ = enter[:, p_idx], leave[:, p_idx]  # (K, M)
    clash = (e < busy_out[g_idx] + buffer) & (busy_in[g_idx] < l_ + buffer)
    ok = ~clash.any(axis=1)
    return int(np.argmax(ok)) if ok.any() else -1


@dataclass
class Grant:
    """A vehicle's reservation: arrival (time, speed) and its slot at each point."""

    t_arrive: float  # [s] when the front reaches the stop line (or now, past it)
    v_arrive: float  # [m/s]
    earliest: bool  # the vehicle was granted its earliest arrival
    slots: dict = field(default_factory=dict)  # point key -> (enter, leave) [s]


class Reservations:
    """The intervals reserved so far in one step: (enter, leave) [s] at point keys, in grant order."""

    def __init__(self):
        self.enter: list[float] = []
        self.leave: list[float] = []
        self.point: list[int] = []

    def add(self, keys: np.ndarray, enter: np.ndarray, leave: np.ndarray) -> None:
        for key, e, l_ in zip(keys, enter, leave):
            self.enter.append(float(e))
            self.leave.append(float(l_))
            self.point.append(int(key))

    def first_free(self, enter: np.ndarray, leave: np.ndarray, keys: np.ndarray, buffer: float) -> int:
        """:func:`free_slot` of the candidates (enter, leave) at points ``keys`` against these."""
        return free_slot(enter, leave, np.asarray(self.enter), np.asarray(self.leave), keys,
                         np.asarray(self.point, np.int64), buffer)
