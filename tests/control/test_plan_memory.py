"""PlanMemory as a unit: applied plans, shifting, warm starts with typed keys."""

import numpy as np

from intersection_cosim.control.game.plan_memory import GameKey, PlanMemory, SoloKey
from intersection_cosim.games.problem import Plan

DT = 0.1  # [s]
STEPS = 30


def _plan(a0=0.0):
    a = np.linspace(a0, a0 + 2.9, STEPS)  # [m/s^2] distinct per step, to see shifts
    return Plan.from_accelerations(10.0, 5.0, a, DT)


def test_a_warm_start_is_shifted_by_the_periods_since_its_solve_and_expires_past_half_the_horizon():
    memory = PlanMemory(shift=1, period=0.1, steps=STEPS, dt=DT, a_max=2.5, v_max=13.89)
    key = GameKey("A", "B", "inner", "middle")
    stored = (_plan(0.0), _plan(-1.0))
    memory.store(key, 1.0, stored)
    moved = memory.warm_start(key, 1.3)
    for old, new in zip(stored, moved):  # 3 periods of 0.1 s = 3 plan steps
        assert np.allclose(new.accelerations[:STEPS - 3], old.accelerations[3:])
        assert np.allclose(new.accelerations[STEPS - 3:], old.accelerations[-1])  # the last one repeated
    assert memory.warm_start(key, 1.0) is not None  # solved this step: at least one period on
    assert np.allclose(memory.warm_start(key, 1.0)[0].accelerations[:-1], stored[0].accelerations[1:])
    assert memory.warm_start(key, 2.5) is not None  # 15 periods: exactly half of 30 steps
    assert memory.warm_start(key, 2.6) is None  # 16 periods
    assert memory.warm_start(GameKey("A", "B", "inner", "inner"), 1.1) is None


def test_a_control_period_of_several_solver_steps_shifts_by_all_of_them():
    memory = PlanMemory(shift=2, period=0.2, steps=STEPS, dt=DT, a_max=2.5, v_max=13.89)
    plan = _plan()
    assert np.allclose(memory.shifted(plan).accelerations[:-2], plan.accelerations[2:])
    assert np.allclose(memory.shifted(plan, 3).accelerations[:-6], plan.accelerations[6:])


def test_warm_starts_of_departed_vehicles_are_pruned_and_keys_are_typed():
    memory = PlanMemory(shift=1, period=0.1, steps=STEPS, dt=DT, a_max=2.5, v_max=13.89)
    memory.store(SoloKey("A", "inner"), 0.0, (_plan(),))
    memory.store(GameKey("A", "B", "inner", "inner"), 0.0, (_plan(), _plan()))
    memory.store(GameKey("C", "D", "inner", "inner"), 0.0, (_plan(), _plan()))
    assert memory.warm_start(GameKey("A", "B", "inner", "inner"), 0.1) is not None
    assert memory.warm_start(GameKey("B", "A", "inner", "inner"), 0.1) is None  # keys are ordered
    memory.prune_warm({"A", "C", "D"})
    assert set(memory.keys()) == {SoloKey("A", "inner"), GameKey("C", "D", "inner", "inner")}


def test_driven_and_kept_plans():
    memory = PlanMemory(shift=1, period=0.1, steps=STEPS, dt=DT, a_max=2.5, v_max=13.89)
    plan = _plan()
    memory.apply("A", plan, "middle")
    assert memory.driven_plan("A", "inner") is None  # driving another exit lane
    assert np.allclose(memory.driven_plan("A", "middle").accelerations[:-1], plan.accelerations[1:])
    assert memory.held_option("A", "inner") == "middle" and memory.held_option("B", "inner") == "inner"

    class _World:  # the two arrays PlanMemory reads
        s = np.array([12.0, 30.0])  # [m]
        v = np.array([6.0, 4.0])  # [m/s]
        ids = ["A", "B"]

    kept = memory.kept_plan(_World, 0, comfort_brake=2.0)
    assert kept.positions[0] == 12.0 and kept.speeds[0] == 6.0  # re-anchored at the measured state
    assert np.allclose(kept.accelerations[:-1], plan.accelerations[1:])
    braking = memory.kept_plan(_World, 1, comfort_brake=2.0)  # no plan: comfortable braking
    assert np.allclose(braking.accelerations, -2.0) and braking.speeds[0] == 4.0
    memory.forget("A")
    assert memory.driven_plan("A", "middle") is None


def test_the_kept_plan_is_built_once_per_applied_plan_and_measured_state():
    """anchored: the applied plan shifted and started from the measured state, the same object
    while plan and state stay (the step asks for it three times), a new one when either moves;
    None without a plan, and none once the vehicle is forgotten."""
    memory = PlanMemory(shift=1, period=0.1, steps=STEPS, dt=DT, a_max=2.5, v_max=13.89)

    class _World:
        s = np.array([12.0])  # [m]
        v = np.array([6.0])  # [m/s]
        ids = ["A"]

    assert memory.anchored(_World, 0) is None
    plan = _plan()
    memory.apply("A", plan, "inner")
    first = memory.anchored(_World, 0)
    assert first is memory.anchored(_World, 0) and first is memory.kept_plan(_World, 0, comfort_brake=2.0)
    assert first.positions[0] == 12.0 and first.speeds[0] == 6.0
    assert np.array_equal(first.accelerations, memory.shifted(plan).accelerations)
    _World.v = np.array([6.5])
    moved = memory.anchored(_World, 0)
    assert moved is not first and moved.speeds[0] == 6.5
    assert moved.positions[5] > first.positions[5]  # 0.5 m/s faster: 0.25 m further after 0.5 s
    memory.apply("A", _plan(1.0), "inner")
    assert memory.anchored(_World, 0).accelerations[0] == memory.shifted(memory.plans["A"]).accelerations[0]
    memory.forget("A")
    assert memory.anchored(_World, 0) is None


def test_a_shifted_plan_is_kept_while_steps_use_it_and_dropped_after_a_step_without_use():
    memory = PlanMemory(shift=1, period=0.1, steps=STEPS, dt=DT, a_max=2.5, v_max=13.89)
    used, unused = _plan(0.0), _plan(-1.0)
    first, other = memory.shifted(used), memory.shifted(unused)
    assert memory.shifted(used) is first  # the same step: computed once
    memory.new_step()
    assert memory.shifted(used) is first  # used in the last step: kept
    memory.new_step()
    assert memory.shifted(used) is first  # and in this one
    again = memory.shifted(unused)  # two steps without use: computed anew, the same values
    assert again is not other and np.array_equal(again.accelerations, other.accelerations)
    assert np.array_equal(again.positions, other.positions)
