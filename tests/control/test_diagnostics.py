"""Controller.diagnostics(): what each controller reports for summary.json and convergence.csv."""

from __future__ import annotations

import dataclasses

import pytest

from intersection_cosim.control import registry
from intersection_cosim.network.movements import paper_movements
from intersection_cosim.control.base import ControlContext, Diagnostics
from intersection_cosim.models.settings import ModelSettings


def test_defaults_mean_not_applicable():
    d = Diagnostics()
    assert (d.convergence, d.safety_interventions, d.box_rule_clearances, d.pedestrian_holds) == (None,) * 4
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.safety_interventions = 1


@pytest.mark.parametrize("kind", ["sumo", "sumo-priority", "sumo-allway-stop", "sumo-tls", "fcfs"])
def test_controllers_without_games_or_filter_report_nothing(kind):
    ctrl = registry.create(kind, None, "priority")
    assert ctrl.diagnostics() == Diagnostics()


@pytest.mark.parametrize("kind", ["nash", "stackelberg"])
def test_a_fresh_game_controller_reports_zero_counts_and_no_records(kind, paths, net_file):
    ctrl = registry.create(kind, None, "priority")
    ctrl.setup(ControlContext(movements=paper_movements(net_file), model=ModelSettings(), control_period=0.1,
                              settings=None, etm=True))
    assert ctrl.diagnostics() == Diagnostics(convergence=(), safety_interventions=0, box_rule_clearances=0,
                                             pedestrian_holds=0)

