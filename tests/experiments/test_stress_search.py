"""The stress search: generations, the cross-entropy fit to the elite and seeded proposals."""

from __future__ import annotations

import numpy as np
import pytest

from intersection_cosim.experiments.stress.draws import Param
from intersection_cosim.experiments.stress.search import cem_fit, from_unit, generations, propose, to_unit

PARAMS = (Param("a", 0.0, 10.0), Param("b", -1.0, 1.0))


def test_generations_split_the_runs_evenly_and_cover_each_once():
    gens = generations(10, 4)
    assert [len(g) for g in gens] == [2, 3, 3, 2]
    assert [i for g in gens for i in g] == list(range(10))
    assert generations(2, 4) == [range(0, 1), range(1, 2)]


def test_cem_fit_takes_the_runs_with_the_smallest_margins():
    unit = np.array([[0.0, 0.0], [1.0, 1.0], [0.2, 0.4], [0.9, 0.9]])
    margins = np.array([5.0, -1.0, 0.5, 3.0])
    mean, std = cem_fit(unit, margins, elite=0.5, min_std=0.01)
    assert mean == pytest.approx([0.6, 0.7])  # rows 1 and 2
    assert std == pytest.approx([0.4, 0.3])
    _mean, std = cem_fit(unit, margins, elite=0.25, min_std=0.05)
    assert std == pytest.approx([0.05, 0.05])  # one elite run: the floor


def test_unit_coordinates_round_trip_and_clip():
    draw = {"a": 2.5, "b": 0.5}
    assert to_unit(PARAMS, draw) == pytest.approx([0.25, 0.75])
    assert from_unit(PARAMS, np.array([0.25, 0.75])) == draw
    assert from_unit(PARAMS, np.array([-1.0, 2.0])) == {"a": 0.0, "b": 1.0}


def test_a_proposal_depends_only_on_seed_index_and_fit():
    assert propose(PARAMS, 3, 5) == propose(PARAMS, 3, 5)
    assert propose(PARAMS, 3, 5) != propose(PARAMS, 3, 6)
    fit = (np.array([0.9, 0.1]), np.array([0.01, 0.01]))
    seeds, draws = zip(*(propose(PARAMS, 3, i, fit) for i in range(20)))
    assert all(8.5 < d["a"] < 9.5 and -0.9 < d["b"] < -0.7 for d in draws)
    assert propose(PARAMS, 3, 5, fit)[0] == propose(PARAMS, 3, 5)[0]  # the run's scenario seed is the same
