"""Sweeps: every combination of per-vehicle kappa values, controllers and seeds, one run each.

A sweep folder holds ``sweep.json`` (the spec), ``sweep.csv`` (the table), ``runs/<run id>/``
(one run folder each, written atomically by experiments/run.py) and ``failed/<run id>.json`` (the
error of a run that failed, removed when a retry succeeds); see ``results.layout`` and
``results.sweep_folder``.

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
import json
import math
import os
import re
import shutil
import sys
import time
import tomllib
from pathlib import Path

import pandas as pd

from intersection_cosim.control import registry
from intersection_cosim.errors import InputError
from intersection_cosim.experiments.axes import parse_axes
from intersection_cosim.experiments.executors import (OVERRIDE_TABLES, Job, execute_job, finished_results, open_executor,
                                                      stop_children)
from intersection_cosim.results.layout import FAILED_DIR, RUNS_DIR, SPEC_FILE, TABLE_FILE, failure_file, run_folder
from intersection_cosim.results.sweep_folder import DECIMALS, SweepSpec, load_spec, safe_name, sweep_table
from intersection_cosim.experiments.stress.toml_text import dumps
from intersection_cosim.results.units import write_units
from intersection_cosim.scenario import load_scenario
from intersection_cosim.scenario.set_option import apply_sets, validated

LOCK_FILE = ".sweep.lock"
MAX_VALUES = 10_000  # [-] values one --kappa spec may expand to
# The controllers whose decisions use a vehicle's kappa (the game controllers, control/game/controller.py); SUMO's
# own driver model (sumo, sumo-*) and the FCFS reservation (control/baselines/fcfs.py) ignore it.
KAPPA_CONTROLLERS = ("nash", "stackelberg")


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

def make_spec(scenario: str | Path, kappa: list[str] | None = None, controllers: str | None = None,
              seeds: str | None = None, overrides: dict[str, float] | None = None,
              axes: dict[str, str | None] | None = None, sets: list[str] | None = None) -> SweepSpec:
    """Validate the command line's sweep spec against the scenario; raise InputError before any run.

    ``sets``: ``--set TABLE.KEY=VALUE`` options (scenario/set_option.py), written into the text the
    runs run (and so into the sweep's identity).

    ``overrides``: [scenario] / [controller] fields set for every run (``executors.OVERRIDE_TABLES``), e.g.
    ``{"duration": 60.0, "budget_ms": 20.0}``; part of the sweep's identity. ``axes``: the scenario
    axes of the command line (experiments/axes.py), name -> value list text, e.g. ``{"latency": "0,0.1"}``.
    """
    path = Path(scenario)
    scn = load_scenario(path)
    text = path.read_text()  # load_scenario has checked it is readable UTF-8
    if sets:
        data = apply_sets(tomllib.loads(text), sets)
        scn = validated(data, str(path), sets)
        text = dumps(data, f"{path.name} with --set {' '.join(sets)}")
    vids = [v.id for v in scn.vehicles]
    grid = parse_kappa(kappa, vids)
    safe = [safe_name(v) for v in grid]
    if len(set(safe)) != len(safe):
        raise InputError("--kappa", "kappa", ", ".join(grid), "vehicle ids collide in run folder names")
    scenario_axes = parse_axes(axes)
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
                     controllers=kinds, seeds=seed_list, scenario_text=text, overrides=tuple(fixed),
                     scenario_axes=scenario_axes)


def sweep_jobs(spec: SweepSpec, out: str | Path, scenario_text: str = "") -> list[Job]:
    """The runs of ``spec`` in the sweep folder ``out``, in grid order; ``scenario_text`` is the
    scenario file's text they run."""
    out = Path(out).resolve()
    return [Job(run_id=(rid := spec.run_id(c, s, k, a)), scenario=spec.scenario, scenario_text=scenario_text,
                controller=c, seed=s, kappa=k, run_dir=str(run_folder(out, rid)),
                failed_file=str(failure_file(out, rid)), overrides=spec.overrides, axes=a)
            for c, s, k, a in spec.grid()]


def kappa_warning(spec: SweepSpec) -> str | None:
    """One line naming the sweep's controllers that ignore kappa when the sweep sets kappa (their
    runs differ only by seed, whatever --kappa says); None otherwise."""
    blind = [c for c in spec.controllers if c not in KAPPA_CONTROLLERS]
    if not spec.kappa or not blind:
        return None
    return (f"intersection-cosim: warning: {', '.join(blind)} {'ignores' if len(blind) == 1 else 'ignore'} kappa: "
            f"{'its' if len(blind) == 1 else 'their'} runs differ only by seed, whatever --kappa says "
            f"(kappa is used by {', '.join(KAPPA_CONTROLLERS)})")


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
                                                "seeds", "overrides", "scenario axes"), old.identity(), spec.identity(),
                                               strict=True) if a != b]
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
def locked_folder(out: Path):
    """Hold ``out``'s lock file while a sweep (or a stress search) writes; remove it when done (a
    finished sweep leaves no lock behind). A sweep that opened the file just before another removed it finds
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
        with locked_folder(out):
            check_out(spec, out)  # again, now that we hold the lock
            _write_atomic(out / SPEC_FILE, json.dumps(spec.to_dict(), indent=2) + "\n")
            warning = kappa_warning(spec)  # once, after every input check passed
            if warning:
                print(warning, file=sys.stderr)
            _clean_leftovers(out)
            (out / RUNS_DIR).mkdir(exist_ok=True)
            jobs = sweep_jobs(spec, out, spec.scenario_text)
            todo = [j for j in jobs if not j.finished]
            skipped = len(jobs) - len(todo)
            bar = tqdm(total=len(jobs), initial=skipped, unit="run", desc=spec.scenario_name, file=sys.stderr,
                       disable=not progress, dynamic_ncols=True)
            failed = 0
            futures = {}
            try:
                futures = {executor.submit(execute_job, job): job for job in todo}
                for job, result in finished_results(futures):
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

def write_table(out: str | Path, spec: SweepSpec | None = None) -> pd.DataFrame:
    """Rebuild sweep.csv atomically; return the table."""
    out = Path(out)
    table = sweep_table(out, spec)
    _write_atomic(out / TABLE_FILE, table.to_csv(index=False, float_format="%.6g"))
    write_units(out, {TABLE_FILE: table.columns})
    return table
