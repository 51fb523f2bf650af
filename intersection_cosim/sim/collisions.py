"""SUMO's collisions of each step, with whether a controller commanded each vehicle then.

SUMO's collision output (``collisions.xml``) says who collided, not who drove: a collision of two
of SUMO's own drivers inside an OSM junction cluster (whose internal lanes may cross without a foe
relation) is not the controller's doing. The adapter reads ``simulation.getCollisions()`` after
every step and notes which of the two vehicles were under a controller at that moment.
"""

from __future__ import annotations

from typing import Container, NamedTuple


class CollisionRecord(NamedTuple):
    """One of SUMO's collision records (one row of collisions.csv)."""

    time: float  # [s]
    collider: str
    victim: str
    type: str  # SUMO's collision type: "collision" (on a lane), "junction", "swap", "crossing", ...
    lane: str
    collider_commanded: bool  # the collider was under a controller at that step (commanded, or taken over)
    victim_commanded: bool


def step_collisions(api, time: float, commanded: Container[str]) -> list[CollisionRecord]:
    """The collisions SUMO detected in the step that ended at ``time`` [s]; ``commanded``: the
    vehicles under a controller in that step."""
    return [CollisionRecord(time, c.collider, c.victim, c.type, c.lane, c.collider in commanded,
                            c.victim in commanded) for c in api.simulation.getCollisions()]
