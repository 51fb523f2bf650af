"""control/per_junction.py: one controller per junction, the World split by the vehicles' paths."""

import os

import pytest

from intersection_cosim.control.base import ControlContext, Decisions, Diagnostics
from intersection_cosim.control.per_junction import PerJunction, merge_decisions
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.network.junction_net import load_movements

from tests.control.conftest import make_world

CORRIDOR = os.path.join(os.path.dirname(__import__("sumo").__file__), "tools", "game", "corridor", "corridor.net.xml")


class _Recorder:
    """A controller that records what it was set up with and shown."""

    junction_type = "priority"
    controls_vehicles = True
    yields_to_pedestrians = True

    def setup(self, context):
        self.junctions = context.movements.junctions
        self.paths = set(context.paths)
        self.seen = []

    def decide(self, world, deadline):
        self.seen.append(list(world.ids))
        # what it last commanded and no longer sees: as if "E" and "gone" had been its vehicles
        gone = [vid for vid in ("E", "gone") if vid not in world.ids]
        return Decisions(accel={vid: 1.0 for vid in world.ids}, release=gone, games=len(world.ids))

    def fallback(self, world):
        return Decisions(fallback=True)

    def diagnostics(self):
        return Diagnostics(safety_interventions=len(self.seen))


@pytest.fixture(scope="module")
def movements():
    return load_movements(CORRIDOR, ("gneJ10", "gneJ11", "gneJ12"), 80.0)


def test_each_junction_gets_its_own_movements_and_the_vehicles_on_its_paths(movements):
    pj = PerJunction(_Recorder)
    pj.setup(ControlContext(movements=movements, model=ModelSettings(), control_period=0.1, settings=None, etm=True))
    assert list(pj.parts) == ["gneJ10", "gneJ11", "gneJ12"]
    assert [p.junctions for p in pj.parts.values()] == [("gneJ10",), ("gneJ11",), ("gneJ12",)]
    assert all(movements.paths[pid].junction == j for j, p in pj.parts.items() for pid in p.paths)
    assert sum(len(p.paths) for p in pj.parts.values()) == len(movements.paths)
    world = make_world(movements.paths, 1.0, [("E", "gneE10_0>gneE11_0", 100.0, 5.0),
                                              ("W", "gneE18_0>gneE19_0", 50.0, 5.0),
                                              ("N", "gneE21_0>gneE22_0", 60.0, 5.0)])
    decisions = pj.decide(world, deadline=1e12)
    assert [p.seen for p in pj.parts.values()] == [[["W"]], [["E", "N"]], [[]]]
    assert decisions.accel == {"E": 1.0, "W": 1.0, "N": 1.0} and decisions.games == 3
    # "E" is gneJ11's: the release of gneJ10 and gneJ12 is dropped, "gone" (in no sub-World) stays
    assert decisions.release == ["gone", "gone", "gone"]
    assert pj.diagnostics().safety_interventions == 3


def test_one_junction_s_decisions_pass_unchanged():
    d = Decisions(accel={"a": 1.0}, release=["b"])
    assert merge_decisions({"C": d}, {}) is d


def test_each_junction_sees_its_own_vehicles_human_flags(movements):
    """World.human is per vehicle: split with the vehicles, not handed whole to every junction."""
    import dataclasses

    import numpy as np

    class HumanRecorder(_Recorder):
        def decide(self, world, deadline):
            self.seen.append([(vid, world.is_human(k)) for k, vid in enumerate(world.ids)])
            return Decisions()

    pj = PerJunction(HumanRecorder)
    pj.setup(ControlContext(movements=movements, model=ModelSettings(), control_period=0.1, settings=None, etm=True))
    world = make_world(movements.paths, 1.0, [("E", "gneE10_0>gneE11_0", 100.0, 5.0),
                                              ("W", "gneE18_0>gneE19_0", 50.0, 5.0),
                                              ("N", "gneE21_0>gneE22_0", 60.0, 5.0)])
    pj.decide(dataclasses.replace(world, human=np.array([False, True, True])), deadline=1e12)
    assert [p.seen for p in pj.parts.values()] == [[[("W", True)]], [[("E", False), ("N", True)]], [[]]]
