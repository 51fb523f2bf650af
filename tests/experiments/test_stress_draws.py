"""The draws of a stress search: the parameter space, uniform draws, the variant scenario they
write (every drawn value written out, still a valid scenario) and its TOML text."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from intersection_cosim.errors import InputError
from intersection_cosim.experiments.stress.draws import base_data, space, uniform_draw, variant
from intersection_cosim.experiments.stress.toml_text import dumps
from intersection_cosim.scenario import load_scenario, scenario_from_dict
from intersection_cosim.scenario.stress_settings import StressSettings, stress_settings

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
BALANCED = SCENARIOS / "demand_balanced_medium.toml"


def _base(path: Path = BALANCED):
    data = tomllib.loads(path.read_text())
    scn = load_scenario(path)
    return base_data(data, scn, path), scn


def test_space_has_one_flow_scale_per_flow_and_no_vtype_axis_without_vtypes():
    base, scn = _base()
    names = [p.name for p in space(scn, StressSettings())]
    assert sum(n.startswith("flow_scale.") for n in names) == len(scn.flows) == 12
    assert not any(n.startswith("vtype") for n in names)
    assert "demand_scale" in names and "latency" in names


def test_an_axis_set_to_false_is_not_drawn_and_a_range_is_checked():
    _base_data, scn = _base()
    settings = stress_settings("s.toml", {"latency": False, "loss": [0.1, 0.2]})
    names = [p.name for p in space(scn, settings)]
    assert "latency" not in names
    assert settings.axis("loss") == (0.1, 0.2)
    with pytest.raises(InputError, match="low 0.3 is above high 0.2"):
        stress_settings("s.toml", {"loss": [0.3, 0.2]})
    with pytest.raises(InputError, match="unknown key"):
        stress_settings("s.toml", {"lossy": [0.1, 0.2]})
    with pytest.raises(InputError, match=r"must lie in \[0, 1\]"):
        stress_settings("s.toml", {"av_share": [0.5, 1.5]})


def test_uniform_draws_lie_in_their_ranges_and_repeat_for_a_seed():
    _base_data, scn = _base()
    params = space(scn, StressSettings())
    a = uniform_draw(params, np.random.default_rng(7))
    b = uniform_draw(params, np.random.default_rng(7))
    assert a == b
    assert all(p.low <= a[p.name] <= p.high for p in params)


def test_the_variant_writes_every_drawn_value_and_is_a_valid_scenario():
    base, scn = _base()
    settings = StressSettings()
    draw = {"demand_scale": 2.0, f"flow_scale.{scn.flows[0].id}": 0.5, "burst_scale": 1.0, "burst_start": 0.5,
            "burst_length": 10.0, "av_share": 0.75, "kappa_center": 0.3, "kappa_spread": 0.2,
            "insertion_speed": 8.0, "latency": 0.1}
    data = variant(base, scn, draw, seed=123, duration=100.0, settings=settings)
    flows = data["flow"]
    assert flows[0]["rate"] == pytest.approx(base["flow"][0]["rate"] * 2.0 * 0.5)
    assert flows[1]["rate"] == pytest.approx(base["flow"][1]["rate"] * 2.0)
    bursts = [f for f in flows if f["id"].endswith("_burst")]
    assert len(bursts) == 12 and (bursts[0]["begin"], bursts[0]["end"]) == (50.0, 60.0)
    assert bursts[0]["rate"] == pytest.approx(flows[0]["rate"])
    assert flows[0]["kappa"] == {"dist": "uniform", "low": 0.2, "high": 0.4}
    assert data["scenario"]["seed"] == 123 and data["scenario"]["duration"] == 100.0
    assert data["controller"]["work_clock_ms"] == settings.work_clock_ms
    assert data["v2x"]["latency"] == 0.1
    again = scenario_from_dict(tomllib.loads(dumps(data, "a header")), "variant.toml")
    assert again.scenario.seed == 123 and len(again.flows) == 24 and again.v2x.latency == 0.1
    assert [f.id for f in again.flows[:12]] == [f.id for f in scn.flows]


def test_relative_net_paths_become_absolute_so_a_variant_runs_from_any_folder(tmp_path):
    base, _scn = _base(SCENARIOS / "tjunction_high.toml")
    assert Path(base["network"]["file"]).is_absolute()
    scenario_from_dict(tomllib.loads(dumps(base)), str(tmp_path / "elsewhere.toml"))


def test_toml_text_round_trips_tables_arrays_of_tables_and_inline_tables():
    data = {"a": {"x": 1, "y": [1.5, 2.0], "s": 'q"uote', "b": True, "sub": {"k": "v"}},
            "flow": [{"id": "f", "kappa": {"dist": "fixed", "value": 0.5}}, {"id": "g"}],
            "v2x": {"latency": 0.0, "attack": [{"vehicle": "f.0"}]}}
    assert tomllib.loads(dumps(data, "line one\nline two")) == data
