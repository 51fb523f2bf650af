"""``intersection-cosim benchmark resco``: RESCO's real-demand scenarios (TAPAS Cologne, InTAS
Ingolstadt, and two synthetic grids) run as they are, at their own begin, under the chosen
controllers, through the controller comparison (experiments/compare.py: local processes or Dask,
resumable).

The nets and demand come from the ``sumo-rl`` package (``pip install ".[benchmarks]"``; only its
packaged files are used) or from ``--nets DIR`` holding ``<name>/<name>.sumocfg``. Each scenario
is written as a scenario file into ``OUT/scenarios/``: its sumocfg, every manageable junction,
signals off for the controllers that drive the vehicles (the signal baselines keep the net's
lights), ``window`` "full" (the sumocfg's begin to end, one hour) or "600" (its first 600 s).
Besides compare's table and figures it writes ``OUT/benchmark.md`` with the average delay
(tripinfo timeLoss of the arrived trips), scenario by controller; then RESCO's own delay measure
(results/resco_delay.py), which charges the backlog and is the one figure, beside RESCO's
published results for its signal baselines (experiments/resco_published.py).
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pandas as pd

from intersection_cosim.errors import InputError
from intersection_cosim.experiments.compare import CompareOutcome, make_specs, run_compare
from intersection_cosim.experiments.resco_published import RESCO_PUBLISHED, RESCO_SOURCE
from intersection_cosim.experiments.sweep import parse_controllers, parse_seeds, sweep_jobs
from intersection_cosim.results.layout import RUN_MARKER
from intersection_cosim.results.resco_delay import resco_delay
from intersection_cosim.results.sweep_folder import SweepSpec
from intersection_cosim.report.compare_figures import grouped_bars
from intersection_cosim.report.reporting import markdown_table

RESCO_SCENARIOS = ("cologne1", "cologne3", "cologne8", "ingolstadt1", "ingolstadt7", "ingolstadt21",
                   "arterial4x4", "grid4x4")
WINDOWS = {"full": None, "600": 600.0}  # [s] demand window (None: the sumocfg's end - begin)
DRAIN = 180.0  # [s] after the window, for the last vehicles to leave
BENCHMARK_FILE = "benchmark.md"
BENCHMARK_FIGURE = "figures/resco_delay.png"
SCENARIO_TEMPLATE = """# RESCO's {name}, run as it is (written by intersection-cosim benchmark resco)
[scenario]
name = "{name}"
{duration}drain = {drain:g}
ssm = false
seed = 1

[controller]
kind = "nash"

[network]
sumocfg = "{sumocfg}"
junctions = "all"
signals = "off"
"""


def resco_nets(nets: str | None) -> Path:
    """The folder of RESCO's scenarios: ``nets``, else the installed sumo-rl's ``nets/RESCO``."""
    if nets is not None:
        path = Path(nets).expanduser().resolve()
        if not path.is_dir():
            raise InputError("--nets", "nets", nets, "is not a folder")
        return path
    spec = importlib.util.find_spec("sumo_rl")
    if spec is None or spec.origin is None:
        raise InputError("--nets", "nets", None, "sumo-rl is not installed: pip install \".[benchmarks]\", "
                         "or give --nets DIR (the folder holding cologne1/cologne1.sumocfg ...)")
    return Path(spec.origin).parent / "nets" / "RESCO"


def _names(scenarios: str) -> list[str]:
    names = [n.strip() for n in scenarios.split(",") if n.strip()]
    for name in names:
        if name not in RESCO_SCENARIOS:
            raise InputError("--scenarios", "scenarios", name, f"must be among {', '.join(RESCO_SCENARIOS)}")
    if not names:
        raise InputError("--scenarios", "scenarios", scenarios, "names no scenario")
    return names


def write_scenarios(names: list[str], nets: Path, window: str, folder: Path) -> list[Path]:
    """One scenario file per RESCO scenario in ``folder``; an InputError if a sumocfg is missing."""
    if window not in WINDOWS:
        raise InputError("--window", "window", window, f"must be one of {', '.join(WINDOWS)}")
    cfgs = [nets / name / f"{name}.sumocfg" for name in names]
    for cfg in cfgs:
        if not cfg.is_file():
            raise InputError("--nets", "nets", str(nets), f"has no {cfg.relative_to(nets)}")
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, cfg in zip(names, cfgs):
        duration = "" if WINDOWS[window] is None else f"duration = {WINDOWS[window]:g}\n"
        text = SCENARIO_TEMPLATE.format(name=name, duration=duration, drain=DRAIN, sumocfg=cfg)
        path = folder / f"{name}.toml"
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
        paths.append(path)
    return paths


def run_benchmark(scenarios: str, controllers: str, seeds: str, window: str, out: str | Path,
                  nets: str | None = None, **executor) -> CompareOutcome:
    """Write the scenario files, run the comparison into ``out``, write benchmark.md and its figure."""
    out = Path(out)
    names = _names(scenarios)
    try:  # checked before anything is written
        parse_controllers(controllers)
    except InputError as exc:
        raise InputError("--controllers", "controllers", controllers, exc.problem) from None
    parse_seeds(seeds)
    if out.exists() and not out.is_dir():
        raise InputError("--out", "out", str(out), "is a file, not a folder")
    files = write_scenarios(names, resco_nets(nets), window, out / "scenarios")
    specs = make_specs(files, controllers, seeds)
    outcome = run_compare(specs, out, **executor)
    write_benchmark(out, outcome.table, window, resco_delays(specs, out))
    return outcome


def run_resco_delay(run: Path) -> float:
    """[s] RESCO's delay of one finished run (results/resco_delay.py), its window's end from the
    run's resolved settings."""
    settings = json.loads((run / RUN_MARKER).read_text())["settings"]["scenario"]
    end = float(settings["begin"]) + float(settings["duration"])  # [s]
    return resco_delay(run / "tripinfo.xml", sorted(run.glob("demand*.rou.xml")), end)


def resco_delays(specs: list[SweepSpec], out: Path) -> pd.DataFrame:
    """RESCO's delay [s] by scenario (rows) and controller (columns), mean over the finished seeds."""
    rows = [{"scenario": spec.scenario_name, "controller": job.controller,
             "resco_delay": run_resco_delay(Path(job.run_dir))}
            for spec in specs for job in sweep_jobs(spec, out / spec.scenario_name)
            if (Path(job.run_dir) / RUN_MARKER).is_file()]
    table = pd.DataFrame(rows, columns=["scenario", "controller", "resco_delay"])
    return table.pivot_table(index="scenario", columns="controller", values="resco_delay", aggfunc="mean")


def published_table(ours: pd.DataFrame) -> pd.DataFrame:
    """Ours beside RESCO's published delays [s] (experiments/resco_published.py), per scenario, for
    the signal baselines both ran."""
    rows = []
    for scenario in ours.index:
        row = {"scenario": scenario}
        for controller, (value, _) in RESCO_PUBLISHED.get(scenario, {}).items():
            if controller in ours.columns:
                row[f"{controller} (ours)"] = round(float(ours.loc[scenario, controller]), 1)
                row[f"{controller} (RESCO)"] = value
        rows.append(row)
    return pd.DataFrame(rows).dropna(axis=1, how="all")


BENCHMARK_COLUMNS = {"time_loss_mean": "average delay [s]", "travel_time_mean": "travel time [s]",
                     "throughput_veh_h": "throughput [veh/h]", "queue_p95_max": "largest p95 queue [m]",
                     "fuel_g_per_trip": "fuel [g/trip]", "collisions": "collisions (SUMO)",
                     "not_inserted": "never inserted", "arrived": "arrived", "vehicles": "vehicles"}


def write_benchmark(out: Path, table: pd.DataFrame, window: str, resco: pd.DataFrame) -> Path:
    """benchmark.md: the average delay, scenario by controller; RESCO's delay beside RESCO's
    published one; then every measure per run."""
    delay = table.pivot(index="scenario", columns="controller", values="time_loss_mean")
    # the figure shows RESCO's measure: it charges the backlog, so a jammed run cannot look good
    figure = grouped_bars(resco, "RESCO's average delay [s]\n(time loss + insertion delay, backlog)",
                          out / BENCHMARK_FIGURE)
    lines = [f"# RESCO benchmark (window: {window})", "",
             "Average delay: SUMO's tripinfo timeLoss averaged over the arrived trips "
             "(over the seeds). Vehicles never inserted or not arrived are counted beside it: a jammed "
             "controller cannot look better than it is.", "",
             markdown_table(delay.reset_index()), "", "## RESCO's measure, beside RESCO's published results", "",
             "RESCO's own delay (results/resco_delay.py: timeLoss plus insertion delay of the trips "
             "arrived by the window's end, and the wait of the vehicles never inserted), scenario by "
             "controller:", "", markdown_table(resco.reset_index()), ""]
    if window == "full" and len(published := published_table(resco)) and len(published.columns) > 1:
        lines += [f"Beside RESCO's published values ({RESCO_SOURCE}). Their runs stepped SUMO 1.9 at "
                  "1 s; ours step at the scenario's step length, so equal values are not expected: "
                  "the comparison says whether the orderings hold.", "", markdown_table(published), ""]
    lines += ["## Every measure", ""]
    measures = table[["scenario", "controller", *BENCHMARK_COLUMNS]].rename(columns=BENCHMARK_COLUMNS)
    lines += [markdown_table(measures), "",
              f"![resco_delay]({Path(figure).relative_to(out).as_posix()})", ""]
    path = out / BENCHMARK_FILE
    path.write_text("\n".join(lines))
    return path
