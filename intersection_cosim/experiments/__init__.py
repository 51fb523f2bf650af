"""Runs of scenarios: single runs now; sweeps and executors build on them."""
