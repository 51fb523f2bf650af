"""What a stress search runs (``stress.json``), validated from the command line before anything is
written, and the folder it writes into.

A stress folder::

    stress.json             the search's spec (:class:`StressSpec`); a rerun must match it
    stress.csv              one row per run: drawn parameters, margin, failures, arrivals, compute
    summary.json            the search's counts, smallest margin and failure files
    scenarios/<run id>.toml the scenario each run ran (every drawn value written out)
    draws/<run id>.json     its scenario seed, generation and drawn parameters
    runs/<run id>/          the run folders (written atomically); failed/<run id>.json a crash
    verdicts/<run id>.json  each finished run's verdict (experiments/stress/oracles.py)
    shrink/                 the scenarios, runs and verdicts of --shrink's attempts
    failures/<kind>-<place>.toml  one scenario file per de-duplicated failure; it replays it
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import tomllib
from pathlib import Path

from intersection_cosim.errors import InputError
from intersection_cosim.results.layout import STRESS_SPEC_FILE, STRESS_SUMMARY_FILE, STRESS_TABLE_FILE
from intersection_cosim.experiments.stress.draws import Param, base_data, space
from intersection_cosim.experiments.stress.search import SEARCHES
from intersection_cosim.scenario.model import Scenario
from intersection_cosim.scenario.set_option import apply_sets, read_data, validated
from intersection_cosim.scenario.stress_settings import StressSettings, stress_settings

SUMMARY_FILE = STRESS_SUMMARY_FILE
__all__ = ["STRESS_SPEC_FILE", "STRESS_TABLE_FILE", "SUMMARY_FILE", "StressSpec", "Prepared", "prepare", "check_out"]
MAX_RUNS = 100_000  # [-] runs one search may ask for


@dataclasses.dataclass(frozen=True)
class StressSpec:
    """A stress search: stored as ``stress.json``; a rerun with another spec is refused."""

    scenario: str  # absolute path of the scenario file
    scenario_sha256: str  # of its text
    scenario_name: str
    sets: tuple[str, ...]  # the --set options, in order
    runs: int
    seed: int  # the search's seed (each run's own scenario seed is drawn from it)
    search: str  # random / cem
    duration: float  # [s] every run's demand window
    params: tuple[Param, ...]  # what is drawn

    def identity(self) -> dict:
        return self.to_dict()

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["params"] = [dataclasses.asdict(p) for p in self.params]
        d["sets"] = list(self.sets)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "StressSpec":
        return cls(**{**d, "sets": tuple(d["sets"]), "params": tuple(Param(**p) for p in d["params"])})


@dataclasses.dataclass(frozen=True)
class Prepared:
    """A validated search: its spec, the base scenario (dict and typed) and the [stress] settings."""

    spec: StressSpec
    base: dict
    scn: Scenario
    settings: StressSettings


def prepare(scenario: str | Path, runs: int, seed: int = 0, search: str = "random",
            duration: float | None = None, sets: list[str] | None = None) -> Prepared:
    """Validate the command line against the scenario; raise InputError before anything is written."""
    if not (isinstance(runs, int) and 1 <= runs <= MAX_RUNS):
        raise InputError("--runs", "runs", runs, f"must be an integer in [1, {MAX_RUNS}]")
    if not (isinstance(seed, int) and seed >= 0):
        raise InputError("--seed", "seed", seed, "must be an integer >= 0")
    if search not in SEARCHES:
        raise InputError("--search", "search", search, f"unknown search (known: {', '.join(SEARCHES)})")
    if duration is not None and not (math.isfinite(duration) and duration > 0):
        raise InputError("--duration", "duration", duration, "must be a number > 0")
    path = Path(scenario)
    data = apply_sets(read_data(path), sets)
    scn = validated(data, str(path), sets)
    settings = stress_settings(str(path), data.get("stress"))
    base = base_data(data, scn, path)
    window = float(duration) if duration is not None else scn.scenario.duration
    spec = StressSpec(scenario=str(path.resolve()), scenario_sha256=hashlib.sha256(path.read_bytes()).hexdigest(),
                      scenario_name=scn.scenario.name, sets=tuple(sets or ()), runs=runs, seed=seed, search=search,
                      duration=window, params=space(scn, settings))
    return Prepared(spec, base, scn, settings)


def check_out(spec: StressSpec, out: Path) -> None:
    """``out`` must be new, empty, or this same search's folder."""
    if out.exists() and not out.is_dir():
        raise InputError("--out", "out", str(out), "is a file, not a folder")
    marker = out / STRESS_SPEC_FILE
    if marker.is_file():
        try:
            old = json.loads(marker.read_text())
        except (ValueError, OSError) as exc:
            raise InputError("--out", "out", str(out), f"has an unreadable {STRESS_SPEC_FILE} ({exc})") from None
        if old != json.loads(json.dumps(spec.identity())):
            what = [k for k in spec.identity() if old.get(k) != json.loads(json.dumps(spec.identity()[k]))]
            raise InputError("--out", "out", str(out), f"holds another stress search (its {', '.join(what)} "
                             "differ); rerun the same command to continue it, or use another --out")
    elif out.is_dir() and any(not p.name.startswith(".") for p in out.iterdir()):
        raise InputError("--out", "out", str(out), "exists and is not a stress folder; not writing into it")


def load_spec(out: Path) -> StressSpec:
    return StressSpec.from_dict(json.loads((out / STRESS_SPEC_FILE).read_text()))


def scenario_data(text: str) -> dict:
    return tomllib.loads(text)
