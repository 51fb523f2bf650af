"""Where the runs of a stress search go in parameter space: seeded uniform draws (``random``) or a
cross-entropy search (``cem``) towards the smallest margin.

Run ``i`` of a search with seed ``S`` draws from its own generator ``default_rng((S, i))``: its
scenario seed, then its parameters. ``random`` draws every parameter uniformly in its range.
``cem`` splits the runs into generations; the first draws uniformly, each later one draws every
parameter (scaled to [0, 1] over its range) from a normal distribution fitted to the elite of the
generation before (the share ``elite`` of its runs with the smallest margins), its std kept at
least ``min_std``, clipped to the range. A run's draw depends only on (S, i) and the finished runs
of the generations before, so a rerun draws the same runs again.
"""

from __future__ import annotations

import math

import numpy as np

from intersection_cosim.experiments.stress.draws import DECIMALS, Param, run_seed

SEARCHES = ("random", "cem")


def generations(runs: int, count: int) -> list[range]:
    """The run indices of each generation: ``runs`` split into ``count`` (at most ``runs``) near-equal parts."""
    count = max(1, min(count, runs))
    bounds = [round(k * runs / count) for k in range(count + 1)]
    return [range(a, b) for a, b in zip(bounds[:-1], bounds[1:])]


def to_unit(params: tuple[Param, ...], draw: dict[str, float]) -> np.ndarray:
    """A draw as a vector in [0, 1]^d (a parameter of zero width maps to 0.5)."""
    return np.array([0.5 if p.high <= p.low else (draw[p.name] - p.low) / (p.high - p.low) for p in params])


def from_unit(params: tuple[Param, ...], u: np.ndarray) -> dict[str, float]:
    """A vector in [0, 1]^d (clipped) as a draw, rounded to DECIMALS."""
    u = np.clip(u, 0.0, 1.0)
    return {p.name: round(float(p.low + x * (p.high - p.low)), DECIMALS) for p, x in zip(params, u)}


def cem_fit(unit: np.ndarray, margins: np.ndarray, elite: float, min_std: float) -> tuple[np.ndarray, np.ndarray]:
    """(mean, std) per parameter of the elite runs: the ceil(``elite`` * n) rows of ``unit`` (n, d)
    with the smallest ``margins`` (n,) (ties kept in run order); std at least ``min_std``."""
    n = len(margins)
    if n == 0:
        raise ValueError("cem_fit needs at least one run")
    k = max(1, math.ceil(elite * n))
    best = np.argsort(np.asarray(margins, float), kind="stable")[:k]
    chosen = np.asarray(unit, float)[best]
    return chosen.mean(axis=0), np.maximum(chosen.std(axis=0), min_std)


def propose(params: tuple[Param, ...], seed: int, index: int,
            fit: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[int, dict[str, float]]:
    """Run ``index``'s (scenario seed, draw): uniform without ``fit``, else from the normal ``fit``
    = (mean, std) in unit coordinates."""
    rng = np.random.default_rng((seed, index))
    scenario_seed = run_seed(rng)
    if fit is None:
        return scenario_seed, from_unit(params, rng.random(len(params)))
    mean, std = fit
    return scenario_seed, from_unit(params, mean + std * rng.standard_normal(len(params)))
