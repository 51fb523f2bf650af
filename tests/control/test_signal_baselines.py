"""The signal baselines: SUMO's actuated programme built from the net's own phases, and
max-pressure's phase choice with minimum green and yellow."""

from collections import Counter

import pytest

from intersection_cosim.control.baselines.max_pressure import MaxPressureController, _Light, pressure, yellow_between
from intersection_cosim.control.baselines.signal_settings import SignalSettings
from intersection_cosim.network.cache import cached_net
from intersection_cosim.network.signal_programmes import SignalPlan, actuated_programmes, junction_signals
from intersection_cosim.network.spec import IntersectionSpec

PLAN = SignalPlan("T", (("n", "s_out"), ("n", "e_out"), ("e", "w_out"), ("e", "n_out")), ("GGrr", "rrGG"))


def test_pressure_counts_incoming_minus_outgoing_of_green_links():
    counts = Counter({"n": 3, "e": 5, "w_out": 2, "s_out": 1})
    assert pressure(PLAN, "GGrr", counts) == (3 - 1) + (3 - 0)
    assert pressure(PLAN, "rrGG", counts) == (5 - 2) + (5 - 0)


def test_yellow_only_on_links_that_lose_their_green():
    assert yellow_between("GGgr", "rGrG") == "yGyr"


def _controller() -> MaxPressureController:
    mp = MaxPressureController(SignalSettings(min_green=5.0, decision_interval=5.0, yellow=3.0))
    mp.plans, mp.lights = (PLAN,), {"T": _Light()}
    return mp


def test_max_pressure_switches_through_yellow_after_min_green():
    mp = _controller()
    heavy_north, heavy_east = Counter({"n": 4}), Counter({"e": 6})
    light = mp.lights["T"]
    assert mp._step(PLAN, light, 0.0, heavy_north) == "GGrr"  # the first choice, at once
    assert mp._step(PLAN, light, 2.0, heavy_east) is None  # before min green and the next choice
    assert mp._step(PLAN, light, 5.0, heavy_east) == "yyrr"  # east wins: yellow first
    assert mp._step(PLAN, light, 7.9, heavy_east) is None  # yellow lasts 3 s
    assert mp._step(PLAN, light, 8.0, heavy_east) == "rrGG"
    assert (light.current, light.since) == (1, 8.0)
    assert mp._step(PLAN, light, 10.0, heavy_north) is None  # green for 2 s only: held
    assert mp._step(PLAN, light, 13.0, Counter()) is None  # a tie keeps the green


def test_the_generated_signal_net_has_two_green_phases():
    net = str(cached_net(IntersectionSpec(junction_type="traffic_light")))
    (plan,) = junction_signals(net, "C")
    assert len(plan.greens) == 2 and len(plan.links) == len(plan.greens[0])
    assert all(a != b for a, b in zip(*plan.greens) if "r" in (a, b))  # each link is green in one phase


def test_actuated_programme_keeps_the_nets_phases_and_extends_greens():
    net = str(cached_net(IntersectionSpec(junction_type="traffic_light")))
    root = actuated_programmes(net, ("C",), 5.0, 50.0, 3.0, 2.0)
    (logic,) = root.findall("tlLogic")
    assert (logic.get("type"), logic.get("programID")) == ("actuated", "actuated")
    params = {p.get("key"): p.get("value") for p in logic.findall("param")}
    assert params == {"max-gap": "3", "detector-gap": "2"}
    phases = logic.findall("phase")
    greens = [p for p in phases if "y" not in p.get("state")]
    assert greens and all(float(p.get("minDur")) <= float(p.get("duration")) <= float(p.get("maxDur"))
                          for p in greens)
    assert all(p.get("minDur") is None for p in phases if "y" in p.get("state"))


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["sumo-actuated", "max-pressure"])
def test_signal_baselines_run_the_paper_net(tmp_path, kind):
    """A short run of the generated signalized net: every vehicle arrives; the actuated run loads its
    programme file; max-pressure shows its own states (SUMO runs them as the 'online' programme)."""
    import dataclasses
    from pathlib import Path

    from intersection_cosim.experiments.run import run_scenario
    from intersection_cosim.scenario import load_scenario, with_overrides

    scn = with_overrides(load_scenario(Path(__file__).resolve().parents[2] / "scenarios" / "demand_balanced_low.toml"),
                         controller=kind)
    scn = dataclasses.replace(scn, scenario=dataclasses.replace(scn.scenario, duration=60.0, drain=120.0, ssm=False))
    summary = run_scenario(scn, tmp_path / "run")
    c = summary["counts"]
    assert c["vehicles"] > 5 and c["arrived"] == c["vehicles"] and c["not_inserted"] == 0
    assert summary["engineer"]["los_table"] == "HCM signalized"
    assert (tmp_path / "run" / "signals.add.xml").is_file() == (kind == "sumo-actuated")
