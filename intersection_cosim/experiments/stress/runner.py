"""``intersection-cosim stress``: the search loop, generation by generation, then the failures
(de-duplicated, shrunk, written as scenario files), ``stress.csv`` and ``summary.json``.

Run ids are ``run-00000``, ``run-00001``, ...; a rerun of the same command skips the finished runs
(their verdicts are on disk, so a cross-entropy search fits the same generations again) and
rebuilds every output from the run folders, so the outputs after a crash and a rerun are those of
an uninterrupted search (except the wall-clock compute column).
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

from intersection_cosim.errors import InputError
from intersection_cosim.experiments.executors import open_executor
from intersection_cosim.experiments.stress.draws import variant
from intersection_cosim.experiments.stress.people import PEOPLE_DIR, with_people
from intersection_cosim.experiments.stress.outputs import write_outputs
from intersection_cosim.experiments.stress.runs import clean_leftovers, make_job, run_batch, verdict, write_atomic
from intersection_cosim.experiments.stress.search import cem_fit, generations, propose, to_unit
from intersection_cosim.experiments.stress.spec import STRESS_SPEC_FILE, STRESS_TABLE_FILE, Prepared, check_out
from intersection_cosim.experiments.sweep import locked_folder

DRAWS_DIR = "draws"


@dataclasses.dataclass
class StressOutcome:
    out: Path
    runs: int
    finished: int
    crashed: int
    failures: int  # de-duplicated failures written
    min_margin: float  # [s]
    seconds: float

    @property
    def failed(self) -> int:
        return self.crashed

    def lines(self) -> list[str]:
        text = f"{self.out}: {self.finished}/{self.runs} runs finished"
        if self.crashed:
            text += f", {self.crashed} crashed (see {self.out / 'failed'})"
        return [text + f"; smallest margin {self.min_margin:.3f} s; {self.failures} distinct failures in "
                f"{self.out / 'failures'}; {self.out / STRESS_TABLE_FILE}"]


def run_id(index: int) -> str:
    return f"run-{index:05d}"


def _fit(prep: Prepared, out: Path, previous: range):
    """The CEM fit of generation ``previous``'s finished runs (None: none finished, draw uniformly)."""
    units, margins = [], []
    for i in previous:
        v = verdict(out, run_id(i), prep.settings)
        if v is not None:
            drawn = json.loads((out / DRAWS_DIR / f"{run_id(i)}.json").read_text())
            units.append(to_unit(prep.spec.params, drawn["draw"]))
            margins.append(v.margin)
    if not units:
        return None
    s = prep.settings
    return cem_fit(np.array(units), np.array(margins), s.cem_elite, s.cem_min_std)


def _generation_jobs(prep: Prepared, out: Path, indices: range, generation: int, fit) -> list:
    spec = prep.spec
    jobs = []
    for i in indices:
        seed, draw = propose(spec.params, spec.seed, i, fit)
        write_atomic(out / DRAWS_DIR / f"{run_id(i)}.json",
                     json.dumps({"seed": seed, "generation": generation, "draw": draw}, indent=1))
        data = variant(prep.base, prep.scn, draw, seed, spec.duration, prep.settings)
        data = with_people(data, prep.scn, draw, spec.duration, out / PEOPLE_DIR / f"{run_id(i)}.rou.xml")
        header = (f"run {run_id(i)} of a stress search of {spec.scenario_name} ({spec.search}, seed {spec.seed}, "
                  f"generation {generation})")
        jobs.append(make_job(out, run_id(i), data, header))
    return jobs


def _search(prep: Prepared, out: Path, executor, bar) -> int:
    """Every generation's runs; return how many crashed."""
    spec = prep.spec
    gens = generations(spec.runs, prep.settings.cem_generations) if spec.search == "cem" else [range(spec.runs)]
    crashed = 0
    for g, indices in enumerate(gens):
        fit = _fit(prep, out, gens[g - 1]) if g > 0 else None
        crashed += run_batch(executor, _generation_jobs(prep, out, indices, g, fit), out, prep.settings, bar)
    return crashed


def _start(prep: Prepared, out: Path) -> None:
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError("--out", "out", str(out), f"cannot be written ({exc.strerror})") from None


def run_stress(prep: Prepared, out: str | Path, *, workers: int | None = None, dask_scheduler: str | None = None,
               progress: bool = True, shrink: bool = True, command: str = "") -> StressOutcome:
    """Run the search ``prep`` into ``out`` (skipping finished runs), then write its outputs."""
    from tqdm import tqdm

    t0 = time.monotonic()
    out = Path(out)
    check_out(prep.spec, out)
    with open_executor(workers, dask_scheduler) as executor:
        _start(prep, out)
        with locked_folder(out):
            check_out(prep.spec, out)
            write_atomic(out / STRESS_SPEC_FILE, json.dumps(prep.spec.to_dict(), indent=2) + "\n")
            clean_leftovers(out)
            bar = tqdm(total=prep.spec.runs, unit="run", desc=f"stress {prep.spec.scenario_name}", file=sys.stderr,
                       disable=not progress, dynamic_ncols=True)
            try:
                crashed = _search(prep, out, executor, bar)
            finally:
                bar.close()
            summary = write_outputs(prep, out, executor, shrink, command, progress)
    return StressOutcome(out=out, runs=prep.spec.runs, finished=summary["runs_finished"], crashed=crashed,
                         failures=len(summary["failures"]), min_margin=summary["min_margin"],
                         seconds=time.monotonic() - t0)
