"""Settings of the game controller beyond the game itself: its policy (re-planning, lane choice,
the anytime schedule), a typed frozen object with documented defaults set from the scenario table
``[controller.policy]``; its safety filter's settings are control/safety/settings.py's SafetySettings.

:class:`GameControllerSettings` gathers the four tables of the ``nash`` and ``stackelberg``
controllers: ``[controller.game]`` (the game problem), ``[controller.solver]``,
``[controller.policy]`` and ``[controller.safety]``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from intersection_cosim.control.safety.settings import SafetySettings
from intersection_cosim.games.settings import GameSettings, ProblemSettings, SolverSettings
from intersection_cosim.settings import non_negative, positive


@dataclass(frozen=True)
class PolicySettings:
    """How the controller re-plans, chooses exit lanes and meets its step budget."""

    free_resolve_steps: int = 5  # [-] most control steps between solves of a vehicle in no game
    #                              whose inputs did not change (control/game/solo.py)
    game_resolve_steps: int = 5  # [-] most control steps between solves of a pair's game whose
    #                              inputs did not change (control/game/game_reuse.py; 1: solve every step)
    game_reuse_gap: float = 1.0  # [s] ... and whose players' planned arrivals at each of their
    #                              conflict points are at least this far apart
    solo_max_iter: int = 1  # [-] SQP steps of a solo vehicle's best response per control step
    #                         (real-time iteration: an unconverged plan is applied and the SQP
    #                         goes on from it, shifted, at the next step)
    # [-] equilibrium iterations per control step of a game in progress, one whose warm start is
    # its own equilibrium of the last step (Nash best-response rounds, Stackelberg leader steps;
    # 0: only the solver's caps): an unconverged game applies its last iterate and goes on from
    # it at the next step, the real-time iteration of solo_max_iter. A pair's first solve, and
    # one after a pause, runs in full (decision record 018)
    game_max_iter: int = 1
    solo_leader_tol: float = 0.1  # [m] and [m/s]: a solo vehicle solves again when its leader's
    #                               predicted positions (speeds) moved more than this since its solve
    solo_speed_tol: float = 0.05  # [m/s] ... or when its measured speed is this far from its shifted
    #                               plan's (it left the plan; not counted while the filter holds it)
    solo_position_tol: float = 0.5  # [m] ... or its measured position this far from the plan's
    solo_reuse_residual: float = 0.3  # [m/s^2] a capped (real-time) SQP step that moved the plan
    #                                   less than this, or than nash_tol, counts as converged: its
    #                                   plan may be kept, shifted, instead of iterating on at once
    #                                   (0: only nash_tol; free_resolve_steps still forces a solve)
    lane_choice_range: float = 30.0  # [m] a vehicle chooses among its exit lanes only within this
    #                                  distance of its stop line (v_max * horizon: what the plan
    #                                  reaches); farther out it keeps its current exit lane
    lane_choice_period: int = 5  # [-] control steps between a vehicle's exit-lane decisions (it
    #                              holds its choice in between; 1 = decide every step)
    # [-] a pair of AVs whose crossing the safety filter had to guard plays its game from the next
    # control step on until the crossing is passed, whatever Gamma_cp says (an event of the ETM,
    # Eq. 39, beside Gamma_cp > Gamma_sf): the game, not the filter, then sets its margin; the
    # event ends once both are in the junction and one is below SafetySettings.clear_speed.
    # With game_gap_share it hands Case 1 D's margin to the aggressive pair's game; it costs the
    # trigger its saving in Case 1 A (decision records 024, 025)
    filter_event: bool = True
    # [s] hysteresis of the ETM (Eq. 39): a pair that played its game keeps playing at the next
    # step while neither has passed its conflict point and their times to it (TCP, Eqs. 21-22)
    # differ by less than this, whatever Gamma_cp says; it ends once both are in the junction and
    # one is below SafetySettings.clear_speed (0: off, the ETM alone). Without it a cautious
    # yielder that slowed for its game leaves its own preview t_p^i (TCP > t_p^i: Gamma_cp = 0),
    # plans alone, speeds up, fires the ETM again and brakes, every other step. It keeps more
    # games in play at high demand, which costs compute (decision records 021, 027)
    trigger_hold_gap: float = 6.0
    anytime_reserve: float = 0.1  # [-] share of the step budget kept for the safety filter (at
    #                               least twice its measured mean time): games and solo solves that
    #                               would not finish before the rest of the budget are deferred
    #                               (their vehicles keep their last plan, shifted); see decision
    #                               record 012

    cluster_check: bool = False  # [-] check every converged cluster game for unilateral deviations
    #                               (games/coupled_check.py) into games.csv; after the loop, outside
    #                               the step budget (a check takes 10-100 times a solve)

    def check(self) -> list[tuple[str, str]]:
        problems = positive(self, "free_resolve_steps", "game_resolve_steps", "solo_max_iter", "lane_choice_period")
        problems += non_negative(self, "game_max_iter", "solo_leader_tol", "solo_speed_tol", "solo_position_tol",
                                 "solo_reuse_residual", "game_reuse_gap", "lane_choice_range", "anytime_reserve", "trigger_hold_gap")
        if not self.anytime_reserve < 1:
            problems.append(("anytime_reserve", "must be < 1"))
        return problems


@dataclass(frozen=True)
class GameControllerSettings:
    """Everything the ``nash`` and ``stackelberg`` controllers are set with, one table each."""

    game: ProblemSettings = field(default_factory=ProblemSettings)  # [controller.game]
    solver: SolverSettings = field(default_factory=SolverSettings)  # [controller.solver]
    policy: PolicySettings = field(default_factory=PolicySettings)  # [controller.policy]
    safety: SafetySettings = field(default_factory=SafetySettings)  # [controller.safety]

    @property
    def games(self) -> GameSettings:
        """The game problem and solver, as the games layer takes them."""
        return GameSettings(self.game, self.solver)
