"""Problem data of the longitudinal game, plans, results, and the plan utilities.

The formulation (paper Section III-IV, reduced to the co-simulation): every player i follows its
own lane path; its state is the arc length s [m] along that path and the speed v [m/s]; its decision
is the acceleration sequence a_0 .. a_{N-1} [m/s^2] over the horizon (N = horizon / dt). The
dynamics are the longitudinal part of Eq. 2, discretised exactly for piecewise-constant a:

    v_{k+1} = v_k + a_k dt,        s_{k+1} = s_k + v_k dt + a_k dt^2 / 2,

so speeds and positions are affine in the accelerations. The game couples players only through
the safety costs of their :class:`Interaction` s (J_lat of Eq. 19 for cross / confluence conflicts,
J_log of Eq. 15 for a following pair).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Sequence

import numpy as np

from intersection_cosim.games.dynamics import horizon_matrices, plan_trajectory, shifted_trajectory
from intersection_cosim.games.settings import GameSettings

INTERACTION_KINDS = ("cross", "confluence", "following")
STATUSES = ("converged", "iteration cap", "solver failure", "deadline")


@dataclass(frozen=True)
class Player:
    """One vehicle of the game, at the start of the horizon."""

    s0: float  # [m] arc length along the player's own path
    v0: float  # [m/s] speed (>= 0)
    kappa: float  # [-] aggressiveness in [0, 1] (Eq. 13)
    v_max: float | None = None  # [m/s] max / desired speed of J_e (Eq. 24); None: ModelSettings.v_max
    j_lk: float = 0.0  # [-] J_lk (Eq. 23) of the player's discrete lane choice, constant in time
    preferred_lane: str | None = None  # the exit lane the player would keep without a game
    name: str = ""
    #: A leading vehicle that is not a player: its predicted positions s_1..s_N [m], already in
    #: this player's path coordinates (front bumper), and speeds v_1..v_N [m/s]. It enters the
    #: player's J_log (Eqs. 15-18) exactly like a following interaction, but nobody optimises it:
    #: the leader's cost has no term for its follower, so this is part of the player's own
    #: problem, not a game. Kept by :meth:`Problem.decoupled`.
    leader: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False, compare=False)
    length: float | None = None  # [m] its body, bumper to bumper: its gap to a follower (None: ModelSettings.vehicle_length)
    leader_length: float | None = None  # [m] the body of ``leader`` (None: ModelSettings.vehicle_length)
    a_max: float | None = None  # [m/s^2] its own strongest acceleration (its vType's accel); the plan's
    #                             upper bound is the smaller of it and ProblemSettings.a_max (None: that)
    a_min: float | None = None  # [m/s^2] its own hardest planned braking (< 0, minus its vType's decel);
    #                             the plan's lower bound is the larger of it and ProblemSettings.a_min
    #: Crossing vehicles that are not players (human drivers): per crossing (s_cp own [m], s_cp on
    #: the other's path [m], its predicted positions s_1..s_N [m] in its own path, its speeds
    #: v_1..v_N [m/s]). Each enters the player's J_lat (Eqs. 19-22) like a cross interaction with
    #: a partner whose plan is fixed: part of the player's own problem, kept by
    #: :meth:`Problem.decoupled`.
    crossers: tuple[tuple[float, float, np.ndarray, np.ndarray], ...] = field(default=(), repr=False, compare=False)


@dataclass(frozen=True)
class Interaction:
    """A coupling between two players.

    * ``cross`` / ``confluence``: the paths of ``i`` and ``j`` meet at a conflict point at arc
      length ``s_cp_i`` on i's path and ``s_cp_j`` on j's path [m]. Both players carry
      J_lat = 1 / (TTC_lat^2 + eps) (Eqs. 19-22) while neither has passed its conflict point by
      more than ``ModelSettings.conflict_clearance``.
    * ``following``: ``i`` follows the leading vehicle ``j`` on the same lane. In i's path
      coordinates the leader is at ``s_j + offset`` [m]; the gap is that minus s_i minus the
      leader's length (``Player.length``). Only the follower carries J_log (Eqs. 15-18).

    Build with :meth:`cross`, :meth:`confluence` or :meth:`following`.
    """

    kind: str
    i: int
    j: int
    s_cp_i: float = math.nan  # [m] conflict point on i's path (cross / confluence)
    s_cp_j: float = math.nan  # [m] conflict point on j's path (cross / confluence)
    offset: float = 0.0  # [m] leader position in the follower's path = s_j + offset (following)

    @classmethod
    def cross(cls, i: int, j: int, s_cp_i: float, s_cp_j: float) -> "Interaction":
        return cls("cross", i, j, float(s_cp_i), float(s_cp_j))

    @classmethod
    def confluence(cls, i: int, j: int, s_cp_i: float, s_cp_j: float) -> "Interaction":
        return cls("confluence", i, j, float(s_cp_i), float(s_cp_j))

    @classmethod
    def following(cls, follower: int, leader: int, offset: float = 0.0) -> "Interaction":
        return cls("following", follower, leader, offset=float(offset))

    @property
    def lateral(self) -> bool:
        return self.kind in ("cross", "confluence")

    def involves(self, p: int) -> bool:
        return p in (self.i, self.j)


@dataclass(frozen=True)
class Problem:
    """Players and their interactions at one control step."""

    players: tuple[Player, ...]
    interactions: tuple[Interaction, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "players", tuple(self.players))
        object.__setattr__(self, "interactions", tuple(self.interactions))

    @property
    def n(self) -> int:
        return len(self.players)

    def validate(self) -> list[str]:
        """Structural and numerical problems of the input; empty when the input is usable."""
        out = []
        if not self.players:
            out.append("no players")
        for k, p in enumerate(self.players):
            for name in ("s0", "v0", "kappa", "j_lk"):
                if not math.isfinite(getattr(p, name)):
                    out.append(f"player {k}: {name} is not finite")
            if math.isfinite(p.v0) and p.v0 < 0.0:
                out.append(f"player {k}: v0 < 0")
            if p.v_max is not None and not (math.isfinite(p.v_max) and p.v_max > 0):
                out.append(f"player {k}: v_max must be finite and > 0")
            if math.isfinite(p.kappa) and not 0.0 <= p.kappa <= 1.0:
                out.append(f"player {k}: kappa must lie in [0, 1]")
            if p.leader is not None and not all(np.isfinite(x).all() for x in p.leader):
                out.append(f"player {k}: leader trajectory is not finite")
            if any(not all(np.isfinite(x).all() for x in c) for c in p.crossers):
                out.append(f"player {k}: a crossing trajectory is not finite")
        for m, it in enumerate(self.interactions):
            if it.kind not in INTERACTION_KINDS:
                out.append(f"interaction {m}: unknown kind {it.kind!r}")
            if not (0 <= it.i < self.n and 0 <= it.j < self.n) or it.i == it.j:
                out.append(f"interaction {m}: players {it.i}, {it.j} invalid")
            if it.lateral and not (math.isfinite(it.s_cp_i) and math.isfinite(it.s_cp_j)):
                out.append(f"interaction {m}: conflict point not finite")
            if it.kind == "following" and not math.isfinite(it.offset):
                out.append(f"interaction {m}: offset not finite")
        return out

    def replace_player(self, k: int, **changes) -> "Problem":
        """Copy with ``players[k]`` replaced by ``dataclasses.replace(players[k], **changes)``."""
        players = list(self.players)
        players[k] = replace(players[k], **changes)
        return replace(self, players=tuple(players))

    def decoupled(self) -> "Problem":
        """The zeroth-order problem of Section IV-C: same players, no interactions (Eq. 33)."""
        return replace(self, interactions=())


@dataclass(frozen=True, eq=False)
class Plan:
    """An open-loop plan of one player over the horizon.

    ``duals`` is solver state for warm starts: the multipliers of the last QP's 2N rows (input
    box, then speed bounds) at this plan; :func:`shift_plan` shifts them with the plan.
    """

    accelerations: np.ndarray = field(repr=False)  # [m/s^2] a_0 .. a_{N-1}, shape (N,)
    speeds: np.ndarray = field(repr=False)  # [m/s] v_0 .. v_N, shape (N + 1,)
    positions: np.ndarray = field(repr=False)  # [m] s_0 .. s_N along the own path, shape (N + 1,)
    dt: float  # [s]
    duals: np.ndarray | None = field(default=None, repr=False)  # [-] QP multipliers, shape (2N,)

    @classmethod
    def from_accelerations(cls, s0: float, v0: float, a, dt: float,
                           duals: np.ndarray | None = None) -> "Plan":
        a = np.array(a, dtype=float)
        v, s = plan_trajectory(s0, v0, a, horizon_matrices(a.shape[0], float(dt)))
        return cls(a, v, s, dt, duals)

    @property
    def steps(self) -> int:
        return len(self.accelerations)

    @property
    def mean_speed(self) -> float:
        """[m/s] mean of the planned speeds v_1 .. v_N."""
        return float(np.mean(self.speeds[1:]))


@dataclass(frozen=True)
class GameResult:
    """Outcome of :func:`nash_equilibrium` or :func:`stackelberg_equilibrium`.

    ``costs`` are the players' true costs dt * sum_k J_i(k) (+ comfort), the negative of the
    payoff P_i of Eq. 12 with a constant terminal payoff. ``residuals[m]`` [m/s^2] is the largest
    change of any player's acceleration in iteration m + 1, ``cost_history[m]`` the costs after it
    (the data of the paper's Fig. 3).
    """

    plans: tuple[Plan, ...]
    costs: np.ndarray  # [-] true cost of each player, shape (n,)
    residuals: tuple[float, ...]  # [m/s^2] per iteration
    cost_history: np.ndarray  # [-] shape (iterations, n)
    iterations: int
    qp_count: int  # QP solves in this call (exact interior answers and OSQP)
    status: str  # one of STATUSES
    solver: str  # "nash" or "stackelberg"
    wall_time: float = 0.0  # [s]
    leader: int | None = None  # Stackelberg: index of the leader
    message: str = ""

    @property
    def payoffs(self) -> np.ndarray:
        """[-] P_i = -cost_i (Eq. 12, terminal payoff taken as 0)."""
        return -self.costs

    @property
    def accelerations(self) -> np.ndarray:
        """[m/s^2] shape (n, N)."""
        return np.stack([p.accelerations for p in self.plans])

    @property
    def ok(self) -> bool:
        return self.status != "solver failure"


def speed_cap(player: Player, v_max_default: float) -> float:
    """[m/s] upper speed bound of the plan: v_max, or v0 if the player starts faster (feasible)."""
    v_max = player.v_max if player.v_max is not None else v_max_default
    return max(v_max, player.v0)


def keeps_speed_cap(plan: Plan, v_max_now: float, v_max_then: float) -> bool:
    """Whether a kept plan (shifted) stays within the speed cap a solve now would impose: v_max
    [m/s], or, for a plan that starts faster (a vehicle that came in above it, :func:`speed_cap`),
    its own start speed, as long as v_max is the one it was solved for (``v_max_then`` [m/s]).
    Without the second case every vehicle entering faster than its v_max is solved every step."""
    top = float(plan.speeds.max())  # [m/s]
    if top <= v_max_now + 1e-6:
        return True
    return v_max_now == v_max_then and top <= float(plan.speeds[0]) + 1e-6


def safe_plan(player: Player, settings: GameSettings) -> Plan:
    """Comfortable braking to a stop at ``settings.problem.comfort_brake``, respecting v >= 0.

    The fallback of every solver failure. Non-finite inputs are replaced (s0 -> 0 m, v0 -> 0 m/s)
    so the plan itself is always finite.
    """
    n, dt = settings.problem.steps, settings.problem.dt
    s0 = player.s0 if math.isfinite(player.s0) else 0.0
    v0 = player.v0 if math.isfinite(player.v0) else 0.0
    v0 = max(v0, 0.0)
    v = np.maximum(v0 - settings.problem.comfort_brake * dt * np.arange(n + 1), 0.0)
    a = np.diff(v) / dt
    return Plan.from_accelerations(s0, v0, a, dt)


def hold_plan(player: Player, settings: GameSettings) -> Plan:
    """Zero acceleration over the horizon (constant speed)."""
    return Plan.from_accelerations(player.s0, player.v0, np.zeros(settings.problem.steps), settings.problem.dt)


def project_accelerations(a, v0: float, v_cap: float, settings: GameSettings) -> np.ndarray:
    """[m/s^2] ``a`` made feasible: a_min <= a <= a_max and 0 <= v_k <= v_cap. Non-finite entries
    become 0. Vectorised: the speeds are clipped to [0, v_cap] and the accelerations recomputed
    from them (exact whenever those stay in the box); a forward pass (each a_k clipped given the
    speed the earlier steps reach) handles the rest."""
    a = np.array(a, dtype=float)
    if not np.isfinite(a).all():
        a[~np.isfinite(a)] = 0.0
    dt = settings.problem.dt
    np.maximum(a, settings.problem.a_min, out=a)
    np.minimum(a, settings.problem.a_max, out=a)
    v = v0 + dt * a.cumsum()
    if v.min() >= 0.0 and v.max() <= v_cap:
        return a
    v = np.clip(v, 0.0, max(v_cap, 0.0))
    a = np.diff(v, prepend=v0) / dt
    np.maximum(a, settings.problem.a_min, out=a)
    np.minimum(a, settings.problem.a_max, out=a)
    v = v0 + dt * a.cumsum()
    if v.min() >= -1e-12 and v.max() <= v_cap + 1e-12:
        return a
    vk = v0
    for k in range(len(a)):
        lo = max(settings.problem.a_min, -vk / dt)
        hi = min(settings.problem.a_max, (v_cap - vk) / dt)
        a[k] = min(max(a[k], lo), max(lo, hi))
        vk = max(vk + a[k] * dt, 0.0)
    return a


def shift_plan(plan: Plan) -> Plan:
    """The plan one step later: drop a_0, repeat the last acceleration at the end (warm start).

    Speeds and positions start from (s_1, v_1); the appended step is kept at v >= 0.
    """
    n = plan.steps
    if n == 0:
        return plan
    a, v, s = shifted_trajectory(np.asarray(plan.accelerations, dtype=float), plan.speeds[-1], plan.positions[1],
                                 plan.speeds[1], horizon_matrices(n, float(plan.dt)))
    duals = None
    if plan.duals is not None:
        y = plan.duals
        if y.shape == (2 * n,):
            duals = np.empty(2 * n)
            duals[:n - 1], duals[n - 1] = y[1:n], y[n - 1]
            duals[n:2 * n - 1], duals[2 * n - 1] = y[n + 1:], y[-1]
        else:
            duals = np.concatenate((y[1:n], y[n - 1:n], y[n + 1:], y[-1:]))
    return Plan(a, v, s, plan.dt, duals)


def shift_plans(plans: Sequence[Plan] | GameResult) -> tuple[Plan, ...]:
    """:func:`shift_plan` of every plan (accepts a :class:`GameResult`)."""
    if isinstance(plans, GameResult):
        plans = plans.plans
    return tuple(shift_plan(p) for p in plans)
