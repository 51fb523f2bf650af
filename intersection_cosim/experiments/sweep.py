"""Sweeps: every combination of per-vehicle kappa values, controllers and seeds, one run each.

A sweep folder holds::

    sweep.json          the sweep's spec (scenario, grid, controllers, seeds): the axes of `report`
    sweep.csv           one row per finished or failed run, rebuilt from the run folders
    runs/<run id>/      one run folder each (see experiments/run.py), written atomically
    failed/<run id>.json  the error of a run that failed (removed when a retry succeeds)

Run ids are stable, e.g. ``sumo-seed1-V1_0.30-V2_0.50``, so a rerun of the same command skips the
finished runs (and retries failed ones). ``sweep.csv`` is rebuilt from the run folders at the end
of a sweep (also an interrupted one), so it is exact after a crash and a rerun.

Spec syntax (command line): ``--kappa V1=0.1:0.9:0.1`` (a range, both ends included, values
rounded to 6 decimals), ``--kappa V2=0.2,0.5`` (a list) or ``--kappa V2=0.5``; ``--seeds 1-5``,
``--seeds 1,3,7`` or a mix ``1-3,7``; ``--controllers nash,stackelberg,sumo`` (``--controller``, the old
spelling, is accepted too).
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import itertools
import json
import math
import os
import re
import shutil
import sys
import time
from concurrent.futures import as_completed
from pathlib import Path

import numpy as np
import pandas as pd

from intersection_cosim.errors import InputError
from intersection_cosim.experiments.executors import Job, execute_job, open_executor, stop_children, write_failure

SPEC_FILE = "sweep.json"
TABLE_FILE = "sweep.csv"
RUNS_DIR = "runs"
FAILED_DIR = "failed"
LOCK_FILE = ".sweep.lock"
MAX_VALUES = 10_000  # [-] values one --kappa spec may expand to
DECIMALS = 6  # kappa values are rounded to this many decimals
# The controllers whose decisions use a vehicle's kappa (the game controllers, control/game.py); SUMO's
# own driver model (sumo, sumo-*) and the FCFS reservation (control/fcfs.py) ignore it.
KAPPA_CONTROLLERS = ("nash", "stackelberg")
# Columns that depend on the wall clock, not on the simulation (differ between identical runs).
WALL_CLOCK_COLUMNS = ("compute_ms_median", "compute_ms_p95", "deadline_misses", "fallbacks")


# --- spec parsing ------------------------------------------------------------------------------

def _float(text: str, spec: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError("--kappa", "kappa", spec, f"bad syntax: {text.strip()!r} is not a number "
                         "(expected VEHICLE=a:b:step, VEHICLE=a,b,c or VEHICLE=a)") from None
    if not math.isfinite(value) or not 0.0 <= value <= 1.0:
        raise InputError("--kappa", "kappa", spec, f"kappa {text.strip()} is outside [0, 1]")
    return value


def parse_kappa_values(spec: str, text: str) -> tuple[float, ...]:
    """``a:b:step`` (both ends included where on the grid), ``a,b,c`` or ``a`` -> sorted values."""
    text = text.strip()
    if not text:
        raise InputError("--kappa", "kappa", spec, "bad syntax: no values after '='")
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise InputError("--kappa", "kappa", spec, "bad syntax: a range is a:b:step")
        a, b, step = (_float(p, spec) if i < 2 else _step(p, spec) for i, p in enumerate(parts))
        if b < a:
            raise InputError("--kappa", "kappa", spec, f"empty range: end {b:g} is below start {a:g}")
        n = int(math.floor((b - a) / step + 1e-9)) + 1
        if n > MAX_VALUES:
            raise InputError("--kappa", "kappa", spec, f"range has {n} values, more than {MAX_VALUES}")
        values = [round(a + i * step, DECIMALS) for i in range(n)]
    else:
        values = [round(_float(p, spec), DECIMALS) for p in text.split(",")]
        if len(set(values)) != len(values):
            dup = next(v for v in values if values.count(v) > 1)
            raise InputError("--kappa", "kappa", spec, f"value {dup:g} given twice")
    return tuple(sorted(values))


def _step(text: str, spec: str) -> float:
    try:
        step = float(text)
    except ValueError:
        raise InputError("--kappa", "kappa", spec, f"bad syntax: step {text.strip()!r} is not a number") from None
    if not math.isfinite(step) or step <= 0:
        raise InputError("--kappa", "kappa", spec, f"empty range: step {text.strip()} must be > 0")
    return step


def parse_kappa(specs: list[str] | None, vehicle_ids: list[str]) -> dict[str, tuple[float, ...]]:
    """``["V1=0.1:0.9:0.1", "V2=0.2,0.5"]`` -> ``{"V1": (0.1, ..., 0.9), "V2": (0.2, 0.5)}``."""
    grid: dict[str, tuple[float, ...]] = {}
    for spec in specs or []:
        vid, sep, values = spec.partition("=")
        vid = vid.strip()
        if not sep or not vid:
            raise InputError("--kappa", "kappa", spec, "bad syntax: expected VEHICLE=a:b:step, VEHICLE=a,b,c "
                             "or VEHICLE=a")
        if vid not in vehicle_ids:
            known = ", ".join(vehicle_ids) or "none"
            raise InputError("--kappa", "kappa", spec, f"unknown vehicle {vid!r} (the scenario's vehicles: {known})")
        if vid in grid:
            raise InputError("--kappa", "kappa", spec, f"vehicle {vid} is swept twice")
        grid[vid] = parse_kappa_values(spec, values)
    return grid


def parse_seeds(text: str) -> tuple[int, ...]:
    """``1-5``, ``1,3,7`` or ``1-3,7`` -> seeds in the given order."""
    seeds: list[int] = []
    for part in text.split(","):
        part = part.strip()
        m = re.fullmatch(r"(\d+)(?:\s*-\s*(\d+))?", part)
        if not m:
            raise InputError("--seeds", "seeds", text, f"bad syntax at {part!r}: expected N, A-B or a list of them "
                             "(seeds are integers >= 0)")
        a = int(m.group(1))
        b = int(m.group(2)) if m.group(2) is not None else a
        if b < a:
            raise InputError("--seeds", "seeds", text, f"empty range {part}")
        seeds.extend(range(a, b + 1))
    if len(set(seeds)) != len(seeds):
        dup = next(s for s in seeds if seeds.count(s) > 1)
        raise InputError("--seeds", "seeds", text, f"seed {dup} given twice")
    return tuple(seeds)


def parse_controllers(text: str) -> tuple[str, ...]:
    from intersection_cosim.control import registry

    kinds = [k.strip() for k in text.split(",")]
    known = registry.names()
    for k in kinds:
        if k not in known:
            raise InputError("--controllers", "controllers", text, f"unknown controller {k!r} "
                             f"(known: {', '.join(known)})")
    if len(set(kinds)) != len(kinds):
        raise InputError("--controllers", "controllers", text, "a controller is given twice")
    return tuple(kinds)


# --- the sweep's spec and its jobs -------------------------------------------------------------

def format_kappa(value: float) -> str:
    """0.3 -> ``0.30``, 0.125 -> ``0.125``: at least two decimals, no trailing noise."""
    whole, _, frac = f"{value:.{DECIMALS}f}".rstrip("0").partition(".")
    return f"{whole}.{frac.ljust(2, '0')}"


def _safe(name: str) -> str:
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
    overrides: tuple[tuple[str, float], ...] = ()  # [scenario] / [controller] field overrides of every run (executors.py)

    @property
    def axes(self) -> list[str]:
        """The kappa columns of sweep.csv, one per swept vehicle."""
        return [f"kappa_{vid}" for vid, _ in self.kappa]

    @property
    def total(self) -> int:
        return len(self.controllers) * len(self.seeds) * math.prod(len(v) for _, v in self.kappa)

    def grid(self):
        """(controller, seed, ((vehicle, kappa), ...)) for every run, in the order of sweep.csv."""
        vids = [vid for vid, _ in self.kappa]
        for controller in self.controllers:
            for seed in self.seeds:
                for combo in itertools.product(*(values for _, values in self.kappa)):
                    yield controller, seed, tuple(zip(vids, combo, strict=True))

    @staticmethod
    def run_id(controller: str, seed: int, kappa: tuple[tuple[str, float], ...]) -> str:
        return f"{controller}-seed{seed}" + "".join(f"-{_safe(v)}_{format_kappa(k)}" for v, k in kappa)

    def jobs(self, out: Path, scenario_text: str = "") -> list[Job]:
        """The runs, in grid order; ``scenario_text`` is the scenario file's text they run."""
        out = Path(out).resolve()
        return [Job(run_id=(rid := self.run_id(c, s, k)), scenario=self.scenario, scenario_text=scenario_text,
                    controller=c, seed=s, kappa=k, run_dir=str(out / RUNS_DIR / rid),
                    failed_file=str(out / FAILED_DIR / f"{rid}.json"), overrides=self.overrides)
                for c, s, k in self.grid()]

    def identity(self) -> tuple:
        """What must match for a rerun to continue a sweep (the file may have moved)."""
        return (self.scenario_sha256, self.vehicles, self.kappa, self.controllers, self.seeds, self.overrides)

    def to_dict(self) -> dict:
        return {"scenario": self.scenario, "scenario_sha256": self.scenario_sha256,
                "scenario_name": self.scenario_name, "vehicles": list(self.vehicles),
                "kappa": {vid: list(values) for vid, values in self.kappa},
                "controllers": list(self.controllers), "seeds": list(self.seeds), "runs": self.total,
                **({"overrides": dict(self.overrides)} if self.overrides else {})}

    @classmethod
    def from_dict(cls, d: dict) -> "SweepSpec":
        return cls(scenario=d["scenario"], scenario_sha256=d["scenario_sha256"], scenario_name=d["scenario_name"],
                   vehicles=tuple(d["vehicles"]),
                   kappa=tuple((vid, tuple(float(x) for x in vals)) for vid, vals in d["kappa"].items()),
                   controllers=tuple(d["controllers"]), seeds=tuple(int(s) for s in d["seeds"]),
                   overrides=tuple((str(f), float(x)) for f, x in d.get("overrides", {}).items()))


def make_spec(scenario: str | Path, kappa: list[str] | None = None, controllers: str | None = None,
              seeds: str | None = None, overrides: dict[str, float] | None = None) -> SweepSpec:
    """Validate the command line's sweep spec against the scenario; raise InputError before any run.

    ``overrides``: [scenario] / [controller] fields set for every run (``executors.OVERRIDE_TABLES``), e.g.
    ``{"duration": 60.0, "budget_ms": 20.0}``; part of the sweep's identity.
    """
    from intersection_cosim.experiments.executors import OVERRIDE_TABLES

    from intersection_cosim.scenario import load_scenario

    path = Path(scenario)
    scn = load_scenario(path)
    text = path.read_text()  # load_scenario has checked it is readable UTF-8
    vids = [v.id for v in scn.vehicles]
    grid = parse_kappa(kappa, vids)
    safe = [_safe(v) for v in grid]
    if len(set(safe)) != len(safe):
        raise InputError("--kappa", "kappa", ", ".join(grid), "vehicle ids collide in run folder names")
    kinds = parse_controllers(controllers) if controllers else (scn.controller.kind,)
    seed_list = parse_seeds(seeds) if seeds else (scn.scenario.seed,)
    fixed = []
    for name, value in (overrides or {}).items():
        if name not in OVERRIDE_TABLES:
            raise InputError(f"--{name}", name, value, f"cannot be overridden (only {', '.join(OVERRIDE_TABLES)})")
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise InputError(f"--{name}", name, value, "must be a number > 0")
        fixed.append((name, float(value)))
    return SweepSpec(scenario=str(path.resolve()), scenario_sha256=hashlib.sha256(text.encode()).hexdigest(),
                     scenario_name=scn.scenario.name, vehicles=tuple(vids), kappa=tuple(grid.items()),
                     controllers=kinds, seeds=seed_list, scenario_text=text, overrides=tuple(fixed))


def kappa_warning(spec: SweepSpec) -> str | None:
    """One line naming the sweep's controllers that ignore kappa when the sweep sets kappa (their
    runs differ only by seed, whatever --kappa says); None otherwise."""
    blind = [c for c in spec.controllers if c not in KAPPA_CONTROLLERS]
    if not spec.kappa or not blind:
        return None
    return (f"intersection-cosim: warning: {', '.join(blind)} {'ignores' if len(blind) == 1 else 'ignore'} kappa: "
            f"{'its' if len(blind) == 1 else 'their'} runs differ only by seed, whatever --kappa says "
            f"(kappa is used by {', '.join(KAPPA_CONTROLLERS)})")


def load_spec(out: str | Path) -> SweepSpec:
    return SweepSpec.from_dict(json.loads((Path(out) / SPEC_FILE).read_text()))


def check_out(spec: SweepSpec, out: Path) -> None:
    """``out`` must be new, empty, or this same sweep's folder."""
    if out.exists() and not out.is_dir():
        raise InputError("--out", "out", str(out), "is a file, not a folder")
    if (out / SPEC_FILE).is_file():
        try:
            old = load_spec(out)
        except (ValueError, KeyError, TypeError) as exc:
            raise InputError("--out", "out", str(out), f"has an unreadable {SPEC_FILE} ({exc})") from None
        if old.identity() != spec.identity():
            what = [name for name, a, b in zip(("scenario file content", "vehicles", "kappa grid", "controllers",
                                                "seeds", "overrides"), old.identity(), spec.identity(), strict=True) if a != b]
            raise InputError("--out", "out", str(out), f"holds another sweep (its {', '.join(what)} differ); "
                             "rerun the same command to continue it, or use another --out")
    elif out.is_dir() and any(p.name != LOCK_FILE for p in out.iterdir()):
        raise InputError("--out", "out", str(out), "exists and is not a sweep folder; not writing into it")


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(text)
    os.replace(tmp, path)


def _clean_leftovers(out: Path) -> None:
    """Remove temporary files and folders of runs that were killed (we hold the sweep's lock)."""
    for folder in (out, out / RUNS_DIR, out / FAILED_DIR):
        if not folder.is_dir():
            continue
        for p in folder.iterdir():
            if p.name.startswith(".") and (".tmp-" in p.name or ".old-" in p.name):
                shutil.rmtree(p, ignore_errors=True) if p.is_dir() else p.unlink(missing_ok=True)


@contextlib.contextmanager
def _locked(out: Path):
    """Hold ``out``'s lock file while the sweep writes; remove it when done (a finished sweep
    leaves no lock behind). A sweep that opened the file just before another removed it finds
    its inode gone from the folder and is refused like any concurrent sweep."""
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock
        yield
        return
    lock = out / LOCK_FILE
    busy = InputError("--out", "out", str(out), "another sweep is writing into this folder")
    with open(lock, "w") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise busy from None
        try:
            if os.stat(lock).st_ino != os.fstat(fh.fileno()).st_ino:
                raise busy
        except FileNotFoundError:
            raise busy from None
        try:
            yield
        finally:
            lock.unlink(missing_ok=True)  # still holding the lock: no other sweep is in between


# --- running -----------------------------------------------------------------------------------

@dataclasses.dataclass
class SweepOutcome:
    out: Path
    total: int  # runs in the grid
    skipped: int  # finished before this call
    ok: int  # finished runs now
    failed: int  # failed runs now
    seconds: float  # wall time of this call

    def line(self) -> str:
        text = f"{self.out}: {self.ok}/{self.total} runs finished"
        if self.skipped:
            text += f" ({self.skipped} already before)"
        if self.failed:
            text += f", {self.failed} failed (see {self.out / FAILED_DIR})"
        return text + f"; {self.out / TABLE_FILE}"


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C: pending runs cancelled, finished runs kept, sweep.csv written."""

    def __init__(self, outcome: SweepOutcome):
        self.outcome = outcome
        super().__init__(f"{outcome.ok} of {outcome.total} runs finished and kept; rerun the same command to "
                         f"finish the sweep")


def run_sweep(spec: SweepSpec, out: str | Path, *, workers: int | None = None, dask_scheduler: str | None = None,
              progress: bool = True) -> SweepOutcome:
    """Run every job of ``spec`` not yet finished in ``out``; write sweep.csv; return counts.

    Raises :class:`SweepInterrupted` on Ctrl-C (after stopping the runs and writing sweep.csv).
    """
    if not spec.scenario_text:
        raise ValueError("run_sweep needs a spec from make_spec (with the scenario's text)")
    from tqdm import tqdm

    t0 = time.monotonic()
    out = Path(out)
    check_out(spec, out)
    with open_executor(workers, dask_scheduler) as executor:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError("--out", "out", str(out), f"cannot be written ({exc.strerror})") from None
        with _locked(out):
            check_out(spec, out)  # again, now that we hold the lock
            _write_atomic(out / SPEC_FILE, json.dumps(spec.to_dict(), indent=2) + "\n")
            warning = kappa_warning(spec)  # once, after every input check passed
            if warning:
                print(warning, file=sys.stderr)
            _clean_leftovers(out)
            (out / RUNS_DIR).mkdir(exist_ok=True)
            jobs = spec.jobs(out, spec.scenario_text)
            todo = [j for j in jobs if not j.finished]
            skipped = len(jobs) - len(todo)
            bar = tqdm(total=len(jobs), initial=skipped, unit="run", desc=spec.scenario_name, file=sys.stderr,
                       disable=not progress, dynamic_ncols=True)
            failed = 0
            futures = {}
            try:
                futures = {executor.submit(execute_job, job): job for job in todo}
                for fut in as_completed(futures):
                    job = futures[fut]
                    try:
                        result = fut.result()
                    except Exception as exc:  # noqa: BLE001 - the executor lost the task (e.g. a Dask worker died)
                        result = {"status": "failed", "error": f"{type(exc).__name__}: {exc}"}
                        write_failure(job, result["error"])
                    if result["status"] == "failed":
                        failed += 1
                        bar.set_postfix(failed=failed)
                        bar.write(f"run {job.run_id} failed: {result['error']}", file=sys.stderr)
                    bar.update(1)
            except KeyboardInterrupt:
                for fut in futures:
                    fut.cancel()
                stop_children()
                bar.close()
                table = write_table(out, spec)
                raise SweepInterrupted(_outcome(out, spec, table, skipped, t0)) from None
            bar.close()
            table = write_table(out, spec)
    return _outcome(out, spec, table, skipped, t0)


def _outcome(out: Path, spec: SweepSpec, table: pd.DataFrame, skipped: int, t0: float) -> SweepOutcome:
    status = table["status"] if len(table) else pd.Series([], dtype=str)
    return SweepOutcome(out=out, total=spec.total, skipped=skipped, ok=int((status == "ok").sum()),
                        failed=int((status == "failed").sum()), seconds=time.monotonic() - t0)


# --- sweep.csv ---------------------------------------------------------------------------------

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
    summary = json.loads((run_dir / "summary.json").read_text())
    veh = pd.read_csv(run_dir / "vehicles.csv", dtype={"vehicle": str})
    pairs = pd.read_csv(run_dir / "pairs.csv", dtype={"vehicle_a": str, "vehicle_b": str})
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
    return {k: (np.nan if v is None else v) for k, v in m.items()}


def sweep_table(out: str | Path, spec: SweepSpec | None = None) -> pd.DataFrame:
    """sweep.csv's table, built from the run folders and failure records (grid order)."""
    out = Path(out)
    spec = spec or load_spec(out)
    rows = []
    for (controller, seed, kappa), job in zip(spec.grid(), spec.jobs(out), strict=True):
        row = {"run_id": job.run_id, "controller": controller, "seed": seed}
        row.update({f"kappa_{vid}": k for vid, k in kappa})
        if job.finished:
            row.update(run_metrics(Path(job.run_dir), spec.vehicles))
            row.update(status="ok", error="")
        elif Path(job.failed_file).is_file():
            try:
                error = json.loads(Path(job.failed_file).read_text()).get("error", "")
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


def write_table(out: str | Path, spec: SweepSpec | None = None) -> pd.DataFrame:
    """Rebuild sweep.csv atomically; return the table."""
    out = Path(out)
    table = sweep_table(out, spec)
    _write_atomic(out / TABLE_FILE, table.to_csv(index=False, float_format="%.6g"))
    return table
