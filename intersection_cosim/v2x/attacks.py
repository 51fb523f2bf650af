"""Spoofed states (``[[v2x.attack]]``): what an attacked vehicle sends instead of its state."""

from __future__ import annotations

import dataclasses

from intersection_cosim.v2x.messages import StateMessage
from intersection_cosim.v2x.settings import AttackSettings


class History:
    """The true states a replaying vehicle sent, kept as long as a replay may reach back."""

    def __init__(self, keep: float):
        self.keep = keep  # [s]
        self._states: dict[str, list[StateMessage]] = {}

    def add(self, msg: StateMessage) -> None:
        states = self._states.setdefault(msg.sender, [])
        states.append(msg)
        while states and states[0].stamp < msg.stamp - self.keep - 1e-9:
            states.pop(0)

    def at(self, sender: str, time: float) -> StateMessage | None:
        """The newest true state of ``sender`` sent at or before ``time`` [s] (else its oldest)."""
        states = self._states.get(sender, [])
        older = [m for m in states if m.stamp <= time + 1e-9]
        return older[-1] if older else (states[0] if states else None)


def attacked(msg: StateMessage, attack: AttackSettings, history: History) -> StateMessage | None:
    """What ``msg``'s sender sends under ``attack`` (None: nothing, a ``silent`` attack)."""
    if attack.kind == "silent":
        return None
    if attack.kind == "position_offset":
        return dataclasses.replace(msg, s=msg.s + attack.value, attacked=True)
    if attack.kind == "speed_offset":
        return dataclasses.replace(msg, v=max(0.0, msg.v + attack.value), attacked=True)
    old = history.at(msg.sender, msg.stamp - attack.value) or msg  # replay: an old state, stamped as now
    return dataclasses.replace(old, stamp=msg.stamp, arrival=msg.arrival, attacked=True)
