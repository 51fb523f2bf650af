"""Which pairs of vehicles play their game beside the ETM's Gamma_cp (Eq. 39): the pairs that
played this step (:func:`playing`) and the rule that ends a forced pair's play in the junction
(:func:`in_force`), for PolicySettings.filter_event and PolicySettings.trigger_hold_gap."""

from __future__ import annotations

from typing import Iterable

from intersection_cosim.control.base import World
from intersection_cosim.control.game.relations import Relations


def playing(world: World, relations: Relations) -> frozenset[tuple[str, str]]:
    """The vehicle pairs that play their game this step, as sorted vehicle-id pairs."""
    ids = world.ids
    return frozenset((min(ids[a], ids[b]), max(ids[a], ids[b])) for a, b in relations.triggered_pairs())


def in_force(world: World, pairs: Iterable[tuple[str, str]], entered, stall_held, clear_speed: float
             ) -> set[tuple[str, str]]:
    """``pairs`` (sorted vehicle-id pairs) less those whose two vehicles are both in the junction
    (``entered``, the entry queue) with one of them slower than ``clear_speed`` [m/s]
    (SafetySettings.clear_speed), and those with a vehicle the safety filter's last step held at
    its stop line for a stalled box (``stall_held``, SafetySettings.stalled_box_hold): it must wait
    whatever the game says, so the game only cost QPs (in a jam about a third of them; decision
    record 025)."""
    index = {vid: k for k, vid in enumerate(world.ids)}
    slow = clear_speed  # [m/s]
    stall = stall_held

    def holds(e: tuple[str, str]) -> bool:
        if e[0] in stall or e[1] in stall:
            return False
        if e[0] not in entered or e[1] not in entered:
            return True
        return all(v in index and float(world.v[index[v]]) >= slow for v in e)
    return {e for e in pairs if holds(e)}
