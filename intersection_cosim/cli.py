"""Command-line entry point ``intersection-cosim``: thin; parsing and error reporting only.

Bad input is reported as one line on stderr with exit status 2 and no traceback.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from intersection_cosim import __version__
from intersection_cosim.errors import InputError


DESCRIPTION = """\
Co-simulation of autonomous vehicles at an intersection without traffic lights: Eclipse SUMO
(through libsumo) with the differential-game decisions of Hang et al. (aggressiveness kappa,
potential-field risk, event trigger, Nash and Stackelberg equilibria)."""

EXAMPLES = """\
examples:
  intersection-cosim run scenarios/case1_A.toml --out runs/case1_A
      play the paper's Case 1 A (Nash game unless --controller says otherwise; --gui: live in sumo-gui)
  intersection-cosim sweep scenarios/case1_A.toml --kappa V2=0.1:0.9:0.2 --out sweeps/V2
      one run per kappa value of V2 (add --controllers nash,stackelberg,sumo to compare)
  intersection-cosim compare scenarios/demand_balanced_low.toml --seeds 1-3 --out compare/low
      every controller over seeds under random demand: delay, safety, compute time
  intersection-cosim stress scenarios/demand_balanced_high.toml --runs 40 --duration 120 --out stress/high
      40 seeded variants of a scenario judged for collisions, locks and near misses (--search cem: adversarial);
      each failure becomes a scenario file in stress/high/failures/ that 'run' replays
  intersection-cosim report sweeps/V2
      figures and report.md of a run or sweep folder (a kappa sweep: kappa_tradeoff_<V>.png)
  intersection-cosim animate runs/case1_A
      a GIF of the run drawn from its outputs (runs/case1_A/animation.gif)
  intersection-cosim net --arms 3 --lanes 2 --out nets/t_junction
      build a net with netconvert: here a T-junction, two lanes a road (default: the paper's cross)
  intersection-cosim junctions '$SUMO_HOME/tools/game/cross/cross.net.xml'
      the intersections of any SUMO net and whether the controller can manage them (--all: every junction)

'intersection-cosim COMMAND --help' describes a command's options."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # argparse's own errors: one line, status 2
        self.exit(2, f"{self.prog}: error: {message}\n")

    def format_help(self) -> str:
        if callable(self.epilog):  # filled on demand (e.g. from the controller registry)
            self.epilog = self.epilog()
        return super().format_help()


def _controllers_epilog() -> str:
    """``run --help``'s list of the controllers, from the registry (imported only for help)."""
    from intersection_cosim.control import registry

    width = max(len(n) for n in registry.names())
    lines = [f"  {name:<{width}}  {registry.get(name).description}" for name in registry.names()]
    return "controllers (--controller or [controller] kind in the scenario file):\n" + "\n".join(lines)


def _number(kind: type, low: float, strict: bool):
    """An argparse type: ``kind`` (float or int) above ``low`` (``strict``) or at least ``low``;
    NaN is refused as out of range."""
    what = "a number" if kind is float else "an integer"

    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}") from None
        if not (value > low if strict else value >= low):
            raise argparse.ArgumentTypeError(f"{text!r} must be {'>' if strict else '>='} {low:g}")
        return value

    return parse


_positive_float = _number(float, 0.0, strict=True)
_non_negative_float = _number(float, 0.0, strict=False)
_positive_int = _number(int, 1, strict=False)
_non_negative_int = _number(int, 0, strict=False)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="intersection-cosim", description=DESCRIPTION, epilog=EXAMPLES,
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log warnings and progress")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)  # none given: main prints the help

    net = sub.add_parser("net", help="generate the intersection net with netconvert")
    net.add_argument("--arms", type=int, choices=(3, 4), default=4,
                     help="4 (default): the paper's cross; 3: a T-junction without the north arm "
                     "(south is the stem, east-west the through road)")
    net.add_argument("--lanes", type=int, choices=(1, 2, 3), default=3,
                     help="lanes on each road in and out (default 3, the paper's)")
    net.add_argument("--out", default="sumo_networks", help="output folder (default: sumo_networks)")
    net.add_argument("--junction-type", default="priority",
                     help="priority (default), allway_stop, traffic_light or right_before_left")
    net.add_argument("--approach-length", type=_positive_float, default=150.0,
                     help="[m] distance from the centre to each arm's end (default 150)")

    run = sub.add_parser("run", help="run one scenario in SUMO (headless, or live in sumo-gui with --gui)", epilog=_controllers_epilog,
                         formatter_class=argparse.RawDescriptionHelpFormatter)
    run.add_argument("scenario", help="scenario file (TOML)")
    run.add_argument("--controller", help="controller kind, one of the list below (overrides [controller] kind)")
    run.add_argument("--out", help="output folder (default: runs/<scenario>-<controller>-seed<N>); "
                     "a folder holding a finished run is refused unless --force")
    run.add_argument("--force", action="store_true", help="replace the finished run in --out")
    run.add_argument("--seed", type=int, help="random seed (overrides [scenario] seed)")
    run.add_argument("--budget-ms", type=_positive_float, help="[ms] wall-time budget per control step")
    run.add_argument("--work-clock", type=_positive_float, metavar="MS",
                     help="[ms] keep the budget by a work clock: each QP solve costs MS (the same run on any machine)")
    run.add_argument("--no-etm", action="store_true", help="play a game for every conflicting pair")
    run.add_argument("--realtime", action="store_true", help="pace the simulation to the wall clock")
    run.add_argument("--gui", action="store_true",
                     help="show the run live in sumo-gui (through TraCI); the outputs are the same")
    run.add_argument("--quiet", action="store_true", help="do not print SUMO's first warnings (they stay in sumo.log)")
    run.add_argument("--gui-delay", type=_non_negative_float, default=50.0, metavar="MS",
                     help="[ms] sumo-gui's pause per SUMO step with --gui (default 50: about real time)")

    _add_set_option(run)
    _add_sweep(sub)
    _add_compare(sub)
    _add_benchmark(sub)
    _add_stress(sub)
    report = sub.add_parser("report", help="figures and report.md of a run or a sweep folder (compare writes its own)")
    report.add_argument("folder", help="a run folder (holds summary.json) or a sweep folder (holds sweep.json)")
    _add_animate(sub)
    _add_junctions(sub)
    return parser


def _add_sweep(sub) -> None:
    sweep = sub.add_parser("sweep", help="run a scenario over a grid of kappa values, controllers and seeds")
    sweep.add_argument("scenario", help="scenario file (TOML)")
    sweep.add_argument("--kappa", action="append", metavar="VEHICLE=SPEC",
                       help="kappa values of one vehicle: a:b:step (b included), a,b,c or a; repeatable")
    sweep.add_argument("--controllers", "--controller", dest="controllers", metavar="K1,K2",
                       help="controller kinds, comma-separated, as in compare (default: the scenario's; "
                       "--controller is the old spelling)")
    sweep.add_argument("--seeds", help="seeds: 1-5, 1,3,7 or 1-3,7 (default: the scenario's)")
    sweep.add_argument("--out", required=True, help="sweep folder; rerunning the same command skips finished runs")
    _add_set_option(sweep)
    _add_axis_options(sweep)
    _add_executor_options(sweep)


def _add_compare(sub) -> None:
    compare = sub.add_parser("compare", help="compare controllers over seeds on one or more demand scenarios")
    compare.add_argument("scenario", nargs="+", help="scenario file(s) (TOML), e.g. one per demand level")
    compare.add_argument("--controllers", "--controller", dest="controllers", metavar="K1,K2", default="nash,stackelberg,fcfs,sumo-priority,sumo-allway-stop,sumo-tls",
                         help="controller kinds, comma-separated (default: %(default)s)")
    compare.add_argument("--seeds", default="1-5", help="seeds: 1-5, 1,3,7 or 1-3,7 (default: 1-5)")
    compare.add_argument("--duration", type=_positive_float, help="[s] override every scenario's demand window")
    compare.add_argument("--budget-ms", type=_positive_float,
                         help="[ms] override every run's time budget per control step")
    compare.add_argument("--work-clock", type=_positive_float, metavar="MS",
                         help="[ms] keep every run's budget by a work clock: each QP solve costs MS "
                         "(the same results on any machine and load)")
    compare.add_argument("--out", required=True, help="comparison folder; rerunning the same command skips "
                         "finished runs")
    _add_set_option(compare)
    _add_axis_options(compare)
    _add_executor_options(compare)


def _add_benchmark(sub) -> None:
    bench = sub.add_parser("benchmark", help="RESCO's real-demand scenarios under the chosen controllers")
    bench.add_argument("suite", choices=["resco"], help="the benchmark suite (resco: TAPAS Cologne, InTAS Ingolstadt)")
    bench.add_argument("--scenarios", default="cologne1,cologne3,cologne8,ingolstadt1,ingolstadt7,ingolstadt21,"
                       "arterial4x4,grid4x4", help="comma-separated (default: all eight)")
    bench.add_argument("--controllers", default="nash,stackelberg,fcfs,sumo-tls,sumo-actuated,max-pressure,sumo-priority",
                       help="controller kinds, comma-separated (default: %(default)s)")
    bench.add_argument("--seeds", default="1", help="seeds: 1-5, 1,3,7 or 1-3,7 (default: 1)")
    bench.add_argument("--window", choices=["full", "600"], default="full",
                       help="full: the sumocfg's begin to end (one hour); 600: its first 600 s (default: full)")
    bench.add_argument("--nets", help="folder of <name>/<name>.sumocfg (default: the installed sumo-rl's nets/RESCO)")
    bench.add_argument("--out", required=True, help="benchmark folder; rerunning the same command skips finished runs")
    _add_executor_options(bench)


def _cmd_benchmark(args) -> int:
    from intersection_cosim.experiments.benchmark import run_benchmark

    return _interruptible(lambda: run_benchmark(args.scenarios, args.controllers, args.seeds, args.window, args.out,
                                                args.nets, workers=args.workers, dask_scheduler=args.dask_scheduler,
                                                progress=not args.no_progress))


def _add_axis_options(parser) -> None:
    """One option per scenario axis (experiments/axes.py), e.g. ``--latency 0,0.1,0.2``."""
    from intersection_cosim.experiments.axes import AXES

    for axis in AXES.values():
        parser.add_argument(axis.flag, dest=f"axis_{axis.name}", metavar="A,B,...",
                            help=f"[{axis.unit}] values of {axis.field} (a comma-separated list): one run of "
                            "each per controller and seed")


def _axes(args) -> dict:
    from intersection_cosim.experiments.axes import AXES

    return {name: getattr(args, f"axis_{name}") for name in AXES}


def _add_executor_options(parser) -> None:
    """Where the runs of a sweep or comparison go: local processes or a Dask cluster."""
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--workers", type=_positive_int, help="parallel local runs (default: the number of CPUs)")
    where.add_argument("--dask-scheduler", metavar="ADDRESS", help="run on a Dask cluster, e.g. tcp://host:8786")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def _add_set_option(parser) -> None:
    parser.add_argument("--set", action="append", metavar="TABLE.KEY=VALUE", dest="sets",
                        help="set one scenario-file setting, e.g. controller.safety.time_gap=0.3 (repeatable; "
                        "checked like the file)")


def _add_stress(sub) -> None:
    stress = sub.add_parser("stress", help="search a scenario's variants for collisions, locks and near misses; "
                            "each failure becomes a scenario file that replays it")
    stress.add_argument("scenario", help="scenario file (TOML); its [stress] table sets the axes and ranges")
    stress.add_argument("--runs", type=_positive_int, required=True, help="how many runs (variants) to draw")
    stress.add_argument("--seed", type=_non_negative_int, default=0, help="the search's seed (default 0)")
    stress.add_argument("--duration", type=_positive_float, help="[s] every run's demand window (default: the scenario's)")
    stress.add_argument("--search", choices=("random", "cem"), default="random",
                        help="random: seeded uniform draws (default); cem: a cross-entropy search towards the "
                        "smallest margin")
    stress.add_argument("--out", help="stress folder (default: stress/<scenario name>); rerunning the same "
                        "command skips finished runs")
    stress.add_argument("--shrink", action=argparse.BooleanOptionalAction, default=True,
                        help="try shorter windows and fewer flows that still fail; keep the smallest (default: on)")
    _add_set_option(stress)
    _add_executor_options(stress)
    stress.add_argument("--dask", dest="dask_scheduler", metavar="ADDRESS", help=argparse.SUPPRESS)


def _add_animate(sub) -> None:
    animate = sub.add_parser("animate", help="a GIF or MP4 of a run, drawn from its run folder")
    animate.add_argument("run_dir", help="a run folder (holds summary.json)")
    animate.add_argument("--out", help="FILE.gif or FILE.mp4 (MP4 needs ffmpeg; default: RUN_DIR/animation.gif)")
    animate.add_argument("--fps", type=_positive_float, default=10.0,
                         help="[1/s] frames per second; one frame per 0.1 s of simulation (default 10: real time)")


def _add_junctions(sub) -> None:
    junctions = sub.add_parser("junctions", help="list the junctions of a SUMO net and whether they can be managed")
    junctions.add_argument("net", help="a SUMO net file (.net.xml); $SUMO_HOME in it is expanded")
    junctions.add_argument("--all", action="store_true",
                           help="every junction, not only intersections (3 or more arms, or a traffic light)")


def _cmd_junctions(args) -> int:
    import pandas as pd

    from intersection_cosim.network.junction_net import junction_table
    from intersection_cosim.scenario.network import resolve_path

    table = junction_table(resolve_path("junctions", "net", args.net, Path.cwd()), all_junctions=args.all)
    with pd.option_context("display.max_rows", None, "display.max_columns", None, "display.width", 200):
        print(table.to_string(index=False) if len(table) else "no junctions")
    return 0


def _cmd_net(args) -> int:
    from intersection_cosim.network.build import build_network
    from intersection_cosim.network.spec import IntersectionSpec

    net = build_network(args.out, IntersectionSpec(junction_type=args.junction_type,
                                                   approach_length=args.approach_length,
                                                   arms=args.arms, lanes_per_road=args.lanes))
    print(net)
    return 0


def _cmd_run(args) -> int:
    from intersection_cosim.experiments.run import run_scenario
    from intersection_cosim.scenario import with_overrides
    from intersection_cosim.scenario.set_option import load_with_sets

    scn = load_with_sets(args.scenario, args.sets)
    scn = with_overrides(scn, controller=args.controller, seed=args.seed, budget_ms=args.budget_ms,
                         work_clock_ms=args.work_clock, etm=False if args.no_etm else None, realtime=True if args.realtime else None)
    out = Path(args.out) if args.out else Path("runs") / f"{scn.scenario.name}-{scn.controller.kind}-seed{scn.scenario.seed}"
    gui = None
    if args.gui:
        from intersection_cosim.sim.gui import GuiSettings

        gui = GuiSettings(delay_ms=args.gui_delay)
    summary = run_scenario(scn, out, force=args.force, gui=gui)
    c = summary["counts"]
    k = summary["collisions"]
    print(f"{out}: {c['arrived']}/{c['vehicles']} vehicles arrived ({c['departed']} inserted, "
          f"{c['not_inserted']} never inserted, {c['never_arrived']} inserted but not arrived), "
          f"{c['collisions']} collisions "
          f"({k['sumo_pairs_commanded']} pairs with a controlled vehicle, {k['sumo_pairs_uncommanded']} without; "
          f"our overlap check: {k['overlap_pairs_commanded']} / {k['overlap_pairs'] - k['overlap_pairs_commanded']}), "
          f"mean travel time {summary['metrics']['mean_travel_time'] or float('nan'):.2f} s")
    warned = summary.get("sumo_warnings") or {}
    if warned.get("warnings") and not args.quiet:
        kinds = len(warned["by_kind"])
        print(f"{out}: SUMO warned {warned['warnings']} times ({kinds} kinds, every one in {out / 'sumo.log'}); first:")
        print("\n".join(f"  {line}" for line in warned["first"]))
    if (end := summary.get("ended_early")) is not None:
        why = (f"all {end['vehicles']} vehicles in the network stood still from t={end['since']:.1f} s (a deadlock)"
               if end["reason"] == "deadlock" else f"the run held {end['peak_gb']:.1f} GB (scenario.memory_limit)")
        print(f"{out}: ended early at t={end['time']:.1f} s: {why}")
    return 0


def _interruptible(start) -> int:
    """Run a sweep-like job; exit 130 with one line on Ctrl-C, 1 if any run failed."""
    from intersection_cosim.experiments.sweep import SweepInterrupted

    try:
        outcome = start()
    except SweepInterrupted as exc:
        print(f"intersection-cosim: interrupted: {exc}", file=sys.stderr)
        return 130
    print("\n".join(outcome.lines()) if hasattr(outcome, "lines") else outcome.line())
    return 1 if outcome.failed else 0


def _cmd_sweep(args) -> int:
    from intersection_cosim.experiments.sweep import make_spec, run_sweep

    spec = make_spec(args.scenario, args.kappa, args.controllers, args.seeds, axes=_axes(args), sets=args.sets)
    return _interruptible(lambda: run_sweep(spec, args.out, workers=args.workers,
                                            dask_scheduler=args.dask_scheduler, progress=not args.no_progress))


def _cmd_compare(args) -> int:
    from intersection_cosim.experiments.compare import make_specs, run_compare

    specs = make_specs(args.scenario, args.controllers, args.seeds, args.duration, args.budget_ms, axes=_axes(args),
                       work_clock_ms=args.work_clock, sets=args.sets)
    return _interruptible(lambda: run_compare(specs, args.out, workers=args.workers,
                                              dask_scheduler=args.dask_scheduler, progress=not args.no_progress))


def _cmd_stress(args) -> int:
    from intersection_cosim.experiments.stress.runner import run_stress
    from intersection_cosim.experiments.stress.spec import prepare

    prep = prepare(args.scenario, args.runs, args.seed, args.search, args.duration, args.sets)
    out = args.out or str(Path("stress") / prep.spec.scenario_name)
    command = " ".join(["intersection-cosim", *sys.argv[1:]]) if sys.argv[1:2] == ["stress"] else "stress"
    return _interruptible(lambda: run_stress(prep, out, workers=args.workers, dask_scheduler=args.dask_scheduler,
                                             progress=not args.no_progress, shrink=args.shrink, command=command))


def _cmd_report(args) -> int:
    from intersection_cosim.report.reporting import write_report

    print(write_report(args.folder))
    return 0


def _cmd_animate(args) -> int:
    from intersection_cosim.report.animation import AnimationSettings, animate

    print(animate(args.run_dir, args.out, AnimationSettings(fps=args.fps)))
    return 0


COMMANDS = {"net": _cmd_net, "run": _cmd_run, "sweep": _cmd_sweep, "compare": _cmd_compare, "benchmark": _cmd_benchmark,
            "stress": _cmd_stress, "report": _cmd_report, "animate": _cmd_animate, "junctions": _cmd_junctions}


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:  # a bare command: what it can do, not an error line
        parser.print_help()
        return 0
    logging.basicConfig(level=logging.INFO if args.verbose else logging.ERROR,
                        format="%(levelname)s %(name)s: %(message)s")
    try:
        return COMMANDS[args.command](args)
    except InputError as exc:
        print(f"intersection-cosim: error: {exc.one_line()}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("intersection-cosim: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
