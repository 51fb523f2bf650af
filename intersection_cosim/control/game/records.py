"""What one game's solve leaves behind: its convergence record (the paper's Fig. 3) and its
answer for one vehicle."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from intersection_cosim.games.problem import Plan


@dataclass(frozen=True)
class ConvergenceRecord:
    """One game's solve: the data of the paper's Fig. 3. A cluster game (control/game/cluster_games.py)
    names its first player in ``vehicle_a`` and the others, joined by "+", in ``vehicle_b``."""

    time: float  # [s]
    vehicle_a: str
    vehicle_b: str
    solver: str
    status: str
    iterations: int
    residuals: tuple[float, ...]  # [m/s^2] per iteration
    costs: tuple[float, ...]  # [-] final cost of each player


class Choice(NamedTuple):
    """One game's (or solo problem's) answer for one vehicle."""

    first_accel: float  # [m/s^2] the plan's first acceleration
    plan: Plan
    option: str  # exit lane
