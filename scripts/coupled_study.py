"""The coupled-game study: pairwise against coupled games, Nash and Stackelberg, written to
docs/coupled-game.md with its figure of cluster sizes per demand level.

Plays the paper's Case 1 A-D and Case 2 A-B under nash, nash-coupled, stackelberg and
stackelberg-coupled (one CLI process per run, a 2000 ms step budget that no step comes near, the
coupled runs with every converged cluster game checked), and reads (or, with ``--run-demand``,
runs) ``intersection-cosim compare`` of the demand scenarios under the same four controllers.
Every number on the page comes from these runs; the page records the commands, the commit and
the date.

    python scripts/coupled_study.py --out study [--levels medium,high] [--seeds 1-5] [--run-demand]

Rerunning reuses finished case runs (their summary.json) and the compare folders' finished runs.
"""

from __future__ import annotations

import argparse
import datetime
import json
import shlex
import subprocess
import sys
import tomllib
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from intersection_cosim.report.reporting import markdown_table  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "coupled-game.md"
FIGURE = ROOT / "docs" / "figures" / "coupled_cluster_sizes.png"
CASES = ["case1_A", "case1_B", "case1_C", "case1_D", "case2_A", "case2_B"]
CONTROLLERS = ["nash", "nash-coupled", "stackelberg", "stackelberg-coupled"]
CASE_BUDGET_MS = 2000.0  # [ms] never binds: the case runs test decisions, not the machine's load
DEMAND_BUDGET_MS = 20.0  # [ms] the demand runs' step budget


def sh(cmd: list[str]) -> str:
    return shlex.join(str(c) for c in cmd)


def case_scenario(out: Path, case: str, ctrl: str) -> Path:
    """The case's scenario file; for a coupled controller a copy with the cluster check on."""
    src = ROOT / "scenarios" / f"{case}.toml"
    if not ctrl.endswith("-coupled"):
        return src
    data = tomllib.loads(src.read_text())
    if "policy" in data.get("controller", {}):
        raise SystemExit(f"coupled_study: {src}: has a [controller.policy] table; add cluster_check by hand")
    dst = out / "scenarios" / f"{case}.toml"
    dst.parent.mkdir(parents=True, exist_ok=True)
    dst.write_text(src.read_text() + "\n[controller.policy]\ncluster_check = true\n")
    return dst


def play_cases(out: Path) -> list[str]:
    """Run every case x controller not yet finished; returns the commands."""
    cmds = []
    for case in CASES:
        for ctrl in CONTROLLERS:
            run_dir = out / "cases" / f"{case}-{ctrl}"
            cmd = [sys.executable, "-m", "intersection_cosim", "run", case_scenario(out, case, ctrl), "--controller",
                   ctrl, "--budget-ms", f"{CASE_BUDGET_MS:g}", "--out", run_dir, "--force"]
            cmds.append("python " + sh(cmd[1:]))
            if (run_dir / "summary.json").is_file():
                continue
            proc = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, cwd=ROOT)
            print(f"{case} {ctrl}: {proc.stdout.strip() or proc.stderr.strip()[-300:]}", flush=True)
    return cmds


def demand_command(out: Path, level: str, seeds: str, work_clock_ms: float | None = None) -> list[str]:
    """The compare of one demand level; with ``work_clock_ms`` the budget is kept by the work clock
    (each QP costs that many ms: deadline misses independent of the machine's load), into
    ``compare_<level>_wc``."""
    wc = [] if work_clock_ms is None else ["--work-clock", f"{work_clock_ms:g}"]
    folder = out / (f"compare_{level}" + ("" if work_clock_ms is None else "_wc"))
    return [sys.executable, "-m", "intersection_cosim", "compare", f"scenarios/demand_balanced_{level}.toml",
            "--controllers", ",".join(CONTROLLERS), "--seeds", seeds, "--budget-ms", f"{DEMAND_BUDGET_MS:g}", *wc,
            "--workers", "1", "--no-progress", "--out", folder]


# ---------------------------------------------------------------- the cases
def entry_order(traj: pd.DataFrame) -> str:
    """The vehicles in the order they entered the junction (first row on an internal lane)."""
    inside = traj[traj["lane"].astype(str).str.startswith(":")]
    first = inside.groupby("vehicle")["time"].min().sort_values()
    return " < ".join(first.index)


def case_rows(out: Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per case x controller: entry order, travel time, time loss, compute, clusters; and per pair
    its min TTC and PET."""
    rows, pair_rows = [], []
    for case in CASES:
        for ctrl in CONTROLLERS:
            d = out / "cases" / f"{case}-{ctrl}"
            if not (d / "summary.json").is_file():
                continue
            summary = json.loads((d / "summary.json").read_text())
            traj = pd.read_csv(d / "trajectories.csv", dtype={"vehicle": str})
            veh = pd.read_csv(d / "vehicles.csv", dtype={"vehicle": str})
            steps = pd.read_csv(d / "steps.csv")
            games = pd.read_csv(d / "games.csv", dtype={"vehicle_a": str, "vehicle_b": str})
            clusters = games.dropna(subset=["cluster"]).drop_duplicates("time") if "cluster" in games else games.iloc[:0]
            conv = clusters[clusters["status"] == "converged"] if len(clusters) else clusters
            rows.append({"case": case, "controller": ctrl, "entry order": entry_order(traj),
                         "travel time mean [s]": veh["travel_time"].mean(), "time loss mean [s]": veh["time_loss"].mean(),
                         "collisions": summary["counts"]["collisions"],
                         "arrived": f"{summary['counts']['arrived']}/{summary['counts']['vehicles']}",
                         "compute median [ms]": steps["compute_ms"].median(),
                         "compute p95 [ms]": steps["compute_ms"].quantile(0.95),
                         "cluster steps": len(clusters),
                         "checked (pass/all)": f"{int((conv['check'] == 'pass').sum())}/{len(conv)}" if len(clusters) else "-"})
            pairs = pd.read_csv(d / "pairs.csv", dtype={"vehicle_a": str, "vehicle_b": str})
            for _, p in pairs.iterrows():
                pair_rows.append({"case": case, "controller": ctrl, "pair": f"{p['vehicle_a']}-{p['vehicle_b']}",
                                  "min TTC [s]": p["min_ttc"], "PET [s]": p["pet"]})
    return pd.DataFrame(rows), pd.DataFrame(pair_rows)


# ---------------------------------------------------------------- the demand levels
def demand_tables(out: Path, levels: list[str]) -> tuple[pd.DataFrame, dict]:
    """comparison.csv of each level's compare folder with the QPs solved per control step (the
    work, independent of the machine's load: median, 95th percentile), and the cluster sizes met
    per level and coupled controller (a pair game counts as size 2)."""
    frames, sizes = [], {}
    for level in levels:
        folder = out / f"compare_{level}"
        if not (folder / "comparison.csv").is_file():
            continue
        table = pd.read_csv(folder / "comparison.csv").assign(level=level)
        qps: dict[str, list] = {}
        for summary in sorted(folder.glob("*/runs/*/summary.json")):
            ctrl = json.loads(summary.read_text())["controller"]
            steps = pd.read_csv(summary.parent / "steps.csv")
            qps.setdefault(ctrl, []).append(steps.groupby("time")["qp_solves"].sum())
        for q in (0.5, 0.95):
            table[f"qp_per_step_{'median' if q == 0.5 else 'p95'}"] = [
                pd.concat(qps[c]).quantile(q) if c in qps else np.nan for c in table["controller"]]
        frames.append(table)
        for summary in sorted(folder.glob("*/runs/*/summary.json")):
            ctrl = json.loads(summary.read_text())["controller"]
            if not ctrl.endswith("-coupled"):
                continue
            games = pd.read_csv(summary.parent / "games.csv", dtype={"vehicle_a": str, "vehicle_b": str})
            if "cluster" not in games:  # no cluster was met: every game a pair's
                games = games.assign(cluster=np.nan, size=np.nan)
            pairs = games[games["cluster"].isna()]
            clus = games.dropna(subset=["cluster"]).drop_duplicates(["time", "cluster"])
            counts = sizes.setdefault((level, ctrl), {})
            counts[2] = counts.get(2, 0) + len(pairs)
            for s, n in clus["size"].astype(int).value_counts().items():
                counts[int(s)] = counts.get(int(s), 0) + int(n)
    return (pd.concat(frames) if frames else pd.DataFrame()), sizes


def differences(table: pd.DataFrame) -> pd.DataFrame:
    """Coupled minus pairwise, per level and equilibrium."""
    rows = []
    cols = ["travel_time_mean", "time_loss_mean", "ssm_min_ttc", "ssm_min_pet", "ssm_share_under_thresholds",
            "compute_ms_median", "compute_ms_p95", "qp_per_step_median", "qp_per_step_p95", "deadline_miss_share"]
    for level, t in table.groupby("level", sort=False):
        t = t.set_index("controller")
        for eq in ("nash", "stackelberg"):
            if eq in t.index and f"{eq}-coupled" in t.index:
                rows.append({"level": level, "equilibrium": eq,
                             **{f"d {c}": t.loc[f"{eq}-coupled", c] - t.loc[eq, c] for c in cols}})
    return pd.DataFrame(rows)


def size_figure(sizes: dict, path: Path) -> Path:
    """Bars: how many games of each size were played, per demand level and coupled controller."""
    keys = sorted(sizes)
    all_sizes = sorted({s for c in sizes.values() for s in c})
    fig, ax = plt.subplots(figsize=(7, 3.6))
    width = 0.8 / max(len(keys), 1)
    for m, key in enumerate(keys):
        counts = [sizes[key].get(s, 0) for s in all_sizes]
        ax.bar(np.arange(len(all_sizes)) + m * width, counts, width, label=f"{key[0]}, {key[1]}")
    ax.set_xticks(np.arange(len(all_sizes)) + 0.4 - width / 2, [str(s) for s in all_sizes])
    ax.set_yscale("log")
    ax.set_xlabel("players in the game (2: a pair outside any cluster)")
    ax.set_ylabel("games solved or kept, all seeds")
    ax.set_title("Game sizes met per demand level (coupled controllers)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


# ---------------------------------------------------------------- the page
def provenance(argv: list[str]) -> list[str]:
    commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, cwd=ROOT).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True, text=True,
                           cwd=ROOT).stdout.strip()
    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return [f"- command: `python scripts/coupled_study.py {sh(argv)}`",
            f"- commit: `{commit}`" + (" (with uncommitted changes)" if dirty else ""), f"- date: {date}"]


def write_page(argv, case_cmds, demand_cmds, cases, pairs, table, diffs, figure, levels, missing) -> None:
    parts = ["# Coupled N-player games against the paper's pairwise games", "",
             "Generated by `scripts/coupled_study.py`; do not edit by hand.", "", *provenance(argv), "",
             "With `[controller.game] coupling = \"cluster\"` (or the controllers `nash-coupled` and "
             "`stackelberg-coupled`) every connected component of three or more vehicles in the graph of the "
             "triggered pairs plays one N-player game (`games/coupled.py`): each player's cost is the paper's J "
             "with J_lat summed over all its partners in the cluster; Nash by iterated best response over all "
             "players, Stackelberg as a hierarchy ordered by TCP. Pairs outside such a component play the "
             "pairwise game as before; the safety filter guards every decision either way. games.csv marks the "
             "pairs that played inside a cluster with the cluster's size, iterations, residual, status and, with "
             "`[controller.policy] cluster_check = true`, the N-player equilibrium check (unilateral deviations, "
             "sampled and by a best-response re-solve; 1 % relative tolerance).", "",
             "## The paper's cases", "",
             f"Each case under the four controllers, step budget {CASE_BUDGET_MS:g} ms (never binding); the coupled "
             "runs check every converged cluster game. Entry order: the order in which the vehicles entered the "
             "junction. Commands:", "", "```", *case_cmds, "```", ""]
    if len(cases):
        parts += [*order_notes(cases), "", markdown_table(cases), "", "Min TTC and PET per pair (ours, `pairs.csv`):", "",
                  markdown_table(pairs.pivot_table(index=["case", "pair"], columns="controller",
                                                   values=["min TTC [s]", "PET [s]"]).reset_index()
                                 .pipe(_flatten)), ""]
    parts += ["## Demand scenarios", "",
              f"`compare` of the balanced demand at each level, seeds as in the commands, step budget "
              f"{DEMAND_BUDGET_MS:g} ms, one run at a time on a machine shared with other work: the compute "
              "times and the deadline misses of the wall-clock runs depend on its load. A level named `<level>_wc` "
              "kept its budget by the work clock instead (`--work-clock`: every QP costs a fixed time), so its "
              "deadline misses depend on the work alone. Commands:", "", "```", *demand_cmds, "```", ""]
    if missing:
        parts += [f"Not run for this page (no finished compare folder): {', '.join(missing)}.", ""]
    if len(table):
        cols = ["level", "controller", "runs_ok", "vehicles", "arrived", "collisions", "late_or_stuck",
                "travel_time_mean", "time_loss_mean", "ssm_min_ttc", "ssm_min_pet", "ssm_share_under_thresholds",
                "compute_ms_median", "compute_ms_p95", "qp_per_step_median", "qp_per_step_p95", "deadline_misses",
                "deadline_miss_share"]
        parts += [markdown_table(table[[c for c in cols if c in table]]), "",
                  "Coupled minus pairwise (travel time and time loss [s], SSM margins [s], compute [ms], QPs per "
                  "step, deadline-miss share):", "",
                  markdown_table(diffs) if len(diffs) else "(no pair of runs to compare)", ""]
    if figure is not None:
        parts += ["## Cluster sizes", "", f"![cluster sizes]({figure.relative_to(PAGE.parent).as_posix()})", ""]
    PAGE.write_text("\n".join(parts))


def order_notes(cases: pd.DataFrame) -> list[str]:
    """One line per case and equilibrium: did coupling change who entered the junction first?"""
    out = []
    for (case, eq), _ in cases.assign(eq=cases["controller"].str.replace("-coupled", "")).groupby(["case", "eq"], sort=False):
        t = cases.set_index(["case", "controller"])
        if (case, eq) in t.index and (case, f"{eq}-coupled") in t.index:
            a, b = t.loc[(case, eq), "entry order"], t.loc[(case, f"{eq}-coupled"), "entry order"]
            out.append(f"- {case}, {eq}: entry order " + (f"unchanged ({a})" if a == b else f"{a} pairwise, {b} coupled"))
    return out


def _flatten(df: pd.DataFrame) -> pd.DataFrame:
    df.columns = [" ".join(str(x) for x in c if x) if isinstance(c, tuple) else c for c in df.columns]
    return df


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="study", help="folder of the runs (default: study)")
    ap.add_argument("--levels", default="medium,high", help="demand levels (default: medium,high)")
    ap.add_argument("--seeds", default="1-5", help="seeds of the demand runs (default: 1-5)")
    ap.add_argument("--run-demand", action="store_true", help="run (or finish) the compare of every level")
    ap.add_argument("--skip-cases", action="store_true", help="only read the case runs already there")
    ap.add_argument("--work-clock", type=float, default=None, metavar="MS",
                    help="also the demand compares on the work clock (MS per QP), seeds --wc-seeds")
    ap.add_argument("--wc-seeds", default="1", help="seeds of the work-clock compares (default: 1)")
    args = ap.parse_args(argv)
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    levels = [x for x in args.levels.split(",") if x]
    case_cmds = [] if args.skip_cases else play_cases(out)
    if args.skip_cases:
        case_cmds = ["(case runs read from an earlier call)"]
    demand_cmds, missing, found = [], [], []
    runs = [(level, level, args.seeds, None) for level in levels]
    if args.work_clock is not None:
        runs += [(level, f"{level}_wc", args.wc_seeds, args.work_clock) for level in levels]
    for level, name, seeds, wc in runs:
        cmd = demand_command(out, level, seeds, wc)
        demand_cmds.append("python " + sh(cmd[1:]))
        if args.run_demand:
            subprocess.run([str(c) for c in cmd], cwd=ROOT, check=False)
        (found if (out / f"compare_{name}" / "comparison.csv").is_file() else missing).append(name)
    cases, pairs = case_rows(out)
    table, sizes = demand_tables(out, found)
    figure = size_figure(sizes, FIGURE) if sizes else None
    write_page(argv, case_cmds, demand_cmds, cases, pairs, table, differences(table) if len(table) else table,
               figure, levels, missing)
    print(f"wrote {PAGE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
