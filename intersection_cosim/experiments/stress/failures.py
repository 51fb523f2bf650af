"""Failures of a stress search: de-duplicated by kind and place, shrunk, and written as scenario
files that replay them.

A failure file ``failures/<kind>-<place>.toml`` is the plain scenario of the run that failed (every
drawn value written out, absolute file paths), headed by comments naming the first failure of that
kind: its time [s], place (lane), vehicles and why it counts. ``intersection-cosim run`` on it
replays the run on the same code.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from pathlib import Path

from intersection_cosim.experiments.stress.oracles import Failure, Verdict
from intersection_cosim.experiments.stress.toml_text import dumps

FAILURES_DIR = "failures"


@dataclasses.dataclass(frozen=True)
class Found:
    """One de-duplicated failure: the run that showed it first (lowest run index) and its data."""

    key: tuple[str, str]  # (kind, place it is de-duplicated by)
    run_id: str
    failure: Failure
    data: dict  # the run's scenario dict
    runs: int  # how many runs showed this kind at this place


def dedup(results: list[tuple[str, Verdict, dict]]) -> list[Found]:
    """One :class:`Found` per (kind, place) over ``results`` = (run id, verdict, scenario dict) in
    run order; the first run in that order keeps it, the others only count."""
    first: dict[tuple[str, str], Found] = {}
    for run_id, verdict, data in results:
        for f in verdict.failures:
            key = (f.kind, f.site)
            if key in first:
                first[key] = dataclasses.replace(first[key], runs=first[key].runs + 1)
            else:
                first[key] = Found(key, run_id, f, data, 1)
    return sorted(first.values(), key=lambda fd: (fd.failure.time, fd.key))


def file_name(key: tuple[str, str]) -> str:
    """``<kind>-<place>.toml`` with characters other than letters, digits, ``._-`` as ``_``."""
    return re.sub(r"[^A-Za-z0-9._-]", "_", f"{key[0]}-{key[1]}") + ".toml"


def header(found: Found, command: str) -> str:
    f = found.failure
    return "\n".join([
        f"intersection-cosim stress: a {f.kind} at {found.key[1]}, found by run {found.run_id} "
        f"({found.runs} run{'s' if found.runs != 1 else ''} showed it)",
        f"first {f.kind}: t = {f.time:.2f} s on {f.place}; vehicles {', '.join(f.vehicles) or '-'}",
        f"why: {f.why}",
        f"replay: intersection-cosim run <this file>   (search: {command})",
    ])


def write_failure(folder: Path, found: Found, command: str) -> Path:
    """Write ``found``'s scenario file into ``folder`` atomically; return its path."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / file_name(found.key)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(dumps(found.data, header(found, command)))
    os.replace(tmp, path)
    return path


def _flow_of(vehicle: str, flow_ids: set[str]) -> str | None:
    head = vehicle.rpartition(".")[0]
    return head if head in flow_ids else None


def shrink_candidates(data: dict, failure: Failure, pad: float, attempts: int) -> list[dict]:
    """Smaller scenarios that may still fail, smallest first: the window ended ``pad`` [s] after
    the failure (if that is at least ``pad`` shorter) and only the flows of its vehicles (with
    their bursts), both and each alone."""
    scen = data.get("scenario", {})
    duration = float(scen.get("duration", 60.0))
    short = float(math.ceil(failure.time + pad))
    flows = data.get("flow", [])
    ids = {t["id"] for t in flows if "id" in t}
    keep = {fl for v in failure.vehicles if (fl := _flow_of(v, ids)) is not None}
    kept = [t for t in flows if t.get("id") in keep or t.get("id", "").removesuffix("_burst") in keep]
    out = []
    fewer = bool(kept) and len(kept) < len(flows)
    shorter = short <= duration - pad
    if shorter and fewer:
        out.append({**data, "scenario": {**scen, "duration": short}, "flow": kept})
    if shorter:
        out.append({**data, "scenario": {**scen, "duration": short}})
    if fewer:
        out.append({**data, "flow": kept})
    return out[:attempts]


def size(data: dict) -> tuple[int, float]:
    """(flows, demand window [s]): what a shrunk scenario is smaller in."""
    return len(data.get("flow", [])), float(data.get("scenario", {}).get("duration", 0.0))
