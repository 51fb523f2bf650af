"""Fixtures of the controller tests."""

import pytest

from intersection_cosim.network.movements import paper_movements
from intersection_cosim.control.base import ControlContext
from intersection_cosim.control.game.controller import GameController
from intersection_cosim.models.settings import ModelSettings


@pytest.fixture
def controller(paths, net_file):
    """A Nash game controller set up on the default net (ETM on, 0.1 s period)."""
    c = GameController("nash")
    c.setup(ControlContext(movements=paper_movements(net_file), model=ModelSettings(), control_period=0.1,
                           settings=None, etm=True))
    return c


def make_world(paths, t, vehicles, kappa=0.5):
    """A World of vehicles given as (id, path id, s [m], v [m/s]), all "ready", each with its
    path's exit lane as its only choice."""
    import numpy as np

    from intersection_cosim.control.base import World

    ids = [v[0] for v in vehicles]
    pids = [v[1] for v in vehicles]
    s = np.array([v[2] for v in vehicles], float)
    xy = np.array([paths[p].point_at(si) for p, si in zip(pids, s)])
    n = len(ids)
    return World(time=t, ids=ids, path_ids=pids, s=s, v=np.array([v[3] for v in vehicles], float),
                 a=np.zeros(n), x=xy[:, 0], y=xy[:, 1], heading=np.zeros(n), kappa=np.full(n, kappa),
                 role=["ready"] * n, lanes=[paths[p].lanes[0] for p in pids],
                 exit_choices={i: (paths[p].exit_lane,) for i, p in zip(ids, pids)})


def record_solves(c, entry) -> list:
    """Wrap controller ``c``'s equilibrium solver: after every solve ``entry(result)`` is appended
    to the returned list."""
    import dataclasses

    solves = []
    real = c.solver.equilibrium

    def recording(problem, *a, **k):
        result = real(problem, *a, **k)
        solves.append(entry(result))
        return result

    c.solver = dataclasses.replace(c.solver, equilibrium=recording)
    return solves
