"""Write the documentation's results pages (docs/results/*.md) by running the shipped benchmarks.

Each page runs its benchmark commands (the paper's cases through scripts/reproduce_paper.py, the
demand, net, grid, people, mixed-traffic and V2X scenarios through ``intersection-cosim
compare``), then embeds the report each command writes (its tables, its figures copied next to the
page) under a provenance block: the command, the commit, the date and the machine. No number on
a results page is typed by hand; rerun this script to refresh them.

    python scripts/results.py                 # every page, the full benchmarks (hours on 2 cores)
    python scripts/results.py --quick         # every page, a small version of each (minutes)
    python scripts/results.py --pages demand,v2x --work build/results
"""

from __future__ import annotations

import argparse
import datetime as dt
import importlib.metadata
import os
import platform
import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs" / "results"
COSIM = "intersection-cosim"
PROVENANCE = "**Provenance.**"  # the first words of every page's provenance block
PROVENANCE_FIELDS = ("command", "benchmark", "commit", "date", "machine")


@dataclass(frozen=True)
class Page:
    """One results page: what it shows and the benchmark commands that make it."""

    name: str  # file name without .md
    title: str
    about: str  # one paragraph: what the benchmark runs and what to read in it
    full: tuple[str, ...]  # commands ({out} is the command's output folder), full mode
    quick: tuple[str, ...]  # the same, small enough for CI


def _compare(scenarios: str, controllers: str, extra: str = "") -> str:
    files = " ".join(f"scenarios/{s}.toml" for s in scenarios.split())
    return f"{COSIM} compare {files} --controllers {controllers} {extra} --out {{out}} --no-progress".replace("  ", " ")


QUICK = "--seeds 1 --duration 30 --budget-ms 20 --workers 1"
PAGES = (
    Page("paper-cases", "The paper's cases",
         "Case 1 A-D and Case 2 A-B of Hang et al. under the Nash and Stackelberg controllers, each with and "
         "without the event trigger: the paper's Tables II and IV beside ours, the orderings of its Section V "
         "and whether each holds, travel times, trajectories, speeds, convergence and compute time.",
         ("python scripts/reproduce_paper.py --out {out} --workers 2",),
         ("python scripts/reproduce_paper.py --out {out} --workers 1 --quick",)),
    Page("demand", "Controllers under demand",
         "The generated four-arm intersection at 600, 1200 and 1800 veh/h (balanced, and 60 % on one axis), "
         "every controller over five seeds with the 20 ms step budget of a hardware-in-the-loop box: delay, "
         "SUMO's surrogate safety measures, collisions and compute time per control step.",
         (_compare("demand_balanced_low demand_balanced_medium demand_balanced_high demand_unbalanced_low "
                   "demand_unbalanced_medium demand_unbalanced_high",
                   "nash,stackelberg,fcfs,sumo-priority,sumo-allway-stop,sumo-tls",
                   "--seeds 1-5 --budget-ms 20 --workers 2"),),
         (_compare("demand_balanced_low", "nash,sumo-priority", QUICK),)),
    Page("nets", "Other intersections",
         "The shipped net-file scenarios: a T-junction, a two-lane cross, SUMO's cross example and the RiLSA "
         "intersection against its own signal programme, at three demand levels each.",
         (_compare("tjunction_low tjunction_medium tjunction_high cross2_low cross2_medium cross2_high "
                   "cross_low cross_medium cross_high rilsa_low rilsa_medium rilsa_high",
                   "nash,stackelberg,fcfs,sumo-priority,sumo-tls", "--seeds 1-3 --budget-ms 20 --workers 2"),),
         (_compare("tjunction_low", "nash,sumo-priority", QUICK),)),
    Page("pedestrians", "Pedestrians at the crossings",
         "Braunschweig's junction 38 with people walking over its zebra crossings at three demand levels: "
         "people hit, collisions and delay under the game controllers and SUMO's own right of way.",
         (_compare("fokr38_pedestrians_low fokr38_pedestrians_medium fokr38_pedestrians_high",
                   "nash,stackelberg,sumo-priority", "--seeds 1-3 --budget-ms 20 --workers 2"),),
         (_compare("fokr38_pedestrians_low", "nash,sumo-priority", QUICK),)),
    Page("grids", "Grids and corridors",
         "One controller per junction on a grid and a corridor, against coordinated signals and priority "
         "junctions.",
         (_compare("grid_low grid_medium grid_high corridor_low corridor_medium corridor_high",
                   "nash,stackelberg,fcfs,sumo-tls,sumo-priority", "--seeds 1-5 --duration 300 --budget-ms 20 --workers 2"),),
         (_compare("corridor_low", "nash,sumo-tls", QUICK),)),
    Page("mixed", "Mixed traffic and vehicle types",
         "AVs among human drivers at 1200 veh/h, the share of AVs from none to all, and a mix of cars, buses "
         "and trucks.",
         (_compare("demand_balanced_medium", "nash,stackelberg,sumo-priority",
                   "--seeds 1-5 --av-share 0,0.5,0.9,1 --budget-ms 20 --workers 2"),
          _compare("demand_vtypes_medium", "nash,stackelberg,sumo-priority", "--seeds 1-5 --budget-ms 20 --workers 2")),
         (_compare("demand_mixed_medium", "nash", QUICK + " --av-share 0.5,1"),)),
    Page("v2x", "Imperfect V2X",
         "The game controller at 1200 veh/h over a link with latency and message loss, and one vehicle "
         "spoofing its position with the plausibility check on and off.",
         (_compare("demand_balanced_medium", "nash",
                   "--seeds 1-5 --latency 0,0.1,0.2,0.3,0.5 --loss 0,0.1,0.2,0.3 --budget-ms 20 --workers 2"),
          _compare("demand_balanced_medium_attack demand_balanced_medium_attack_unchecked", "nash",
                   "--seeds 42 --workers 2")),
         (_compare("demand_balanced_low", "nash", QUICK + " --latency 0,0.2 --loss 0.2"),)),
    Page("speed", "Speed",
         "What the game controller costs against SUMO alone: the shipped grid (nine junctions) and corridor "
         "(three) under Nash and under SUMO's own drivers, wall-time ratios, the controller's step and the "
         "junction-steps skipped; and the single junction's step against its vehicle count, as a multiple "
         "of SUMO's bare step in the same runs.",
         ("python scripts/bench_network.py --report {out}", "python scripts/bench_scale.py --no-ssm --report {out}"),
         ("python scripts/bench_network.py scenarios/corridor_low.toml --duration 20 --drain 0 --report {out}",
          "python scripts/bench_scale.py --no-ssm --duration 35 --warmup 25 --max-noetm-s 10 --report {out}")),
)


def git(*args: str) -> str:
    try:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def machine() -> str:
    """The machine a benchmark ran on, in one line (no host name)."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        sumo_version = importlib.metadata.version("eclipse-sumo")
    except importlib.metadata.PackageNotFoundError:
        sumo_version = "?"
    return (f"{platform.system()} {platform.machine()}, {cpu}, {os.cpu_count()} cores, "
            f"Python {platform.python_version()}, SUMO {sumo_version}")


def provenance(command: str, benchmarks: list[str], commit: str, date: str, where: str) -> str:
    """The block every results page starts with."""
    lines = [f"> {PROVENANCE} Generated by a script; do not edit by hand.", ">",
             f"> - command: `{command}`"]
    lines += [f"> - benchmark: `{b}`" for b in benchmarks]
    lines += [f"> - commit: `{commit}`", f"> - date: {date}", f"> - machine: {where}"]
    return "\n".join(lines)


def has_provenance(text: str) -> bool:
    """True when ``text`` carries a complete provenance block."""
    if PROVENANCE not in text:
        return False
    return all(re.search(rf"^> - {field}: \S", text, re.M) for field in PROVENANCE_FIELDS)


def embed_report(report: Path, figures_to: Path, page_dir: Path) -> str:
    """A benchmark's report.md, its headings demoted under the page's, its figures copied to
    ``figures_to`` and linked from there."""
    text = report.read_text()
    figures_to.mkdir(parents=True, exist_ok=True)

    def image(m: re.Match) -> str:
        src = report.parent / m.group(2)
        if not src.is_file():
            return f"*(figure {m.group(2)} was not written)*"
        dest = figures_to / src.name
        shutil.copyfile(src, dest)
        return f"![{m.group(1)}]({dest.relative_to(page_dir).as_posix()})"

    text = re.sub(r"!\[([^\]]*)\]\(([^)\s]+\.(?:png|gif|svg))\)", image, text)
    text = re.sub(r"(?<!!)\[([^\]]+)\]\((?!https?:|figures/)([^)\s]+)\)", r"\1 (`\2`)", text)  # links into the work folder
    return re.sub(r"^(#+) ", lambda m: "#" * min(len(m.group(1)) + 2, 6) + " ", text, flags=re.M)


def run_page(page: Page, quick: bool, work: Path, run=subprocess.run) -> list[tuple[str, Path]]:
    """Run a page's benchmark commands; (command as run, its report.md) each."""
    done = []
    for k, template in enumerate(page.quick if quick else page.full):
        out = work / page.name / str(k)
        command = template.format(out=out.relative_to(ROOT) if out.is_relative_to(ROOT) else out)
        argv = shlex.split(command)
        if argv[0] == "python":
            argv[0] = sys.executable
        elif argv[0] == COSIM:
            argv = [sys.executable, "-m", "intersection_cosim", *argv[1:]]
        print(f"[{page.name}] {command}", flush=True)
        shutil.rmtree(out, ignore_errors=True)  # every page from runs of this code, none reused
        result = run(argv, cwd=ROOT)
        if getattr(result, "returncode", 0) not in (0, 1):  # 1: some runs failed, the report says which
            raise SystemExit(f"{page.name}: `{command}` exited with status {result.returncode}")
        done.append((command, out / "report.md"))
    return done


def write_page(page: Page, done: list[tuple[str, Path]], header: dict[str, str]) -> Path:
    """docs/results/<page>.md from the reports of its benchmark commands."""
    path = DOCS / f"{page.name}.md"
    figures = DOCS / "figures" / page.name
    shutil.rmtree(figures, ignore_errors=True)
    parts = [f"# {page.title}", "",
             provenance(header["command"], [c for c, _ in done], header["commit"], header["date"], header["machine"]),
             "", page.about, ""]
    if "--quick" in header["command"]:
        parts += ["Written in quick mode: a small version of this benchmark (the commands below), for CI. "
                  "`python scripts/results.py` runs the full one.", ""]
    for command, report in done:
        parts += [f"## `{command}`", ""]
        parts.append(embed_report(report, figures, DOCS) if report.is_file()
                     else f"*(the command wrote no report: {report.name} missing)*")
        parts.append("")
    path.write_text("\n".join(parts).rstrip() + "\n")
    return path


def field_of(text: str, field: str) -> str:
    """The value of one field of a page's provenance block ("" if absent)."""
    m = re.search(rf"^> - {field}: (.*)$", text, re.M)
    return m.group(1).strip() if m else ""


def write_index(header: dict[str, str]) -> Path:
    """docs/results/index.md: every page with the command and date it was last written by."""
    lines = ["# Results", "", provenance(header["command"], [f"{p.name}.md" for p in PAGES], header["commit"],
                                         header["date"], header["machine"]), "",
             "Every page below is written by `python scripts/results.py` from the runs it makes (`--quick`: a "
             "small version of each benchmark, one seed and a short demand window); each page names the "
             "commands it ran, its commit, date and machine. Rerun the script to refresh them.", "",
             "| page | what it runs | written by | date |", "|---|---|---|---|"]
    for page in PAGES:
        path = DOCS / f"{page.name}.md"
        text = path.read_text() if path.is_file() else ""
        lines.append(f"| [{page.title}]({page.name}.md) | {page.about} | {field_of(text, 'command') or '(not yet)'} "
                     f"| {field_of(text, 'date') or '-'} |")
    path = DOCS / "index.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a small version of every benchmark (for CI)")
    ap.add_argument("--pages", default=",".join(p.name for p in PAGES),
                    help="comma-separated pages to write (default: all)")
    ap.add_argument("--work", default="build/results", help="folder for the benchmarks' outputs (default: build/results)")
    args = ap.parse_args(argv)
    wanted = args.pages.split(",")
    unknown = [name for name in wanted if name not in {p.name for p in PAGES}]
    if unknown:
        print(f"--pages: unknown page {unknown[0]!r} (known: {', '.join(p.name for p in PAGES)})", file=sys.stderr)
        return 2
    work = (ROOT / args.work).resolve()
    header = {"command": "python scripts/results.py" + (" --quick" if args.quick else "")
              + ("" if args.pages == ap.get_default("pages") else f" --pages {args.pages}"),
              "commit": git("rev-parse", "--short=12", "HEAD") + (" (with uncommitted changes)" if git("status", "--porcelain") else ""),
              "date": dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
              "machine": machine()}
    DOCS.mkdir(parents=True, exist_ok=True)
    for page in PAGES:
        if page.name in wanted:
            print(f"wrote {write_page(page, run_page(page, args.quick, work), header)}", flush=True)
    print(f"wrote {write_index(header)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
