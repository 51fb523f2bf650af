"""A per-user cache of generated nets, keyed by the intersection spec and the SUMO version.

Runs and scenario loading need a net for every junction type; building it takes netconvert a
fraction of a second, but a sweep does it thousands of times. Nets are built once into
``$INTERSECTION_COSIM_CACHE`` (default ``~/.cache/intersection-cosim``), never into the installed
package. ``build_network`` moves finished files in atomically, so parallel runs may race safely.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from pathlib import Path

import sumolib

from intersection_cosim.network.build import NET_FILE, build_network
from intersection_cosim.network.spec import IntersectionSpec


def cache_root() -> Path:
    env = os.environ.get("INTERSECTION_COSIM_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "intersection-cosim"


def sumo_version() -> str:
    """SUMO's version string, as sumolib reports it."""
    return str(sumolib.version.gitDescribe()).lstrip("v") if hasattr(sumolib, "version") else "unknown"


def cached_net(spec: IntersectionSpec | None = None) -> Path:
    """The net file for ``spec``, built on first use."""
    spec = spec or IntersectionSpec()
    key = json.dumps({"spec": dataclasses.asdict(spec), "sumo": sumo_version(), "v": 1}, sort_keys=True)
    folder = cache_root() / "nets" / hashlib.sha256(key.encode()).hexdigest()[:16]
    net = folder / NET_FILE
    if not net.exists():
        build_network(folder, spec)
    return net
