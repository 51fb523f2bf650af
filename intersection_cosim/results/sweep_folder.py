"""A sweep folder: its spec (``sweep.json``), its run ids and its table (``sweep.csv``).

The spec is what a sweep runs (scenario, kappa grid, controllers, seeds); ``experiments.sweep``
makes it from the command line and runs it, ``report`` reads it back for the axes of its figures.
Run ids are stable, e.g. ``sumo-seed1-V1_0.30-V2_0.50``. :func:`sweep_table` rebuilds sweep.csv's
table from the run folders and failure records alone, so it is exact after a crash and a rerun.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from intersection_cosim.results.layout import (PAIRS_FILE, RUN_MARKER, SPEC_FILE, VEHICLES_FILE, failure_file,
                                               is_finished_run, run_folder)

DECIMALS = 6  # kappa values are rounded to this many decimals
# Columns that depend on the wall clock, not on the simulation (differ between identical runs).
WALL_CLOCK_COLUMNS = ("compute_ms_median", "compute_ms_p95", "deadline_misses", "fallbacks")


def format_kappa(value: float) -> str:
    """0.3 -> ``0.30``, 0.125 -> ``0.125``: at least two decimals, no trailing noise."""
    whole, _, frac = f"{value:.{DECIMALS}f}".rstrip("0").partition(".")
    return f"{whole}.{frac.ljust(2, '0')}"


def safe_name(name: str) -> str:
    """A vehicle id as it appears in run ids and folder names (``[A-Za-z0-9.]``, others ``_``)."""
    return re.sub(r"[^A-Za-z0-9.]+", "_", name)


@dataclasses.dataclass(frozen=True)
class SweepSpec:
    """What a sweep runs: stored as ``sweep.json`` so a rerun and ``report`` know the axes."""

    scenario: str  # absolute path of the scenario file
    scenario_sha256: str  # of the file's bytes: a rerun on an edited file is refused
    scenario_name: str
    vehicles: tuple[str, ...]  # ids of the scenario's hand-placed vehicles (per-vehicle columns)
    kappa: tuple[tuple[str, tuple[float, ...]], ...]  # swept vehicles and their values, in axis order
    controllers: tuple[str, ...]
    seeds: tuple[int, ...]
    scenario_text: str = dataclasses.field(default="", compare=False, repr=False)  # what the runs run
    overrides: tuple[tuple[str, float], ...] = ()  # [scenario] / [controller] field overrides of every run (experiments/executors.py)
    # scenario axes (experiments/axes.py) and their values, e.g. (("latency", (0.0, 0.1)),), in axis order
    scenario_axes: tuple[tuple[str, tuple[float, ...]], ...] = ()

    @property
    def axes(self) -> list[str]:
        """The axis columns of sweep.csv: one kappa column per swept vehicle, then the scenario axes."""
        return [f"kappa_{vid}" for vid, _ in self.kappa] + [name for name, _ in self.scenario_axes]

    @property
    def total(self) -> int:
        return (len(self.controllers) * len(self.seeds) * math.prod(len(v) for _, v in self.kappa)
                * math.prod(len(v) for _, v in self.scenario_axes))

    def grid(self):
        """(controller, seed, ((vehicle, kappa), ...), ((axis, value), ...)) for every run, in the
        order of sweep.csv."""
        vids = [vid for vid, _ in self.kappa]
        names = [name for name, _ in self.scenario_axes]
        for controller in self.controllers:
            for seed in self.seeds:
                for point in itertools.product(*(values for _, values in self.scenario_axes)):
                    for combo in itertools.product(*(values for _, values in self.kappa)):
                        yield controller, seed, tuple(zip(vids, combo, strict=True)), tuple(zip(names, point))

    @staticmethod
    def run_id(controller: str, seed: int, kappa: tuple[tuple[str, float], ...],
               axes: tuple[tuple[str, float], ...] = ()) -> str:
        return (f"{controller}-seed{seed}" + "".join(f"-{safe_name(v)}_{format_kappa(k)}" for v, k in kappa)
                + "".join(f"-{name}_{format_kappa(x)}" for name, x in axes))

    def identity(self) -> tuple:
        """What must match for a rerun to continue a sweep (the file may have moved)."""
        return (self.scenario_sha256, self.vehicles, self.kappa, self.controllers, self.seeds, self.overrides,
                self.scenario_axes)

    def to_dict(self) -> dict:
        return {"scenario": self.scenario, "scenario_sha256": self.scenario_sha256,
                "scenario_name": self.scenario_name, "vehicles": list(self.vehicles),
                "kappa": {vid: list(values) for vid, values in self.kappa},
                "controllers": list(self.controllers), "seeds": list(self.seeds), "runs": self.total,
                **({"overrides": dict(self.overrides)} if self.overrides else {}),
                **({"axes": {name: list(values) for name, values in self.scenario_axes}} if self.scenario_axes else {})}

    @classmethod
    def from_dict(cls, d: dict) -> "SweepSpec":
        return cls(scenario=d["scenario"], scenario_sha256=d["scenario_sha256"], scenario_name=d["scenario_name"],
                   vehicles=tuple(d["vehicles"]),
                   kappa=tuple((vid, tuple(float(x) for x in vals)) for vid, vals in d["kappa"].items()),
                   controllers=tuple(d["controllers"]), seeds=tuple(int(s) for s in d["seeds"]),
                   overrides=tuple((str(f), float(x)) for f, x in d.get("overrides", {}).items()),
                   scenario_axes=tuple((str(n), tuple(float(x) for x in vals)) for n, vals in d.get("axes", {}).items()))


def load_spec(out: str | Path) -> SweepSpec:
    """The spec of the sweep folder ``out`` (its ``sweep.json``)."""
    return SweepSpec.from_dict(json.loads((Path(out) / SPEC_FILE).read_text()))


PAIR_METRICS = (("min_ttc", "min_ttc"), ("min_ttc_ssm", "min_ttc_ssm"), ("pet", "pet_ssm"))  # (column, pairs.csv)
COUNT_COLUMNS = ("collisions", "arrived", "vehicles")
TIMING_COLUMNS = ("compute_ms_median", "compute_ms_p95", "deadline_misses", "fallbacks")


def _pair_key(a: str, b: str) -> str:
    return f"{a}_{b}"


def run_metrics(run_dir: Path, vehicles: tuple[str, ...] | None = None) -> dict:
    """Headline metrics of one finished run: per hand-placed vehicle, per pair of them, overall.

    ``vehicles``: the vehicles that get their own columns (default: every vehicle of the run).
    """
    run_dir = Path(run_dir)
    summary = json.loads((run_dir / RUN_MARKER).read_text())
    veh = pd.read_csv(run_dir / VEHICLES_FILE, dtype={"vehicle": str})
    pairs = pd.read_csv(run_dir / PAIRS_FILE, dtype={"vehicle_a": str, "vehicle_b": str})
    chosen = set(veh["vehicle"] if vehicles is None else vehicles)
    m: dict = {}
    tt = veh.set_index("vehicle")["travel_time"]
    for vid in (list(veh["vehicle"]) if vehicles is None else vehicles):
        m[f"travel_time_{vid}"] = float(tt[vid]) if vid in tt.index else np.nan
    metrics = dict(summary.get("metrics", {}))
    counts = summary.get("counts", {})
    m["mean_travel_time"] = metrics.pop("mean_travel_time", None)
    for _, row in pairs.iterrows():
        a, b = sorted((row["vehicle_a"], row["vehicle_b"]))
        if a in chosen and b in chosen:
            for col, src in PAIR_METRICS:
                m[f"{col}_{_pair_key(a, b)}"] = row[src]
    m["min_ttc"] = metrics.pop("min_ttc", None)
    m["min_ttc_ssm"] = metrics.pop("min_ttc_ssm", None)
    m["min_pet"] = float(pairs["pet_ssm"].min()) if len(pairs) and pairs["pet_ssm"].notna().any() else np.nan
    for key in COUNT_COLUMNS:
        m[key] = counts.get(key)
    m["compute_ms_median"] = metrics.pop("compute_ms_median", None)
    m["compute_ms_p95"] = metrics.pop("compute_ms_p95", None)
    m["deadline_misses"] = counts.get("deadline_misses")
    m["fallbacks"] = counts.get("fallbacks")
    for key, value in sorted(metrics.items()):  # metrics added to summary.json later get columns too
        if isinstance(value, (int, float)) or value is None:
            m[key] = value
    for key, value in summary.get("v2x", {}).items():  # a run with a [v2x] link: its message counts
        m[f"v2x_{key}"] = value
    return {k: (np.nan if v is None else v) for k, v in m.items()}


def sweep_table(out: str | Path, spec: SweepSpec | None = None) -> pd.DataFrame:
    """sweep.csv's table, built from the run folders and failure records (grid order)."""
    out = Path(out)
    spec = spec or load_spec(out)
    rows = []
    for controller, seed, kappa, axes in spec.grid():
        run_id = spec.run_id(controller, seed, kappa, axes)
        row = {"run_id": run_id, "controller": controller, "seed": seed}
        row.update({f"kappa_{vid}": k for vid, k in kappa})
        row.update(dict(axes))
        failed = failure_file(out, run_id)
        if is_finished_run(run_folder(out, run_id)):
            row.update(run_metrics(run_folder(out, run_id), spec.vehicles))
            row.update(status="ok", error="")
        elif failed.is_file():
            try:
                error = json.loads(failed.read_text()).get("error", "")
            except ValueError:
                error = "unreadable failure record"
            row.update(status="failed", error=error)
        else:
            continue
        rows.append(row)
    params = ["run_id", "controller", "seed", *spec.axes]
    seen = list(dict.fromkeys(k for r in rows for k in r))
    pair_keys = sorted({c[len("min_ttc_ssm_"):] for c in seen if c.startswith("min_ttc_ssm_")})
    fixed = (params + [f"travel_time_{v}" for v in spec.vehicles] + ["mean_travel_time"]
             + [f"{col}_{key}" for key in pair_keys for col, _ in PAIR_METRICS]
             + ["min_ttc", "min_ttc_ssm", "min_pet", *COUNT_COLUMNS, *TIMING_COLUMNS])
    extras = [c for c in seen if c not in fixed and c not in ("status", "error")]
    columns = fixed + extras + ["status", "error"]
    return pd.DataFrame(rows, columns=columns)
