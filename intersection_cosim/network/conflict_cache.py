"""The conflict points and tables of a net's movements, kept on disk between runs.

Building them is geometry over every pair of paths (network/conflicts.py, conflict_zones.py):
some seconds for a city net of two hundred junctions, paid again by every run, seed and worker
of a study. Each result is stored under ``$INTERSECTION_COSIM_CACHE/conflicts/`` (the per-user
cache of generated nets, network/cache.py), named by a digest of everything it is computed from:
the paths themselves (ids, lanes, centre lines, headings, curvature, speed limits), SUMO's foe
pairs, the body sizes, and the source of the modules that compute it. A changed net, setting or
algorithm therefore misses the cache; it cannot return a stale table. Files are written under a
temporary name and moved in, so parallel runs may race; a file that cannot be read is rebuilt,
and a cache that cannot be written only costs the build.
"""

from __future__ import annotations

import functools
import hashlib
import os
import pickle
from pathlib import Path
from typing import Callable, Mapping, TypeVar

from intersection_cosim.network.cache import cache_root
from intersection_cosim.network.paths import MovementPath

T = TypeVar("T")
SOURCES = ("conflicts.py", "conflict_zones.py", "paths.py", "conflict_cache.py")  # what computes the results
FOLDER = "conflicts"


@functools.lru_cache(maxsize=1)
def _code_digest() -> bytes:
    """Digest of the source of the modules that compute conflicts (a code change misses the cache)."""
    h = hashlib.sha256()
    for name in SOURCES:
        h.update((Path(__file__).parent / name).read_bytes())
    return h.digest()


def inputs_digest(kind: str, paths: Mapping[str, MovementPath], foes, sizes: tuple[float, ...]) -> str:
    """Hex digest of one result's inputs: ``kind``, the paths (sorted by id), the foe pairs (sorted)
    and the body sizes [m]."""
    h = hashlib.sha256(_code_digest())
    h.update(pickle.dumps((kind, sorted(foes), tuple(float(v) for v in sizes)), protocol=4))
    for pid in sorted(paths):
        h.update(pickle.dumps(paths[pid], protocol=4))
    return h.hexdigest()


def disk_cached(digest: str, build: Callable[[], T]) -> T:
    """The result stored under ``digest`` (:func:`inputs_digest`), else ``build()``, stored."""
    path = cache_root() / FOLDER / f"{digest[:40]}.pkl"
    try:
        return pickle.loads(path.read_bytes())
    except (OSError, pickle.UnpicklingError, EOFError, AttributeError, ImportError, TypeError, ValueError):
        pass  # not there yet, or unreadable: build it
    value = build()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
        tmp.write_bytes(pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL))
        os.replace(tmp, path)
    except OSError:
        pass  # a read-only or full cache only costs the build
    return value
