"""Game solvers of the decision layer (paper Section IV). Pure: no simulator import.

Each vehicle follows its own lane path; a player's decision is its acceleration sequence over the
horizon, its cost the paper's running cost (Eqs. 13-24, from ``models.cost``) summed over the
horizon. Entry points:

* :func:`best_response` - one player against the others' plans (sequential QP; each QP exact when
  no bound is active, else OSQP);
* :func:`nash_equilibrium` - iterated best response (Eq. 25);
* :func:`stackelberg_equilibrium` - leader with the smaller TCP, follower through its KKT
  conditions (Eqs. 34-40);
* :func:`lane_choice_game` - pure equilibrium over discrete lane options;
* :func:`check_nash`, :func:`check_stackelberg` - independent equilibrium checks;
* :func:`shift_plans` - warm start for the next control step.
"""

from intersection_cosim.games.battery import battery, random_pair
from intersection_cosim.games.sqp import BestResponseResult, best_response
from intersection_cosim.games.checks import (Deviation, NashCheck, StackelbergCheck,
                                             best_deviation, check_nash, check_stackelberg)
from intersection_cosim.games.lane_choice import (LaneChoiceResult, lane_change_cost,
                                                  lane_choice_game)
from intersection_cosim.games.nash import nash_equilibrium
from intersection_cosim.games.problem import (GameResult, Interaction, Plan, Player, Problem,
                                              safe_plan, shift_plan, shift_plans)
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.games.stackelberg import stackelberg_equilibrium, stackelberg_leader

__all__ = [
    "BestResponseResult", "Deviation", "GameResult", "GameSettings", "Interaction",
    "LaneChoiceResult", "NashCheck", "Plan", "Player", "Problem", "StackelbergCheck", "battery",
    "best_deviation", "best_response", "check_nash", "check_stackelberg", "lane_change_cost",
    "lane_choice_game", "nash_equilibrium", "random_pair", "safe_plan", "shift_plan",
    "shift_plans", "stackelberg_equilibrium", "stackelberg_leader",
]
