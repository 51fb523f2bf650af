"""A stress folder's outputs, rebuilt from its runs: ``stress.csv``, the failure files (after
``--shrink``) and ``summary.json``."""

from __future__ import annotations

import json
import math
import sys
import tomllib
from pathlib import Path

import pandas as pd

from intersection_cosim.errors import InputError
from intersection_cosim.experiments.stress.failures import (FAILURES_DIR, Found, dedup, file_name, shrink_candidates,
                                                            size, write_failure)
from intersection_cosim.experiments.stress.oracles import KINDS, NEAR_MISS_KINDS
from intersection_cosim.experiments.stress.runs import (SCENARIOS_DIR, make_job, run_batch, run_error, verdict,
                                                        write_atomic)
from intersection_cosim.experiments.stress.spec import STRESS_TABLE_FILE, SUMMARY_FILE, Prepared
from intersection_cosim.scenario import scenario_from_dict

SHRINK_DIR = "shrink"


def _row(prep: Prepared, out: Path, index: int) -> tuple[dict, tuple | None]:
    """stress.csv's row of run ``index`` and (run id, verdict, scenario dict) if it finished."""
    rid = f"run-{index:05d}"
    draws = out / "draws" / f"{rid}.json"
    drawn = json.loads(draws.read_text()) if draws.is_file() else {"seed": None, "generation": None, "draw": {}}
    row = {"run_id": rid, "generation": drawn["generation"], "seed": drawn["seed"],
           **{p.name: drawn["draw"].get(p.name) for p in prep.spec.params}}
    v = verdict(out, rid, prep.settings)
    if v is None:
        error = run_error(out, rid)
        return {**row, "status": "failed" if error else "pending", "error": error}, None
    first = v.failures[0] if v.failures else None
    row.update(status="ok", margin=v.margin, min_pet=v.min_pet, min_time_gap=v.min_time_gap,
               failures=";".join(f.kind for f in v.failures), near_misses=";".join(f.kind for f in v.near_misses),
               first_failure=first.kind if first else "",
               first_failure_time=first.time if first else math.nan,
               first_failure_place=first.place if first else "", vehicles=v.vehicles, arrived=v.arrived,
               compute_ms_median=v.compute_ms_median, error="")
    data = tomllib.loads((out / SCENARIOS_DIR / f"{rid}.toml").read_text())
    return row, (rid, v, data)


def stress_table(prep: Prepared, out: Path) -> tuple[pd.DataFrame, list[tuple]]:
    rows, finished = [], []
    for i in range(prep.spec.runs):
        row, done = _row(prep, out, i)
        if row["status"] != "pending":
            rows.append(row)
        if done is not None:
            finished.append(done)
    return pd.DataFrame(rows), finished


def _still_fails(found: Found, data: dict, v) -> Found | None:
    """``found`` moved to a shrunk scenario whose verdict ``v`` shows the same kind at the same
    place (None: it does not)."""
    same = [f for f in v.failures if (f.kind, f.site) == found.key]
    return Found(found.key, found.run_id, same[0], data, found.runs) if same else None


def _candidates(prep: Prepared, out: Path, found: Found) -> list[tuple]:
    """(job, scenario dict) of each valid shrink candidate of ``found``."""
    jobs = []
    for n, data in enumerate(shrink_candidates(found.data, found.failure, prep.settings.shrink_pad,
                                               prep.settings.shrink_attempts)):
        try:
            scenario_from_dict(data, prep.spec.scenario)
        except InputError:
            continue  # e.g. an attack on a vehicle of a dropped flow
        rid = file_name(found.key).removesuffix(".toml") + f"-{n}"
        jobs.append((make_job(out / SHRINK_DIR, rid, data, f"shrink attempt {n} of {file_name(found.key)}"), data))
    return jobs


def _smallest(prep: Prepared, out: Path, found: Found, jobs: list[tuple]) -> Found:
    """The smallest of ``found``'s finished candidates that still fails alike (``found`` if none)."""
    best = found
    for job, data in jobs:
        v = verdict(out / SHRINK_DIR, job.run_id, prep.settings)
        moved = _still_fails(found, data, v) if v is not None else None
        if moved is not None and size(data) < size(best.data):
            best = moved
    return best


def _shrunk(prep: Prepared, out: Path, executor, found: list[Found], progress: bool) -> list[Found]:
    """Every failure of ``found`` shrunk: all their candidates run as one batch, then each keeps its smallest."""
    from tqdm import tqdm

    jobs = [_candidates(prep, out, fd) for fd in found]
    total = sum(len(j) for j in jobs)
    bar = tqdm(total=total, unit="run", desc="shrink", file=sys.stderr, disable=not (progress and total),
               dynamic_ncols=True)
    try:
        run_batch(executor, [job for js in jobs for job, _ in js], out / SHRINK_DIR, prep.settings, bar)
    finally:
        bar.close()
    return [_smallest(prep, out, fd, js) for fd, js in zip(found, jobs)]


def _failure_files(prep: Prepared, out: Path, finished: list[tuple], executor, shrink: bool, command: str,
                   progress: bool) -> list[dict]:
    found = dedup(finished)
    small = _shrunk(prep, out, executor, found, progress) if shrink and found else found
    listed = []
    for fd, sm in zip(found, small):
        path = write_failure(out / FAILURES_DIR, sm, command)
        f = sm.failure
        listed.append({"file": str(path.relative_to(out)), "kind": f.kind, "place": sm.key[1],
                       "time": f.time, "lane": f.place, "vehicles": list(f.vehicles), "why": f.why,
                       "found_by": fd.run_id, "runs": fd.runs, "shrunk": sm is not fd,
                       "flows": size(sm.data)[0], "duration": size(sm.data)[1]})
    return listed


def _runs_with(ok: pd.DataFrame, column: str, kinds: tuple[str, ...]) -> dict[str, int]:
    """How many of the finished runs ``ok`` list each of ``kinds`` in ``column`` (kinds joined by ";")."""
    if not len(ok):
        return {k: 0 for k in kinds}
    listed = ok[column].fillna("").astype(str).str.split(";")
    return {k: int(listed.apply(lambda fs, k=k: k in fs).sum()) for k in kinds}


def write_outputs(prep: Prepared, out: Path, executor, shrink: bool, command: str, progress: bool) -> dict:
    """stress.csv, the failure files and summary.json of the stress folder ``out``; return the summary."""
    table, finished = stress_table(prep, out)
    write_atomic(out / STRESS_TABLE_FILE, table.to_csv(index=False, float_format="%.6g"))
    listed = _failure_files(prep, out, finished, executor, shrink, command, progress)
    ok = table[table["status"] == "ok"] if len(table) else table
    margins = ok["margin"] if len(ok) else pd.Series([], dtype=float)
    kinds = _runs_with(ok, "failures", KINDS)
    summary = {"scenario": prep.spec.scenario, "search": prep.spec.search, "seed": prep.spec.seed,
               "runs": prep.spec.runs, "runs_finished": int(len(ok)),
               "runs_crashed": int((table["status"] == "failed").sum()) if len(table) else 0,
               "min_margin": float(margins.min()) if len(margins) else math.nan,
               "median_margin": float(margins.median()) if len(margins) else math.nan,
               "runs_with_failure": kinds, "runs_with_near_miss": _runs_with(ok, "near_misses", NEAR_MISS_KINDS),
               "failures": listed, "command": command}
    write_atomic(out / SUMMARY_FILE, json.dumps(summary, indent=2) + "\n")
    return summary
