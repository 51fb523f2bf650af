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
from intersection_cosim.experiments.stress.oracles import KINDS
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
               failures=";".join(f.kind for f in v.failures), first_failure=first.kind if first else "",
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
    """``found`` moved to a shrunk scenario whose verdict ``v`` shows the same kind (None: not)."""
    same = [f for f in v.failures if f.kind == found.key[0]]
    if not same:
        return None
    best = next((f for f in same if f.site == found.key[1]), same[0])
    return Found(found.key, found.run_id, best, data, found.runs)


def _shrink_one(prep: Prepared, out: Path, executor, found: Found, bar) -> Found:
    """The smallest of ``found``'s shrink candidates that still fails alike (``found`` if none)."""
    folder = out / SHRINK_DIR
    jobs = []
    for n, data in enumerate(shrink_candidates(found.data, found.failure, prep.settings.shrink_pad,
                                               prep.settings.shrink_attempts)):
        try:
            scenario_from_dict(data, prep.spec.scenario)
        except InputError:
            continue  # e.g. an attack on a vehicle of a dropped flow
        rid = file_name(found.key).removesuffix(".toml") + f"-{n}"
        jobs.append((make_job(folder, rid, data, f"shrink attempt {n} of {file_name(found.key)}"), data))
    run_batch(executor, [j for j, _ in jobs], folder, prep.settings, bar)
    best = found
    for job, data in jobs:
        v = verdict(folder, job.run_id, prep.settings)
        moved = _still_fails(found, data, v) if v is not None else None
        if moved is not None and size(data) < size(best.data):
            best = moved
    return best


def _failure_files(prep: Prepared, out: Path, finished: list[tuple], executor, shrink: bool, command: str,
                   progress: bool) -> list[dict]:
    from tqdm import tqdm

    found = dedup(finished)
    bar = tqdm(total=0, unit="run", desc="shrink", file=sys.stderr, disable=not (progress and shrink and found),
               dynamic_ncols=True)
    listed = []
    try:
        for fd in found:
            small = _shrink_one(prep, out, executor, fd, bar) if shrink else fd
            path = write_failure(out / FAILURES_DIR, small, command)
            f = small.failure
            listed.append({"file": str(path.relative_to(out)), "kind": f.kind, "place": small.key[1],
                           "time": f.time, "lane": f.place, "vehicles": list(f.vehicles), "why": f.why,
                           "found_by": fd.run_id, "runs": fd.runs, "shrunk": small is not fd,
                           "flows": size(small.data)[0], "duration": size(small.data)[1]})
    finally:
        bar.close()
    return listed


def write_outputs(prep: Prepared, out: Path, executor, shrink: bool, command: str, progress: bool) -> dict:
    """stress.csv, the failure files and summary.json of the stress folder ``out``; return the summary."""
    table, finished = stress_table(prep, out)
    write_atomic(out / STRESS_TABLE_FILE, table.to_csv(index=False, float_format="%.6g"))
    listed = _failure_files(prep, out, finished, executor, shrink, command, progress)
    ok = table[table["status"] == "ok"] if len(table) else table
    margins = ok["margin"] if len(ok) else pd.Series([], dtype=float)
    kinds = {k: int(ok["failures"].str.split(";").apply(lambda fs, k=k: k in fs).sum()) if len(ok) else 0
             for k in KINDS}
    summary = {"scenario": prep.spec.scenario, "search": prep.spec.search, "seed": prep.spec.seed,
               "runs": prep.spec.runs, "runs_finished": int(len(ok)),
               "runs_crashed": int((table["status"] == "failed").sum()) if len(table) else 0,
               "min_margin": float(margins.min()) if len(margins) else math.nan,
               "median_margin": float(margins.median()) if len(margins) else math.nan,
               "runs_with_failure": kinds, "failures": listed, "command": command}
    write_atomic(out / SUMMARY_FILE, json.dumps(summary, indent=2) + "\n")
    return summary
