"""The intersection's layout: arms, lanes, movements and the paper's coordinate frame.

Frame: origin at the intersection centre, x east, y north, metres.
Right-hand traffic. The paper's intersection (the default :class:`IntersectionSpec`) has four arms,
each with a three-lane road in and a three-lane road out, lane width 4 m, so lane centres sit at
+-2, +-6, +-10 m from the arm's axis (innermost first).

The generator also builds two other layouts (``IntersectionSpec(arms=..., lanes_per_road=...)``):

- ``arms=3``: a T-junction. The ``north`` arm is dropped (:data:`T_DROPPED_ARM`): ``south`` is the
  stem, ``east``-``west`` the through road. Movements whose exit arm is missing are dropped: from
  the stem only left (to the west) and right (to the east); from the east only left (to the
  south) and straight; from the west only straight and right (to the south).
- ``lanes_per_road`` 1, 2 or 3 lanes per road, named (SUMO lane index 0 first, 0 is the rightmost):
  1: ``single``; 2: ``outer``, ``inner``; 3: ``outer``, ``middle``, ``inner``
  (:data:`LANE_NAMES`; lane use per count in :data:`LANE_USE_BY_COUNT`).

Names used everywhere:
- ``approach``: the arm a vehicle comes *from* ("south" means it drives north on the south arm).
- ``lane``: "inner" / "middle" / "outer" = SUMO lane index 2 / 1 / 0 (index 0 is the rightmost)
  on the default three-lane roads; ``spec.lane_index()`` / ``spec.lane_name()`` for any count.
- ``movement``: "left" / "straight" / "right" as seen by the driver.
- edges: ``<arm>_in`` (towards the centre) and ``<arm>_out`` (away from it); the centre node is ``C``.

The module constants (ARMS, LANES, LANE_INDEX, LANE_NAME, EXIT_ARM, LANE_USE) describe the default
four-arm, three-lane intersection; the :class:`IntersectionSpec` methods describe any spec.
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

ARM_COUNTS = (3, 4)  # [-] arms the generator builds: 4 = the paper's cross, 3 = a T-junction
LANE_COUNTS = (1, 2, 3)  # [-] lanes per road the generator builds
T_DROPPED_ARM = "north"  # the arm a T-junction (arms=3) lacks: south is the stem, east-west the through road


def exit_arm(approach: str, movement: str) -> str:
    """The arm a vehicle leaves on, coming from ``approach`` and making ``movement``."""
    return EXIT_ARM[approach][movement]


# Lane use: which exit lanes each approach lane may take for each movement.
LANE_USE: dict[str, dict[str, tuple[str, ...]]] = {
    "inner": {"left": ("inner", "middle"), "straight": ("inner",)},
    "middle": {"straight": ("middle",)},
    "outer": {"right": ("outer", "middle"), "straight": ("outer",)},
}

# Lane names by SUMO lane index (0 = rightmost), per lane count.
LANE_NAMES: dict[int, tuple[str, ...]] = {
    1: ("single",),
    2: ("outer", "inner"),
    3: LANES,
}

# Lane use per lane count, on a four-arm intersection (a T drops the movements to its missing arm).
# Three lanes: the paper's table above. Two lanes: the inner lane turns left (to the inner exit
# lane) or goes straight, the outer lane goes straight or turns right (to the outer exit lane).
# One lane: every movement from the single lane to the single exit lane.
LANE_USE_BY_COUNT: dict[int, dict[str, dict[str, tuple[str, ...]]]] = {
    1: {"single": {"left": ("single",), "straight": ("single",), "right": ("single",)}},
    2: {
        "inner": {"left": ("inner",), "straight": ("inner",)},
        "outer": {"right": ("outer",), "straight": ("outer",)},
    },
    3: LANE_USE,
}


def allowed_movements(lane: str) -> tuple[str, ...]:
    return tuple(LANE_USE[lane])


@dataclass(frozen=True)
class IntersectionSpec:
    """Geometry of the generated net. All lengths in metres.

    Out-of-range ``arms`` / ``lanes_per_road`` are refused by ``build_network`` (one-line
    ``InputError``) and by the lane/arm methods below (``ValueError``).
    """

    lane_width: float = 4.0  # [m] width of every lane
    lanes_per_road: int = 3  # [-] lanes on each road (1, 2 or 3)
    approach_length: float = 150.0  # [m] distance from the centre to each arm's end node
    speed_limit: float = 13.89  # [m/s] edge speed limit (50 km/h)
    junction_type: str = "priority"  # SUMO node type of the centre
    arms: int = 4  # [-] 4 = the paper's cross, 3 = a T-junction without the north arm

    @property
    def half_width(self) -> float:
        """[m] distance from an arm's axis to the outer edge of its outermost lane."""
        return self.lane_width * self.lanes_per_road

    # --- arms -------------------------------------------------------------------------------

    def arms_present(self) -> tuple[str, ...]:
        """The arms of this intersection, in :data:`ARMS` order (a T lacks :data:`T_DROPPED_ARM`)."""
        if self.arms == 4:
            return ARMS
        if self.arms == 3:
            return tuple(a for a in ARMS if a != T_DROPPED_ARM)
        raise ValueError(f"arms = {self.arms!r}: must be one of {', '.join(map(str, ARM_COUNTS))}")

    def exit_arms(self) -> dict[str, dict[str, str]]:
        """approach -> movement -> exit arm, only the movements whose exit arm exists."""
        present = self.arms_present()
        return {a: {mv: EXIT_ARM[a][mv] for mv in MOVEMENTS if EXIT_ARM[a][mv] in present}
                for a in present}

    def exit_arm(self, approach: str, movement: str) -> str:
        """The arm a vehicle leaves on; ``ValueError`` if this intersection has no such movement."""
        try:
            return self.exit_arms()[approach][movement]
        except KeyError:
            raise ValueError(f"no {movement} movement from the {approach} arm of a {self.arms}-arm "
                             "intersection") from None

    def movements(self, approach: str) -> tuple[str, ...]:
        """The movements possible from ``approach`` (left, straight, right order)."""
        return tuple(self.exit_arms()[approach])

    # --- lanes ------------------------------------------------------------------------------

    def lanes(self) -> tuple[str, ...]:
        """Lane names by SUMO lane index (0 = rightmost): :data:`LANE_NAMES` for this lane count."""
        try:
            return LANE_NAMES[self.lanes_per_road]
        except KeyError:
            raise ValueError(f"lanes_per_road = {self.lanes_per_road!r}: must be one of "
                             f"{', '.join(map(str, LANE_COUNTS))}") from None

    def lane_index(self) -> dict[str, int]:
        """Lane name -> SUMO lane index (:data:`LANE_INDEX` for three lanes)."""
        return {name: i for i, name in enumerate(self.lanes())}

    def lane_name(self) -> dict[int, str]:
        """SUMO lane index -> lane name (:data:`LANE_NAME` for three lanes)."""
        return dict(enumerate(self.lanes()))

    def lane_use(self, approach: str | None = None) -> dict[str, dict[str, tuple[str, ...]]]:
        """approach lane -> movement -> the exit lanes it may take.

        Without ``approach``: the table of this lane count on a four-arm intersection
        (:data:`LANE_USE_BY_COUNT`). With it: only the movements that exist from that arm, and only
        the lanes left with a movement (the middle lane of a three-lane T's stem has none: it only
        went straight).
        """
        self.lanes()  # validates lanes_per_road
        table = LANE_USE_BY_COUNT[self.lanes_per_road]
        if approach is None:
            return {lane: dict(moves) for lane, moves in table.items()}
        possible = self.movements(approach)
        out = {lane: {mv: exits for mv, exits in moves.items() if mv in possible}
               for lane, moves in table.items()}
        return {lane: moves for lane, moves in out.items() if moves}

    def lane_offset(self, lane: str) -> float:
        """[m] distance of a lane's centre from its arm's axis (2, 6, 10 for 4 m lanes)."""
        k = self.lanes_per_road - 1 - self.lane_index()[lane]  # 0 = innermost
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
