"""The id of a movement path: approach arm, approach lane, movement and exit lane.

Its text form ``"<approach>_<lane>_<movement>_<exit lane>"`` (e.g. ``"south_inner_left_middle"``)
keys the paths dict, ``World.path_ids`` and the ``path`` column of trajectories.csv; no part
contains ``_`` (see ``network.spec``: ARMS, LANES, MOVEMENTS), so the text parses back uniquely.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from intersection_cosim.network.spec import ARMS, LANES, MOVEMENTS

SEPARATOR = "_"


@dataclass(frozen=True)
class PathId:
    """One approach lane -> exit lane movement; ``str()`` gives the id used everywhere as a key."""

    approach: str  # arm the path comes from: north / east / south / west
    lane: str  # approach lane: inner / middle / outer
    movement: str  # left / straight / right
    exit_lane: str  # lane of the exit arm: inner / middle / outer

    def __str__(self) -> str:
        return SEPARATOR.join((self.approach, self.lane, self.movement, self.exit_lane))

    @classmethod
    def parse(cls, text: str) -> "PathId":
        """``"south_inner_left_middle"`` -> ``PathId("south", "inner", "left", "middle")``.

        Raises ValueError if ``text`` is not four known parts; it does not check that the net has
        the path (``network.spec.LANE_USE`` says which combinations exist).
        """
        parts = text.split(SEPARATOR)
        if len(parts) != 4:
            raise ValueError(f"path id {text!r} is not <approach>_<lane>_<movement>_<exit lane>")
        approach, lane, movement, exit_lane = parts
        for value, known in ((approach, ARMS), (lane, LANES), (movement, MOVEMENTS), (exit_lane, LANES)):
            if value not in known:
                raise ValueError(f"path id {text!r}: {value!r} is not one of {', '.join(known)}")
        return cls(approach, lane, movement, exit_lane)

    def with_exit(self, exit_lane: str) -> "PathId":
        """The path of the same approach lane and movement that ends on ``exit_lane``."""
        return replace(self, exit_lane=exit_lane)

