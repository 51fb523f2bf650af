"""A controlled vehicle as a player of a game or a solo problem: its state, kappa, desired speed,
its body length and the predicted trajectory and body length of its leader (J_log, paper Eqs.
15-18: the gap is to the leader's rear, so a bus ahead is 12 m long, not the model's 4.5 m), its
vType's accel and decel, which narrow the accelerations it may plan (games/objective.py), and the
forecasts of the human drivers it crosses in a triggered pair (J_lat, Eqs. 19-22: non-players,
their forecasts fixed).

The leader's trajectory is its previous plan shifted by one period when it is controlled,
constant speed otherwise. The leader does not care about its follower (its cost has no term for
it), so following is no game. On two paths that part (same approach lane, different exits) the
leader counts only until its rear has left the shared stretch (:attr:`Leader.until`).
"""

from __future__ import annotations

import math

import numpy as np

from intersection_cosim.control.base import World
from intersection_cosim.control.game.plan_memory import PlanMemory
from intersection_cosim.control.game.relations import Leader, Relations
from intersection_cosim.games.problem import Player

FAR = 1.0e4  # [m] added to a leader's predicted position where it no longer constrains its follower


def leader_trajectory(world: World, leader: Leader, memory: PlanMemory) -> tuple[np.ndarray, np.ndarray]:
    """[m], [m/s] the leader's predicted positions (in its own path) and speeds s_1..s_N, v_1..v_N."""
    k = leader.vehicle
    plan = memory.anchored(world, k)
    if plan is None:
        plan = memory.coasting_plan(world, k)
    s, v = plan.positions[1:], plan.speeds[1:]
    if leader.until < math.inf:  # (no leader's s is past an infinite end)
        parted = s > leader.until
        if parted.any():  # past the end of the shared stretch the leader is out of the way
            s = np.where(parted, s + FAR, s)
    return s, v


def prediction_moved(then: tuple, now: tuple, lag: int, tol: float) -> bool:
    """Whether a leader's prediction ``now`` (s [m], v [m/s] over the horizon) moved by more
    than ``tol`` [m] or [m/s] from ``then``, made ``lag`` plan steps earlier, where they overlap
    (all of it when they do not)."""
    s_then, v_then = then
    s_now, v_now = now
    m = len(s_now) - lag
    if m <= 0:
        return True
    return bool(np.abs(s_now[:m] - s_then[lag:]).max() > tol or np.abs(v_now[:m] - v_then[lag:]).max() > tol)


def player(world: World, k: int, option: str, relations: Relations, memory: PlanMemory,
           partner: int | None = None) -> Player:
    """Vehicle k taking exit lane ``option``; its leader enters as a fixed trajectory unless the
    leader is ``partner``, the other player of the same game (then it is an interaction)."""
    leader = relations.leader_of(k, option)
    exo, exo_length = None, None
    if leader is not None and leader.vehicle != partner:
        s_l, v_l = leader_trajectory(world, leader, memory)
        exo = (s_l + leader.offset, v_l)
        exo_length = None if world.length is None else float(world.length[leader.vehicle])
    v_max = world.desired_speed_of(k)  # [m/s]
    caps = relations.rows.speed_cap
    if caps is not None and math.isfinite(cap := float(caps[relations.row_of[(k, option)]])):
        v_max = cap  # a lane limit below the desired speed (relations.lane_speed_caps)
    return Player(s0=float(world.s[k]), v0=float(world.v[k]), kappa=float(world.kappa[k]),
                  v_max=v_max, name=world.ids[k], leader=exo,
                  length=None if world.length is None else float(world.length[k]), leader_length=exo_length,
                  a_max=None if world.accel is None else float(world.accel[k]),
                  a_min=None if world.decel is None else -float(world.decel[k]),
                  crossers=human_crossers(world, k, option, relations, memory))


def human_crossers(world: World, k: int, option: str, relations: Relations, memory: PlanMemory) -> tuple:
    """Player.crossers of vehicle k taking exit lane ``option``: the human drivers it crosses or
    merges with in a triggered pair, each by its forecast (PlanMemory.human_plan)."""
    out = []
    for h, s_own, s_h in relations.human_crossings.get(relations.row_of[(k, option)], ()):
        plan = memory.human_plan(world, h)
        out.append((s_own, s_h, plan.positions[1:], plan.speeds[1:]))
    return tuple(out)
