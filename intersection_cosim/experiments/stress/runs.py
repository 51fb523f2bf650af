"""Running a batch of stress runs on an executor (local processes or Dask, experiments/executors.py)
and judging each finished run once (its verdict cached in ``verdicts/<run id>.json``)."""

from __future__ import annotations

import json
import os
import shutil
import sys
from pathlib import Path

from intersection_cosim.experiments.executors import Job, execute_job, finished_results, stop_children
from intersection_cosim.experiments.stress.oracles import Verdict, judge
from intersection_cosim.experiments.stress.toml_text import dumps
from intersection_cosim.results.layout import FAILED_DIR, RUNS_DIR, failure_file, is_finished_run, run_folder
from intersection_cosim.scenario.stress_settings import StressSettings

SCENARIOS_DIR = "scenarios"
VERDICTS_DIR = "verdicts"


def write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and a rename."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(text)
    os.replace(tmp, path)


def clean_leftovers(folder: Path) -> None:
    """Remove the temporary files and folders that killed writers left in ``folder`` and below."""
    if not folder.is_dir():
        return
    for p in list(folder.rglob(".*")):
        if ".tmp-" in p.name or ".old-" in p.name:
            shutil.rmtree(p, ignore_errors=True) if p.is_dir() else p.unlink(missing_ok=True)


def make_job(folder: Path, run_id: str, data: dict, header: str) -> Job:
    """The job of one run in ``folder`` (a stress folder or its shrink folder); its scenario file
    ``scenarios/<run id>.toml`` is written (again only if it changed)."""
    text = dumps(data, header)
    path = folder / SCENARIOS_DIR / f"{run_id}.toml"
    if not path.is_file() or path.read_text() != text:
        write_atomic(path, text)
    scen, ctrl = data.get("scenario", {}), data.get("controller", {})
    return Job(run_id=run_id, scenario=str(path.resolve()), scenario_text=text, controller=ctrl.get("kind", "sumo"),
               seed=int(scen.get("seed", 42)), kappa=(), run_dir=str(run_folder(folder, run_id).resolve()),
               failed_file=str(failure_file(folder, run_id).resolve()))


def verdict(folder: Path, run_id: str, settings: StressSettings) -> Verdict | None:
    """The verdict of run ``run_id`` of ``folder``; None while it has not finished."""
    if not is_finished_run(run_folder(folder, run_id)):
        return None
    path = folder / VERDICTS_DIR / f"{run_id}.json"
    if path.is_file():
        return Verdict.from_dict(json.loads(path.read_text()))
    v = judge(run_folder(folder, run_id), settings.time_gap_floor, settings.hard_braking_tolerance,
              settings.stuck_time, settings.emergency_braking_fails)
    write_atomic(path, json.dumps(v.to_dict(), indent=1))
    return v


def run_error(folder: Path, run_id: str) -> str:
    """The recorded error of a run that failed ("" if none)."""
    path = failure_file(folder, run_id)
    if not path.is_file():
        return ""
    return json.loads(path.read_text()).get("error", "")


def run_batch(executor, jobs: list[Job], folder: Path, settings: StressSettings, bar) -> int:
    """Run the unfinished ``jobs`` (of ``folder``), judge each as it finishes; return how many failed.

    On Ctrl-C the pending runs are cancelled and the running ones stopped, then it re-raises."""
    (folder / RUNS_DIR).mkdir(parents=True, exist_ok=True)
    todo = [j for j in jobs if not j.finished]
    bar.update(len(jobs) - len(todo))
    crashed = 0
    futures = {}
    try:
        futures = {executor.submit(execute_job, job): job for job in todo}
        for job, result in finished_results(futures):
            if result["status"] == "ok":
                verdict(folder, job.run_id, settings)
            else:
                crashed += 1
                bar.write(f"run {job.run_id} failed: {result['error']}", file=sys.stderr)
            bar.update(1)
    except KeyboardInterrupt:
        for fut in futures:
            fut.cancel()
        stop_children()
        raise
    return crashed


__all__ = ["FAILED_DIR", "SCENARIOS_DIR", "VERDICTS_DIR", "make_job", "run_batch", "verdict"]
