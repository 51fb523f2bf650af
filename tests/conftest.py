"""Shared pytest fixtures."""

from __future__ import annotations

import pytest

from intersection_cosim.network.build import build_network


@pytest.fixture(scope="session")
def net_file(tmp_path_factory):
    """The default intersection net, built once per test session with netconvert."""
    return build_network(tmp_path_factory.mktemp("net"))


@pytest.fixture(scope="session")
def paths(net_file):
    """Every movement path of the default net, keyed by path id."""
    from intersection_cosim.network.paths import load_paths

    return load_paths(net_file)


@pytest.fixture(scope="session")
def conflict_table(net_file):
    """The default net's ConflictTable (conflict points of all path pairs as arrays)."""
    from intersection_cosim.network.conflicts import load_conflict_table

    return load_conflict_table(net_file)


@pytest.fixture(scope="session")
def movements(net_file):
    """The default net's Movements (its centre junction's paths, exits, siblings and lane roles)."""
    from intersection_cosim.network.movements import paper_movements

    return paper_movements(net_file)


DROP_RULE = "INTERSECTION_COSIM_TEST_DROP_RULE"  # a safety rule's name: run the tests without that rule


@pytest.fixture(autouse=True)
def _drop_rule(monkeypatch):
    """With ``$INTERSECTION_COSIM_TEST_DROP_RULE`` set, every safety filter made in the test runs
    without that rule (tests/control/safety/test_rules.py shows each rule's test then fails)."""
    import os

    name = os.environ.get(DROP_RULE)
    if name:
        from intersection_cosim.control.safety import rules

        monkeypatch.setattr(rules, "RULES", tuple(r for r in rules.RULES if r.name != name))
