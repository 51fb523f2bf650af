"""A player's weights in its cost over the horizon (games/objective.py): the risk weight of each
J_lat term (Eq. 19) by the two players' aggressiveness (Eq. 7's factors), the comfort weight by
kappa, the Hessian of the exact quadratic terms, and the player's own acceleration limits."""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from intersection_cosim.games.dynamics import horizon_matrices
from intersection_cosim.games.problem import Player
from intersection_cosim.games.settings import GameSettings
from intersection_cosim.models.settings import ModelSettings


def partner_risk_weight(kappa_partner: float, ms: ModelSettings) -> float:
    """[-] weight of a player's J_lat term (Eq. 19) with a partner of aggressiveness
    ``kappa_partner``: exp(k_lat_partner (kappa_partner - 0.5)), 1 for a partner at 0.5. The
    risk a vehicle poses grows with its aggressiveness, as its potential field's amplitude a^q =
    a_0 exp(kappa^q) does (Eq. 7); ``ModelSettings.k_lat_partner`` = 1 is that factor itself."""
    return math.exp(ms.k_lat_partner * (kappa_partner - 0.5))


def own_risk_weight(kappa_own: float, ms: ModelSettings) -> float:
    """[-] factor of every J_lat term (Eq. 19) of a player of aggressiveness ``kappa_own``:
    exp(-k_lat_own (kappa_own - 0.5)), 1 at 0.5: a cautious player heightens the risk it takes;
    ``ModelSettings.k_lat_own`` = 1 is Eq. 7's factor of its own field, a^p = a_0 exp(kappa^p),
    so with k_lat_partner = 1 too a term weighs the partner's field against the player's own."""
    return math.exp(-ms.k_lat_own * (kappa_own - 0.5))


def lateral_risk_weight(kappa_own: float, kappa_partner: float, ms: ModelSettings) -> float:
    """[-] weight of a player's J_lat term (Eq. 19) with a partner: the partner's risk times the
    player's own factor (:func:`partner_risk_weight`, :func:`own_risk_weight`), at least 1. The
    floor keeps an aggressive player, or one facing a cautious partner, from caring less about a
    crossing than Eq. 19 does: without it the safety filter stepped in much more often at high
    demand and runs could lock (decision record 023)."""
    return max(1.0, partner_risk_weight(kappa_partner, ms) * own_risk_weight(kappa_own, ms))


@functools.lru_cache(maxsize=256)
def comfort_weight(problem, kappa: float) -> float:
    """[s^4/m^2] a player's weight of the squared acceleration, by its aggressiveness ``kappa``
    (``ProblemSettings.w_accel`` at kappa = 0.5, falling by ``w_accel_kappa`` per unit of kappa,
    never below ``w_accel_floor`` nor raised by it above ``w_accel``)."""
    floor = min(problem.w_accel_floor, problem.w_accel)  # [s^4/m^2]
    return max(floor, problem.w_accel + problem.w_accel_kappa * (0.5 - kappa))


@functools.lru_cache(maxsize=1024)  # one entry per kappa in play: built once per vehicle, not per solve
def quadratic_part(n: int, dt: float, w_e: float, w_accel: float, jerk_w: float) -> np.ndarray:
    """Hessian of the exact quadratic terms: sum w_e (v - v_max)^2 + dt w_accel a^2 + dt jerk_w da^2
    (read-only)."""
    hm = horizon_matrices(n, dt)
    Q = (2.0 * w_e * dt * dt) * hm.LtL + (2.0 * dt * w_accel) * hm.eye + (2.0 * dt * jerk_w) * hm.DtD
    Q.setflags(write=False)
    return Q


def own_limits(gs: GameSettings, pl: Player) -> GameSettings:
    """``gs`` with [a_min, a_max] narrowed to player ``pl``'s own limits (its vType's decel and
    accel, :attr:`Player.a_min` / :attr:`Player.a_max`); ``gs`` itself when they do not narrow it."""
    lo = gs.problem.a_min if pl.a_min is None else max(gs.problem.a_min, float(pl.a_min))  # [m/s^2]
    hi = gs.problem.a_max if pl.a_max is None else min(gs.problem.a_max, float(pl.a_max))  # [m/s^2]
    if lo == gs.problem.a_min and hi == gs.problem.a_max:
        return gs
    return dataclasses.replace(gs, problem=dataclasses.replace(gs.problem, a_min=lo, a_max=hi))
