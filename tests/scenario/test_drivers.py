"""Drivers of flow vehicles: av_share, seeded, independent of the arrivals."""

import dataclasses

import numpy as np
import pytest

from intersection_cosim.scenario.draws import draw_drivers, generate_flow_vehicles
from intersection_cosim.scenario.load import load_scenario

SCENARIO = "scenarios/demand_balanced_medium.toml"


def _with_share(scn, share, seed):
    return dataclasses.replace(scn, flows=tuple(dataclasses.replace(f, av_share=share) for f in scn.flows),
                               scenario=dataclasses.replace(scn.scenario, seed=seed))


def _drivers(scn):
    fv = draw_drivers(scn, generate_flow_vehicles(scn, np.random.default_rng(scn.scenario.seed)))
    return fv, np.array([v["driver"] == "av" for v in fv])


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_half_the_vehicles_are_avs_at_av_share_one_half(seed):
    scn = _with_share(load_scenario(SCENARIO), 0.5, seed)
    fv, av = _drivers(scn)
    assert len(fv) > 150
    # binomial(n, 0.5): within 3 standard deviations of n / 2
    assert abs(av.sum() - len(fv) / 2) < 3 * np.sqrt(len(fv) / 4)
    assert 0 < av.sum() < len(fv)


def test_the_shares_change_only_the_drivers_and_the_humans_are_nested():
    base = load_scenario(SCENARIO)
    runs = {share: _drivers(_with_share(base, share, 3)) for share in (0.0, 0.5, 0.9, 1.0)}
    keys = ("id", "depart", "lane", "kappa")
    arrivals = {share: [tuple(v[k] for k in keys) for v in fv] for share, (fv, _) in runs.items()}
    assert arrivals[0.0] == arrivals[0.5] == arrivals[0.9] == arrivals[1.0]
    av = {share: a for share, (_, a) in runs.items()}
    assert av[0.0].sum() == 0 and av[1.0].all()
    assert av[0.5].sum() < av[0.9].sum() < len(av[1.0])
    assert np.all(av[0.9][av[0.5]])  # an AV at 0.5 is an AV at 0.9
    assert np.array_equal(_drivers(_with_share(base, 0.5, 3))[1], av[0.5])  # same seed, same drivers
    assert not np.array_equal(_drivers(_with_share(base, 0.5, 4))[1][:100], av[0.5][:100])
