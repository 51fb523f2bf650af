"""Vehicle types in the games (issue 16): a leader's own length enters the follower's J_log
(Eqs. 15-18, the gap is to the leader's rear), and a player's own accel / decel bound its plan."""

import numpy as np
import pytest

from intersection_cosim.games.nash import nash_equilibrium
from intersection_cosim.games.objective import PlayerObjective
from intersection_cosim.games.problem import Interaction, Plan, Player, Problem
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.games.stackelberg import stackelberg_equilibrium
from intersection_cosim.models.settings import ModelSettings

GS, MS = GameSettings(), ModelSettings()
N, DT = GS.problem.steps, GS.problem.dt
BUS = 12.0  # [m]


def _leader(ahead: float) -> tuple[np.ndarray, np.ndarray]:
    """A leader ``ahead`` [m] (front) of the follower's start, driving 3 m/s."""
    t = np.arange(1, N + 1) * DT  # [s]
    return ahead + 3.0 * t, np.full(N, 3.0)


def _cost(player: Player, a: np.ndarray) -> float:
    return float(PlayerObjective(Problem((player,)), 0, GS, MS).cost(a))


def test_a_bus_leader_costs_what_a_car_leader_7_5_m_closer_costs():
    """Only the leader's rear enters J_log: a 12 m leader with its front 25 m ahead is a 4.5 m
    leader with its front 17.5 m ahead, to the number."""
    a = np.full(N, 0.5)  # [m/s^2]
    bus = _cost(Player(0.0, 8.0, 0.3, leader=_leader(25.0), leader_length=BUS), a)
    car_closer = _cost(Player(0.0, 8.0, 0.3, leader=_leader(25.0 - (BUS - MS.vehicle_length))), a)
    car_same = _cost(Player(0.0, 8.0, 0.3, leader=_leader(25.0)), a)
    assert bus == pytest.approx(car_closer, rel=1e-12)
    assert bus > car_same * 1.5  # the bus's rear is nearer: J_log is larger


def test_a_leading_player_gap_is_to_its_own_rear():
    """A following interaction between players: the leader player's ``length`` sets the gap."""
    a = np.full(N, 0.5)
    follower = Player(0.0, 8.0, 0.3)

    def cost(leader: Player) -> float:
        obj = PlayerObjective(Problem((follower, leader), (Interaction.following(0, 1),)), 0, GS, MS)
        obj.set_others([None, Plan.from_accelerations(leader.s0, leader.v0, np.zeros(N), DT)])
        return float(obj.cost(a))

    assert cost(Player(25.0, 3.0, 0.5, length=BUS)) == pytest.approx(cost(Player(17.5, 3.0, 0.5)), rel=1e-12)
    assert cost(Player(25.0, 3.0, 0.5, length=BUS)) > cost(Player(25.0, 3.0, 0.5))


def test_a_follower_stays_farther_back_behind_a_bus():
    behind_bus = nash_equilibrium(Problem((Player(0.0, 8.0, 0.2, leader=_leader(25.0), leader_length=BUS),)), GS)
    behind_car = nash_equilibrium(Problem((Player(0.0, 8.0, 0.2, leader=_leader(25.0)),)), GS)
    assert behind_bus.status == behind_car.status == "converged"
    gap_to_rear = _leader(25.0)[0] - BUS - behind_bus.plans[0].positions[1:]  # [m]
    assert gap_to_rear.min() > 1.0
    assert behind_bus.plans[0].positions[-1] < behind_car.plans[0].positions[-1] - 1.0


@pytest.mark.parametrize("solve", [nash_equilibrium, stackelberg_equilibrium])
def test_own_accel_and_decel_bound_the_plan(solve):
    """A slow bus (accel 1.2) far from its desired speed plans no more than 1.2 m/s^2 while a
    car of the same state plans up to the game's a_max; a cross partner is bounded by its own."""
    cross = (Interaction.cross(0, 1, 30.0, 30.0),)
    free = solve(Problem((Player(0.0, 2.0, 0.9), Player(-40.0, 2.0, 0.9)), cross), GS)
    bus = solve(Problem((Player(0.0, 2.0, 0.9, a_max=1.2, a_min=-3.0), Player(-40.0, 2.0, 0.9, a_max=1.0)), cross), GS)
    assert free.plans[0].accelerations.max() > 2.0
    assert bus.plans[0].accelerations.max() <= 1.2 + 1e-9
    assert bus.plans[0].accelerations.min() >= -3.0 - 1e-9
    assert bus.plans[1].accelerations.max() <= 1.0 + 1e-9
    assert bus.plans[0].accelerations.max() > 1.0  # it does use what it has
