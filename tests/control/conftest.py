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


class FilterUnderTest:
    """A SafetyFilter on the default net's movements, with the calls the unit tests make:
    :meth:`apply` writes the result's accelerations into a Decisions and returns the held vehicles;
    ``events`` and ``result`` are the last step's."""

    def __init__(self, settings, s_stop, period, s_wait=None, waits=None, gap_slack=0.0, problem=None, model=None,
                 rules=None):
        import math

        import numpy as np

        from intersection_cosim.control.safety.context import GuardedJunction
        from intersection_cosim.control.safety.filter import SafetyFilter
        from intersection_cosim.control.safety.rules import RULES
        from intersection_cosim.games.settings import ProblemSettings
        from intersection_cosim.network.cache import cached_net
        from intersection_cosim.network.spec import IntersectionSpec

        movements = paper_movements(cached_net(IntersectionSpec()))
        s_wait = np.full(len(s_stop), math.inf) if s_wait is None else s_wait
        self.filter = SafetyFilter(GuardedJunction(settings, problem or ProblemSettings(), model or ModelSettings(),
                                                   movements, s_stop, s_wait, dict(waits or {}), period, gap_slack),
                                   RULES if rules is None else rules)
        self.events, self.result = set(), None

    def apply(self, world, relations, plans, options, decisions, games=frozenset(), floors=None):
        """``floors`` [m/s^2]: per vehicle, braking harder than its own that it makes this step (as
        the pedestrians rule's emergency stops), which the other rules count on."""
        if floors:
            from intersection_cosim.control.safety.rules.base import SAFETY, Rule

            def emergency(ctx, step):
                for vid, floor in floors.items():
                    step.brakes[vid] = min(floor, step.brakes.get(vid, ctx.junction.problem.a_min))

            rules = self.filter.rules
            self.filter.rules = (Rule("emergency_stops", SAFETY, emergency), *rules)
            try:
                return self.apply(world, relations, plans, options, decisions, games)
            finally:
                self.filter.rules = rules
        self.result = self.filter.apply(world, relations, plans, options, decisions.accel, games)
        decisions.accel.update(self.result.accel)
        self.events = set(self.result.events)
        return self.result.held

    def human_committed(self, world, k, enter):
        """The context's prediction for human k at a zone starting at ``enter`` [m]."""
        from intersection_cosim.control.safety.context import StepContext

        ctx = StepContext(self.filter.junction, world, None, {}, {}, {}, None, None, frozenset(), {})
        return ctx.human_committed(k, enter)

    def __getattr__(self, name):  # entered, filtered, cleared, record_entries, release
        return getattr(self.filter, name)
