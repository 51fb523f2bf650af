"""Metrics, CSV tables and figures of runs and sweeps."""
