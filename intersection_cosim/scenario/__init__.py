"""Scenario files (TOML): the paper's cases, hand-placed vehicles and demand flows."""

from intersection_cosim.scenario.load import load_scenario, scenario_from_dict, with_overrides

__all__ = ["load_scenario", "scenario_from_dict", "with_overrides"]
