"""Settings of the safety filter on the controllers' accelerations, a typed frozen object with
documented defaults, set from the scenario table ``[controller.safety]``.

The game controller's other settings (its policy and the gathering :class:`GameControllerSettings`)
are in control/game/settings.py.
"""

from __future__ import annotations

from dataclasses import dataclass

from intersection_cosim.settings import non_negative

YIELD_ORDERS = ("tcp", "plan")


@dataclass(frozen=True)
class SafetySettings:
    """The safety filter on the controller's accelerations (not in the paper; control/safety.py)."""

    safety_filter: bool = True  # [-] check every applied acceleration against collision
    safety_time_gap: float = 0.5  # [s] least time between two vehicles' occupancy of a conflict point
    # [-] share of safety_time_gap kept for a pair that plays its game this step (its plans are a
    # game's; not in a fallback step, whose plans are the last ones shifted; 1: one gap for all):
    # below the full gap the filter leaves the pair's margin to the game's trade-off (Eq. 13) and
    # only catches what the game misses (issue 20; 0.4 with PolicySettings.filter_event hands
    # Case 1's margins to the game, docs/design.md rounds 3 and 8)
    game_gap_share: float = 0.4
    safety_margin: float = 1.0  # [m] stop this far before a conflict point / behind a leader
    yield_order: str = "tcp"  # who ranks first at a crossing among vehicles not yet in the
    #                          junction: "tcp" = smaller time to the crossing at the current speed
    #                          (the paper's leader rule, Section IV-D; a pair that played its game
    #                          keeps the game's order, by its plans), "plan" = earlier arrival by
    #                          this step's plans for every pair
    clear_accel: float = 1.0  # [m/s^2] box rule: a vehicle standing (below clear_speed) inside a
    #                           crossing that another vehicle waits for drives out at least this hard
    clear_speed: float = 1.0  # [m/s]
    human_brake: float = 2.0  # [m/s^2] a human braking at least this hard (or standing) where it will
    #                           stop inside a crossing holds the AVs of that crossing at their stop lines
    human_margin: float = 2.0  # [m] an AV in the junction yielding to a human stops this far before
    #                            their crossing zone (SUMO's conflict areas are lane-wide, wider than
    #                            a body, and SUMO holds a human for a vehicle whose front is in one)
    # [-] an AV not yet in the junction waits at its stop line while an AV inside stalls short of
    # leaving their crossing, and that AV drives on: a stalled box takes no new entrant into its
    # crossings, so waits inside it cannot grow into a cycle (three vehicles, each standing in the
    # next one's crossing, locked demand_balanced_high with the 0.4 gap share, the events and the
    # hold; docs/design.md, issue 20 round 9)
    stalled_box_hold: bool = True
    # [s] for stalled_box_hold a vehicle in the junction stalls if its speed is below clear_speed
    # now or will be within this time at its present deceleration (one crawling at 1.05 m/s and
    # braking at 1.7 m/s^2 let a third vehicle in: the same cycle, 10 s later)
    stalled_box_lookahead: float = 1.0
    exit_room: bool = True  # [-] don't block the box: hold a vehicle at its stop line while its exit
    #                         lane has less than vehicle_length + exit_min_gap free (control/exit_room.py)
    exit_min_gap: float = 2.5  # [m] standstill gap a vehicle needs on its exit lane (SUMO's minGap)
    # pedestrians at the crossings of a managed junction (control/pedestrians.py)
    yield_to_pedestrians: bool = True  # [-] false: the vehicles ignore people (an ablation: they are hit)
    pedestrian_time_gap: float = 1.5  # [s] least time between a pedestrian's and a vehicle's time on
    #                                   the vehicle's stretch of a crossing
    pedestrian_clearance: float = 1.0  # [m] room kept to a pedestrian along the crossing, each side
    pedestrian_margin: float = 1.5  # [m] a vehicle yielding inside the junction stops this far before the crossing
    pedestrian_speed_low: float = 0.5  # [m/s] a slower (or standing) pedestrian is predicted to walk on at this
    pedestrian_speed_high: float = 1.5  # [m/s] a slower pedestrian may reach the vehicle's stretch at this speed

    def check(self) -> list[tuple[str, str]]:
        problems = [("game_gap_share", "must lie in [0, 1]")] if not 0 <= self.game_gap_share <= 1 else []
        problems += non_negative(self, "safety_time_gap", "safety_margin", "clear_accel", "clear_speed", "exit_min_gap",
                                 "stalled_box_lookahead",
                                 "human_brake", "human_margin", "pedestrian_time_gap", "pedestrian_clearance",
                                 "pedestrian_margin")
        problems += [(name, "must be > 0") for name in ("pedestrian_speed_low", "pedestrian_speed_high")
                     if not getattr(self, name) > 0]
        if self.yield_order not in YIELD_ORDERS:
            problems.append(("yield_order", f"must be one of {', '.join(YIELD_ORDERS)}"))
        return problems

    def time_gap(self, play: bool) -> float:
        """[s] the least time between the occupancies of a pair that plays its game this step (``play``) or not."""
        return self.safety_time_gap * (self.game_gap_share if play else 1.0)
