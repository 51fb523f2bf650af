"""Controller.diagnostics(): what each controller reports for summary.json and convergence.csv."""

from __future__ import annotations

import dataclasses

import pytest

from intersection_cosim.control import registry
from intersection_cosim.control.base import Diagnostics


def test_defaults_mean_not_applicable():
    d = Diagnostics()
    assert (d.convergence, d.safety_interventions, d.box_rule_clearances) == (None, None, None)
    with pytest.raises(dataclasses.FrozenInstanceError):
        d.safety_interventions = 1


@pytest.mark.parametrize("kind", ["sumo", "sumo-priority", "sumo-allway-stop", "sumo-tls", "fcfs"])
def test_controllers_without_games_or_filter_report_nothing(kind):
    ctrl = registry.create(kind, None, "priority")
    assert ctrl.diagnostics() == Diagnostics()


@pytest.mark.parametrize("kind", ["nash", "stackelberg"])
def test_a_fresh_game_controller_reports_zero_counts_and_no_records(kind):
    ctrl = registry.create(kind, None, "priority")
    assert ctrl.diagnostics() == Diagnostics(convergence=(), safety_interventions=0, box_rule_clearances=0)

