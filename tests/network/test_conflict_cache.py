"""The on-disk cache of conflict tables (network/conflict_cache.py): a second process reads what
the first built, with the same arrays; any change of the inputs misses it; a damaged file is rebuilt."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from intersection_cosim.network import conflicts
from intersection_cosim.network.cache import cached_net
from intersection_cosim.network.conflict_cache import FOLDER
from intersection_cosim.network.movements import paper_movements


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """An empty cache folder, the in-memory caches cleared, and a count of the tables built."""
    net = cached_net()  # the net itself from the usual cache, before the variable moves it
    monkeypatch.setenv("INTERSECTION_COSIM_CACHE", str(tmp_path))
    monkeypatch.setattr(conflicts, "_MOVEMENT_CACHE", {})
    built = []
    build = conflicts.ConflictTable.build

    def counting(*args, **kwargs):
        built.append(1)
        return build(*args, **kwargs)

    monkeypatch.setattr(conflicts.ConflictTable, "build", staticmethod(counting))
    return paper_movements(net), built, tmp_path


def _arrays(table):
    return [np.nan_to_num(a, nan=-1.0) for a in (table.kind, table.s_a, table.s_b, table.zone_in, table.zone_out)]


def test_a_second_process_reads_the_table_the_first_built(cache, monkeypatch):
    movements, built, folder = cache
    first = conflicts.movement_conflict_table(movements, 1.8, 4.5)
    monkeypatch.setattr(conflicts, "_MOVEMENT_CACHE", {})  # as a new process would start
    second = conflicts.movement_conflict_table(movements, 1.8, 4.5)
    assert len(built) == 1 and second is not first
    assert all(np.array_equal(a, b) for a, b in zip(_arrays(first), _arrays(second)))
    assert second.paths == dict(movements.paths) and len(list((folder / FOLDER).glob("*.pkl"))) == 2


def test_other_bodies_or_other_geometry_miss_the_cache(cache, monkeypatch):
    movements, built, _ = cache
    conflicts.movement_conflict_table(movements, 1.8, 4.5)
    monkeypatch.setattr(conflicts, "_MOVEMENT_CACHE", {})
    conflicts.movement_conflict_table(movements, 1.8, 5.0)  # a longer body
    pid = sorted(movements.paths)[0]
    moved = dataclasses.replace(movements.paths[pid], xy=movements.paths[pid].xy + 0.01)
    other = dataclasses.replace(movements, paths={**movements.paths, pid: moved}, net_file="elsewhere.net.xml")
    conflicts.movement_conflict_table(other, 1.8, 4.5)  # one path's centre line 1 cm off
    assert len(built) == 3


def test_a_damaged_file_is_rebuilt(cache, monkeypatch):
    movements, built, folder = cache
    conflicts.movement_conflict_table(movements, 1.8, 4.5)
    for f in (folder / FOLDER).glob("*.pkl"):
        f.write_bytes(b"not a pickle")
    monkeypatch.setattr(conflicts, "_MOVEMENT_CACHE", {})
    table = conflicts.movement_conflict_table(movements, 1.8, 4.5)
    assert len(built) == 2 and table.kind.shape == (len(movements.paths),) * 2
