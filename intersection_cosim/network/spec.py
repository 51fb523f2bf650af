"""The intersection's layout: arms, lanes, movements and the paper's coordinate frame.

Frame: origin at the intersection centre, x east, y north, metres.
Right-hand traffic. Each arm has a three-lane road in and a three-lane road out, lane width 4 m,
so lane centres sit at +-2, +-6, +-10 m from the arm's axis (innermost first).

Names used everywhere:
- ``approach``: the arm a vehicle comes *from* ("south" means it drives north on the south arm).
- ``lane``: "inner" / "middle" / "outer" = SUMO lane index 2 / 1 / 0 (index 0 is the rightmost).
- ``movement``: "left" / "straight" / "right" as seen by the driver.
- edges: ``<arm>_in`` (towards the centre) and ``<arm>_out`` (away from it); the centre node is ``C``.
"""

from __future__ import annotations

from dataclasses import dataclass

ARMS = ("north", "east", "south", "west")
LANES = ("outer", "middle", "inner")  # position = SUMO lane index
MOVEMENTS = ("left", "straight", "right")

LANE_INDEX = {name: i for i, name in enumerate(LANES)}
LANE_NAME = {i: name for i, name in enumerate(LANES)}

# Unit vector pointing from the centre out along each arm.
ARM_DIRECTION = {"north": (0.0, 1.0), "east": (1.0, 0.0), "south": (0.0, -1.0), "west": (-1.0, 0.0)}

# Exit arm of each movement, right-hand traffic. Coming from the south (driving north):
# left -> west, straight -> north, right -> east.
EXIT_ARM: dict[str, dict[str, str]] = {
    "south": {"left": "west", "straight": "north", "right": "east"},
    "east": {"left": "south", "straight": "west", "right": "north"},
    "north": {"left": "east", "straight": "south", "right": "west"},
    "west": {"left": "north", "straight": "east", "right": "south"},
}

JUNCTION_TYPES = ("priority", "allway_stop", "traffic_light", "right_before_left")


def exit_arm(approach: str, movement: str) -> str:
    """The arm a vehicle leaves on, coming from ``approach`` and making ``movement``."""
    return EXIT_ARM[approach][movement]


# Lane use (issue 2, item 2): which exit lanes each approach lane may take for each movement.
LANE_USE: dict[str, dict[str, tuple[str, ...]]] = {
    "inner": {"left": ("inner", "middle"), "straight": ("inner",)},
    "middle": {"straight": ("middle",)},
    "outer": {"right": ("outer", "middle"), "straight": ("outer",)},
}


def allowed_movements(lane: str) -> tuple[str, ...]:
    return tuple(LANE_USE[lane])


@dataclass(frozen=True)
class IntersectionSpec:
    """Geometry of the generated net. All lengths in metres."""

    lane_width: float = 4.0  # [m] width of every lane
    lanes_per_road: int = 3  # [-] lanes on each of the eight roads
    approach_length: float = 150.0  # [m] distance from the centre to each arm's end node
    speed_limit: float = 13.89  # [m/s] edge speed limit (50 km/h)
    junction_type: str = "priority"  # SUMO node type of the centre

    @property
    def half_width(self) -> float:
        """[m] distance from an arm's axis to the outer edge of its outermost lane."""
        return self.lane_width * self.lanes_per_road

    def lane_offset(self, lane: str) -> float:
        """[m] distance of a lane's centre from its arm's axis (2, 6, 10 for 4 m lanes)."""
        k = {"inner": 0, "middle": 1, "outer": 2}[lane]
        return self.lane_width * (k + 0.5)


def incoming_lane_centre_line(spec: IntersectionSpec, approach: str, lane: str):
    """The incoming lane's centre line in the paper frame as (point on line, unit driving direction).

    An incoming vehicle drives towards the centre, i.e. opposite to ARM_DIRECTION; with right-hand
    traffic its lanes lie to the right of the arm axis.
    """
    ax, ay = ARM_DIRECTION[approach]
    dx, dy = -ax, -ay  # driving direction
    rx, ry = dy, -dx  # right-hand normal of the driving direction
    off = spec.lane_offset(lane)
    return (rx * off, ry * off), (dx, dy)
