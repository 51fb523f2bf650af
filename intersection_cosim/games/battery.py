"""Seeded random two-player problems for tests and benchmarks (not used by the controller).

A crossing pair approaches one conflict point from two paths; a merging pair reaches the point
where its two paths become one lane (a confluence conflict). Ranges are those of the paper's
cases: start speeds 3-8 m/s, conflict points 8-40 m ahead, kappa 0.2-0.9.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from intersection_cosim.games.problem import Interaction, Player, Problem


def random_pair(rng: np.random.Generator, kind: str = "cross") -> Problem:
    """One random crossing ("cross") or merging ("confluence") pair."""
    players = tuple(Player(s0=float(rng.uniform(0.0, 5.0)), v0=float(rng.uniform(3.0, 8.0)),
                           kappa=float(rng.uniform(0.2, 0.9)), name=f"V{k + 1}") for k in range(2))
    lo, hi = (8.0, 35.0) if kind == "cross" else (12.0, 40.0)
    s_cp = [float(p.s0 + rng.uniform(lo, hi)) for p in players]
    make = Interaction.cross if kind == "cross" else Interaction.confluence
    return Problem(players, (make(0, 1, s_cp[0], s_cp[1]),))


def battery(count: int, seed: int = 0) -> list[Problem]:
    """``count`` problems, alternating crossing and merging pairs, from ``seed``."""
    rng = np.random.default_rng(seed)
    return [random_pair(rng, "cross" if k % 2 == 0 else "confluence") for k in range(count)]


def advance(problem: Problem, plans, steps: int = 1) -> Problem:
    """The problem ``steps`` control steps later if every player followed its plan."""
    players = tuple(replace(p, s0=float(plan.positions[steps]), v0=float(plan.speeds[steps]))
                    for p, plan in zip(problem.players, plans))
    return Problem(players, problem.interactions)
