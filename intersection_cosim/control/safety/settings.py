"""The ``[controller.safety]`` table of the game controllers: the junction guard's rules
(control/safety/rules/) and their parameters, each documented where it is set."""

from __future__ import annotations

from dataclasses import dataclass

from intersection_cosim.settings import non_negative

YIELD_ORDERS = ("tcp", "plan")


@dataclass(frozen=True)
class SafetySettings:
    """The junction guard on the game controllers' accelerations (not in the paper)."""

    enabled: bool = True  # [-] run the safety filter's rules on every acceleration (false: an ablation)
    time_gap: float = 0.5  # [s] least time between two vehicles' occupancies of a crossing zone
    # [-] share of time_gap kept for a pair that plays its game this step (its plans are a game's;
    # not in a fallback step, whose plans are the last ones shifted; 1: one gap for all): below the
    # full gap the filter leaves the pair's margin to the game's trade-off (Eq. 13) and only
    # catches what the game misses
    game_gap_share: float = 0.4
    margin: float = 1.0  # [m] a vehicle stops this far before a crossing zone and behind its leader
    yield_order: str = "tcp"  # [-] who ranks first at a crossing among vehicles not yet in the
    #                          junction: "tcp" = smaller time to the crossing at the current speed
    #                          (the paper's leader rule, Section IV-D; a pair that played its game
    #                          keeps the game's order, by its plans), "plan" = earlier arrival by
    #                          this step's plans for every pair
    clear_accel: float = 1.0  # [m/s^2] a vehicle standing inside a crossing zone that another waits
    #                           for drives out at least this hard (box_clear)
    clear_speed: float = 1.0  # [m/s] below it a vehicle counts as standing (box_clear, stalled_box)
    human_brake: float = 2.0  # [m/s^2] a human braking at least this hard (or standing) where it will
    #                           stop inside a crossing holds the AVs of that crossing at their stop lines
    human_margin: float = 2.0  # [m] an AV in the junction yielding to a human stops this far before
    #                            their crossing zone (SUMO's conflict areas are lane-wide, wider than
    #                            a body, and SUMO holds a human for a vehicle whose front is in one)
    # [-] an AV not yet in the junction waits at its stop line while an AV inside stalls short of
    # leaving their crossing, and that AV drives on: a stalled box takes no new entrant into its
    # crossings, so waits inside it cannot grow into a cycle (stalled_box)
    stalled_box_hold: bool = True
    # [s] a vehicle in the junction stalls if its speed is below clear_speed now or will be within
    # this time at its present deceleration (stalled_box)
    stalled_box_lookahead: float = 1.0
    exit_room: bool = True  # [-] don't block the box: hold a vehicle at its stop line while its exit
    #                         lane has less than its length + exit_min_gap free (exit_room)
    exit_min_gap: float = 2.5  # [m] standstill gap a vehicle needs on its exit lane (SUMO's minGap)
    yield_to_pedestrians: bool = True  # [-] false: the vehicles ignore people (an ablation: they are hit)
    pedestrian_time_gap: float = 1.5  # [s] least time between a pedestrian's and a vehicle's time on
    #                                   the vehicle's stretch of a crossing
    pedestrian_clearance: float = 1.0  # [m] room kept to a pedestrian along the crossing, each side
    pedestrian_margin: float = 1.5  # [m] a vehicle yielding inside the junction stops this far before the crossing
    pedestrian_speed_low: float = 0.5  # [m/s] a slower (or standing) pedestrian is predicted to walk on at this
    pedestrian_speed_high: float = 1.5  # [m/s] a slower pedestrian may reach the vehicle's stretch at this speed

    def check(self) -> list[tuple[str, str]]:
        problems = [("game_gap_share", "must lie in [0, 1]")] if not 0 <= self.game_gap_share <= 1 else []
        problems += non_negative(self, "time_gap", "margin", "clear_accel", "clear_speed", "exit_min_gap",
                                 "stalled_box_lookahead", "human_brake", "human_margin", "pedestrian_time_gap",
                                 "pedestrian_clearance", "pedestrian_margin")
        problems += [(name, "must be > 0") for name in ("pedestrian_speed_low", "pedestrian_speed_high")
                     if not getattr(self, name) > 0]
        if self.yield_order not in YIELD_ORDERS:
            problems.append(("yield_order", f"must be one of {', '.join(YIELD_ORDERS)}"))
        return problems

    def gap_for(self, play: bool) -> float:
        """[s] the least time between the occupancies of a pair that plays its game this step
        (``play``) or not."""
        return self.time_gap * (self.game_gap_share if play else 1.0)
