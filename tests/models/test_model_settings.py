"""ModelSettings from a scenario's [model] table."""

from __future__ import annotations

import pytest

from intersection_cosim.errors import InputError
from intersection_cosim.models.settings import ModelSettings
from intersection_cosim.settings import from_table


def test_defaults_are_valid():
    s = ModelSettings()
    assert s.check() == []
    assert s.wheelbase == pytest.approx(2.7)
    assert (s.gamma_sf, s.straight_steer, s.prediction_dt, s.prediction_degree) == (40.0, 1e-6, 0.1, 3)


def test_every_field_settable_from_the_model_table():
    s = from_table(ModelSettings, {"gamma_sf": 25, "t_p": 4.0, "prediction_dt": 0.05,
                                   "prediction_degree": 4, "straight_steer": 1e-7}, "case.toml", "model")
    assert (s.gamma_sf, s.t_p, s.prediction_dt, s.prediction_degree, s.straight_steer) == (
        25.0, 4.0, 0.05, 4, 1e-7)


@pytest.mark.parametrize("table, field", [
    ({"gama_sf": 1.0}, "model.gama_sf"),
    ({"prediction_degree": 0}, "model.prediction_degree"),
    ({"prediction_degree": 2.5}, "model.prediction_degree"),
    ({"prediction_dt": 0.0}, "model.prediction_dt"),
    ({"gamma_sf": -1.0}, "model.gamma_sf"),
    ({"straight_steer": 0.0}, "model.straight_steer"),
])
def test_bad_values_are_input_errors(table, field):
    with pytest.raises(InputError) as err:
        from_table(ModelSettings, table, "case.toml", "model")
    assert err.value.field == field
