"""Scenario files (TOML): the paper's cases, hand-placed vehicles and demand flows."""

from intersection_cosim.scenario.load import load_scenario, scenario_from_dict, with_overrides
from intersection_cosim.scenario.model import NetworkSettings

__all__ = ["NetworkSettings", "load_scenario", "scenario_from_dict", "with_overrides"]
