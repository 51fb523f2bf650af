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


def test_network_scheduler_skips_a_junction_only_on_its_second_empty_step_in_a_row(movements):
    """An empty junction is called once (to release what it had), then skipped while it stays
    empty; a vehicle arriving calls it again. The merged Decisions are those of calling them all."""
    from intersection_cosim.sim.network_scheduler import NetworkScheduler

    class Releasing(_Recorder):
        """Releases the vehicles it commanded and no longer sees (the controllers' contract)."""

        def decide(self, world, deadline):
            self.seen.append(list(world.ids))
            gone, self.had = sorted(getattr(self, "had", set()) - set(world.ids)), set(world.ids)
            return Decisions(accel={vid: 1.0 for vid in world.ids}, release=gone, games=len(world.ids))

    def run(skip: bool):
        pj = PerJunction(Releasing)
        pj.setup(ControlContext(movements=movements, model=ModelSettings(), control_period=0.1, settings=None,
                                etm=True))
        sched = NetworkScheduler(pj, budget_ms=1e9)
        if not skip:
            sched._idle = type("Never", (set,), {"__contains__": lambda self, j: False})()
        out = []
        for t, vehicles in enumerate([[("W", "gneE18_0>gneE19_0", 50.0, 5.0)],
                                      [("W", "gneE18_0>gneE19_0", 55.0, 5.0)],
                                      [("N", "gneE21_0>gneE22_0", 60.0, 5.0)]]):
            step = sched.step(make_world(movements.paths, float(t), vehicles))
            out.append((step.decisions.accel, step.decisions.release, step.decisions.owner,
                        [(r.junction, r.skipped, r.games) for r in step.records]))
        return out, [len(p.seen) for p in pj.parts.values()]

    skipping, calls = run(skip=True)
    calling, all_calls = run(skip=False)
    assert all_calls == [3, 3, 3]
    assert calls == [3, 2, 1]  # gneJ10: W, W, empty; gneJ11: empty, skipped, N; gneJ12: empty, skipped, skipped
    assert [[(j, s) for j, s, _ in step[3]] for step in skipping] == [
        [("gneJ10", False), ("gneJ11", False), ("gneJ12", False)],
        [("gneJ10", False), ("gneJ11", True), ("gneJ12", True)],
        [("gneJ10", False), ("gneJ11", False), ("gneJ12", True)]]
    assert [step[:3] for step in skipping] == [step[:3] for step in calling]


def test_a_world_split_in_parts_keeps_each_vehicles_values_and_each_dicts_order(paths):
    """World.subsets: arrays and lists by index, a dict keyed by vehicle in its own order (not the
    order of the indices), a dict keyed by anything else (exit_free, by lane) whole."""
    import dataclasses

    pid = next(iter(paths))
    world = make_world(paths, 1.0, [(f"v{i}", pid, 10.0 + i, float(i)) for i in range(4)])
    world = dataclasses.replace(world, exit_choices={"v3": ("c",), "v0": ("a",), "v2": ("b",)},
                                exit_free={"lane_x": (5.0, 1.0)})
    first, second, none = world.subsets([[2, 0, 3], [1], []])
    assert first.ids == ["v2", "v0", "v3"] and list(first.v) == [2.0, 0.0, 3.0]
    assert list(first.exit_choices) == ["v3", "v0", "v2"]  # the dict's order, not the indices'
    assert second.ids == ["v1"] and second.exit_choices == {} and second.s.tolist() == [11.0]
    assert none.ids == [] and len(none.v) == 0 and none.exit_choices == {}
    assert first.exit_free == second.exit_free == {"lane_x": (5.0, 1.0)}
    assert world.subset([3, 1]).ids == ["v3", "v1"] and len(world.ids) == 4  # the whole World untouched
