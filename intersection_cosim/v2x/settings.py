"""The ``[v2x]`` table and its ``[[v2x.attack]]`` entries."""

from __future__ import annotations

from dataclasses import dataclass

from intersection_cosim.settings import non_negative, positive

ATTACK_KINDS = ("position_offset", "speed_offset", "replay", "silent")


@dataclass(frozen=True)
class AttackSettings:
    """One ``[[v2x.attack]]``: what vehicle ``vehicle`` sends between ``begin`` and ``end``.

    ``position_offset``: its position moved ``value`` [m] along its path; ``speed_offset``: its
    speed raised by ``value`` [m/s] (clipped at 0); ``replay``: the state it had ``value`` [s]
    earlier, stamped as now; ``silent``: nothing (``value`` unused).
    """

    vehicle: str = ""  # [-] id of a [[vehicle]] or of a flow's vehicle ("<flow id>.<k>")
    kind: str = ""  # [-] one of ATTACK_KINDS
    value: float = 0.0  # [m], [m/s] or [s] by kind (see above)
    begin: float = 0.0  # [s] first send time attacked
    end: float = 0.0  # [s] send times before this are attacked

    def check(self) -> list[tuple[str, str]]:
        problems = []
        if not self.vehicle:
            problems.append(("vehicle", "is required (a vehicle id)"))
        if self.kind not in ATTACK_KINDS:
            problems.append(("kind", f"must be one of {', '.join(ATTACK_KINDS)}"))
        problems += non_negative(self, "begin")
        if self.begin > self.end:
            problems.append(("begin", f"must be <= end ({self.end:g} s)"))
        if self.kind == "replay" and not self.value > 0:
            problems.append(("value", "must be > 0 for a replay (how many seconds old the resent state is)"))
        return problems

    def active(self, time: float) -> bool:
        """Whether a message sent at ``time`` [s] is attacked."""
        return self.begin - 1e-9 <= time < self.end - 1e-9


@dataclass(frozen=True)
class V2XSettings:
    """The ``[v2x]`` table: the link between the vehicles and the controller.

    Every default is today's perfect information (then :attr:`enabled` is False and a run does
    not go through the channel at all). Noise is Gaussian, drawn from the scenario's seed.
    """

    latency: float = 0.0  # [s] a message (state up, command down) arrives this long after it is sent
    loss: float = 0.0  # [-] probability that one message (state or command) is lost
    position_noise: float = 0.0  # [m] standard deviation of the sent position along the path
    speed_noise: float = 0.0  # [m/s] standard deviation of the sent speed
    period: float = 0.0  # [s] a vehicle sends its state every period; 0 = the control period
    plausibility: bool = True  # [-] reject a state message inconsistent with the sender's last accepted one
    max_accel: float = 3.0  # [m/s^2] plausibility: strongest acceleration a vehicle can have
    max_decel: float = 4.5  # [m/s^2] plausibility: hardest braking (the vType's decel)
    max_speed: float = 20.0  # [m/s] plausibility: highest speed a vehicle can drive
    resync: float = 2.0  # [s] a sender rejected this long in a row is taken at its newest message again
    # [m/s^2] the receiver's track of a sender (v2x/tracker.py): how much its acceleration may change
    # between two messages, unannounced (the Kalman filter's process noise)
    track_accel_noise: float = 2.0
    attack: tuple[AttackSettings, ...] = ()  # the [[v2x.attack]] tables

    def check(self) -> list[tuple[str, str]]:
        problems = non_negative(self, "latency", "position_noise", "speed_noise", "period")
        if not 0.0 <= self.loss <= 1.0:
            problems.append(("loss", "must be in [0, 1]"))
        problems += positive(self, "max_accel", "max_decel", "max_speed", "resync", "track_accel_noise")
        return problems

    @property
    def enabled(self) -> bool:
        """False for perfect information: no latency, loss, noise, own period or attack."""
        return bool(self.latency > 0 or self.loss > 0 or self.position_noise > 0 or self.speed_noise > 0
                    or self.period > 0 or self.attack)
