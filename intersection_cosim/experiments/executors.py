"""Where the runs of a sweep execute: a local pool, or a Dask cluster; each run in a fresh process.

libsumo allows one simulation per process and keeps global state, so a run never shares its
process with another run. :func:`execute_job` is what an executor is handed: it starts a fresh
Python interpreter (``python -m intersection_cosim.experiments.executors``, i.e. a spawned process,
never a fork), passes it the job on stdin, and waits. The child loads the scenario, applies the
job's overrides and calls :func:`~intersection_cosim.experiments.run.run_scenario`, which writes
the run folder atomically. Because the run lives in its own child:

- a crash of SUMO (even a segfault or ``exit()``) fails that one run and never the pool;
- the same code path serves the local pool and Dask, whose worker processes are daemonic (they
  may not use ``multiprocessing``) and run tasks in threads: a task that waits on a subprocess is
  safe in any number of worker threads.

Outcomes travel through the file system: a finished run is a run folder with ``summary.json``; a
failed run is ``failed/<run id>.json`` with the error (written by the child for a Python exception,
by :func:`execute_job` when the child died without one). :func:`execute_job` returns a small dict
``{run_id, status, error, seconds}`` with status ``ok`` / ``failed`` / ``interrupted``.

The local executor is a thread pool of N supervisors: each thread only waits on its run's process,
so N runs execute in parallel as N processes (the same process isolation as a
``ProcessPoolExecutor(mp_context=spawn, max_tasks_per_child=1)``, without a pool that one crashed
run would break).
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import signal
import subprocess
import sys
import threading
import time
import tomllib
import traceback
from concurrent.futures import Executor, ThreadPoolExecutor, as_completed
from pathlib import Path
from typing import Iterator

from intersection_cosim.errors import InputError
from intersection_cosim.experiments.axes import apply_axes
from intersection_cosim.experiments.run import run_scenario
from intersection_cosim.results.layout import is_finished_run
from intersection_cosim.scenario import scenario_from_dict, with_overrides

CONNECT_TIMEOUT = "10s"  # to the Dask scheduler
OUTPUT_TAIL = 4000  # [chars] of a dead child's output (stdout and stderr) kept in its failure record


@dataclasses.dataclass(frozen=True)
class Job:
    """One run of a sweep: a small picklable description (scenario file + overrides)."""

    run_id: str  # stable name of the run folder, e.g. ``sumo-seed1-V1_0.30-V2_0.50``
    scenario: str  # absolute path of the scenario file (names it in messages and summary.json)
    scenario_text: str  # the file's text as read when the sweep started (workers need not see the file)
    controller: str  # controller kind (registry name)
    seed: int
    kappa: tuple[tuple[str, float], ...]  # (vehicle id, kappa) overrides
    run_dir: str  # absolute path of the run folder (finished <=> it holds summary.json)
    failed_file: str  # absolute path of the failure record
    # (field, value) overrides, e.g. (("duration", 60.0),); see OVERRIDE_TABLES
    overrides: tuple[tuple[str, float], ...] = ()
    axes: tuple[tuple[str, float], ...] = ()  # (scenario axis, value) of experiments/axes.py, e.g. (("latency", 0.1),)

    def to_json(self) -> str:
        return json.dumps(dataclasses.asdict(self))

    @classmethod
    def from_json(cls, text: str) -> "Job":
        d = json.loads(text)
        d["kappa"] = tuple((str(v), float(k)) for v, k in d["kappa"])
        d["overrides"] = tuple((str(f), float(x)) for f, x in d.get("overrides", ()))
        d["axes"] = tuple((str(n), float(x)) for n, x in d.get("axes", ()))
        return cls(**d)

    @property
    def finished(self) -> bool:
        return is_finished_run(self.run_dir)


# Fields a sweep may override for all its runs (``compare --duration``, ``--budget-ms``,
# ``--work-clock``), with the scenario-file table each belongs to.
OVERRIDE_TABLES = {"duration": "scenario", "budget_ms": "controller", "work_clock_ms": "controller"}


def job_scenario(job: Job):
    """The job's scenario: the file with the controller, seed, kappa and [scenario] overrides applied."""
    scn = scenario_from_dict(tomllib.loads(job.scenario_text), job.scenario)
    scn = with_overrides(scn, controller=job.controller, seed=job.seed)
    for name, value in job.overrides:
        table = OVERRIDE_TABLES[name]
        scn = dataclasses.replace(scn, **{table: dataclasses.replace(getattr(scn, table), **{name: value})})
    kappa = dict(job.kappa)
    vehicles = tuple(dataclasses.replace(v, kappa=kappa[v.id]) if v.id in kappa else v for v in scn.vehicles)
    return apply_axes(dataclasses.replace(scn, vehicles=vehicles), job.axes)


def run_job(job: Job) -> dict:
    """Run ``job`` in this process (which must not have run a simulation before); return its summary."""
    summary = run_scenario(job_scenario(job), Path(job.run_dir), compress_trajectories=True)
    with contextlib.suppress(FileNotFoundError):
        os.remove(job.failed_file)  # a retry that succeeded clears the earlier failure
    return summary


def write_failure(job: Job, error: str, detail: str = "") -> None:
    """Write the failure record of ``job`` atomically."""
    path = Path(job.failed_file)
    path.parent.mkdir(parents=True, exist_ok=True)
    params = {k: v for k, v in dataclasses.asdict(job).items() if k != "scenario_text"}
    record = {"run_id": job.run_id, "job": params, "error": " ".join(error.split()),
              "detail": detail, "time": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}-{threading.get_ident()}")
    tmp.write_text(json.dumps(record, indent=2))
    os.replace(tmp, path)


def finished_results(futures: dict):
    """Yield ``(job, result)`` for each of ``futures`` (future -> Job, from ``executor.submit(
    execute_job, job)``) as it finishes; a task the executor lost (e.g. a Dask worker died) is a
    failed result, its failure record written like a run's."""
    for fut in as_completed(futures):
        job = futures[fut]
        try:
            result = fut.result()
        except Exception as exc:  # noqa: BLE001 - the executor lost the task
            result = {"status": "failed", "error": f"{type(exc).__name__}: {exc}"}
            write_failure(job, result["error"])
        yield job, result


def _error_line(exc: BaseException) -> str:
    text = exc.one_line() if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
    return " ".join(text.split())


# Children started by execute_job in this process, so an interrupted sweep can stop them.
_children: set[subprocess.Popen] = set()
_children_lock = threading.Lock()


def execute_job(job: Job) -> dict:
    """Run ``job`` in a fresh Python process and wait; never raises for a failed run."""
    t0 = time.monotonic()
    if job.finished:
        return {"run_id": job.run_id, "status": "ok", "error": "", "seconds": 0.0}
    with contextlib.suppress(FileNotFoundError):
        os.remove(job.failed_file)  # an earlier attempt's error; this attempt writes its own
    cmd = [sys.executable, "-m", "intersection_cosim.experiments.executors"]
    proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, errors="replace", env={**os.environ, PARENT_ENV: str(os.getpid())})
    with _children_lock:
        _children.add(proc)
    try:
        output, _ = proc.communicate(job.to_json())
    finally:
        with _children_lock:
            _children.discard(proc)
    seconds = time.monotonic() - t0
    code = proc.returncode
    if code == 0 and job.finished:
        return {"run_id": job.run_id, "status": "ok", "error": "", "seconds": seconds}
    if code in (130, -signal.SIGINT):
        return {"run_id": job.run_id, "status": "interrupted", "error": "interrupted", "seconds": seconds}
    if code == 1 and Path(job.failed_file).is_file():  # the child recorded its exception
        error = json.loads(Path(job.failed_file).read_text()).get("error", "")
        return {"run_id": job.run_id, "status": "failed", "error": error, "seconds": seconds}
    if code < 0:
        error = f"run process killed by signal {signal.Signals(-code).name}"
    else:
        error = f"run process exited with status {code} without a result"
    write_failure(job, error, (output or "")[-OUTPUT_TAIL:])
    return {"run_id": job.run_id, "status": "failed", "error": error, "seconds": seconds}


def stop_children(grace: float = 3.0) -> None:
    """Stop the runs this process started: they had SIGINT already (Ctrl-C reaches the whole
    process group) and remove their temporary folders; send it to those that did not, then kill."""
    with _children_lock:
        procs = list(_children)
    deadline = time.monotonic() + grace
    for p in procs:
        with contextlib.suppress(subprocess.TimeoutExpired):
            p.wait(max(0.0, deadline - time.monotonic()))
    alive = [p for p in procs if p.poll() is None]
    for p in alive:
        with contextlib.suppress(ProcessLookupError):
            p.send_signal(signal.SIGINT)
    deadline = time.monotonic() + grace
    for p in alive:
        try:
            p.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


@contextlib.contextmanager
def open_executor(workers: int | None = None, dask_scheduler: str | None = None) -> Iterator[Executor]:
    """A ``concurrent.futures`` executor to submit :func:`execute_job` to.

    ``dask_scheduler`` (``tcp://HOST:PORT``): a Dask distributed cluster, through
    ``Client.get_executor``; the workers must have this package installed and see the sweep's
    output folder at the same path (the scenario travels with the job). Otherwise a local pool of
    ``workers`` parallel runs (default: the number of CPUs available to this process).
    """
    if dask_scheduler:
        try:
            from distributed import Client
        except ImportError:
            raise InputError("--dask-scheduler", "dask_scheduler", dask_scheduler,
                             "needs Dask: pip install 'intersection-cosim[dask]'") from None
        try:
            client = Client(dask_scheduler, timeout=CONNECT_TIMEOUT, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as exc:
            raise InputError("--dask-scheduler", "dask_scheduler", dask_scheduler,
                             f"cannot connect to the scheduler ({type(exc).__name__}: {exc})") from None
        try:
            yield client.get_executor(pure=False)
        finally:
            client.close()
        return
    n = workers or default_workers()
    pool = ThreadPoolExecutor(max_workers=n, thread_name_prefix="sweep-run")
    try:
        yield pool
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def default_workers() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


ORPHAN_POLL = 1.0  # [s] how often a run's process checks that the process that started it lives
PARENT_ENV = "INTERSECTION_COSIM_PARENT_PID"  # the pid of the process that started a run's process


def _exit_when_orphaned(parent: int, poll: float = ORPHAN_POLL) -> None:
    """End this process (status 137, as killed) once ``parent`` is no longer its parent (at once if
    it has gone already, while this process was starting): a sweep or stress search
    killed hard (``kill -9``) leaves its runs behind, and a rerun that resumes it must not meet a
    run still writing the folder it runs again. The run's temporary folder is left for the rerun
    to remove, as after any kill."""
    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(poll)
        os._exit(137)

    threading.Thread(target=watch, name="orphan-watch", daemon=True).start()


def _child_main() -> int:
    """Entry point of a run's own process: the job as JSON on stdin."""
    signal.signal(signal.SIGINT, signal.default_int_handler)  # even if the parent ignored SIGINT
    _exit_when_orphaned(int(os.environ.get(PARENT_ENV, os.getppid())))
    job = Job.from_json(sys.stdin.read())
    try:
        run_job(job)
    except KeyboardInterrupt:
        return 130
    except Exception as exc:  # noqa: BLE001 - every failure of a run is recorded, the sweep goes on
        write_failure(job, _error_line(exc), traceback.format_exc())
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(_child_main())
