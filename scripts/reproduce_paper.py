"""Reproduce the result tables and figures of Hang et al. (Section V) in one report folder.

Plays scenarios/case1_{A,B,C,D}.toml and case2_{A,B}.toml under the nash and stackelberg
controllers, each with the event trigger (ETM) on and off, one CLI process per run (libsumo holds one
simulation per process), then writes table_ii.csv, table_iv.csv (the paper's min TTC beside ours), ratios.csv (each
scenario's margins against A, the paper's and ours), travel_times.csv, orderings.csv,
figures/*.png and, last, report.md.

    python scripts/reproduce_paper.py --out report [--workers 2] [--quick] [--budget-ms 2000]

The runs test the controllers' decisions, not this machine's load: their control-step budget is
2000 ms by default, which no step comes near, so the report is the same on every machine (at
the scenarios' own 100 ms, a Stackelberg game of Case 2 A may stop at the anytime deadline on a
loaded machine, and the run then depends on the load by design). ``--budget-ms 100`` emulates
the HIL box.

Rerunning the same command reuses a finished run folder only when its summary.json records the
same resolved settings (scenario, controller with its budget and trigger, model, solver) and the
same intersection_cosim and SUMO versions as the run would have now; any other run is played again
(``run --force``), so a ``--budget-ms 100`` rerun into a 2000 ms folder reports 100 ms runs.
A bad ``--out`` (a file, a folder that cannot be written) is one line on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shlex
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from intersection_cosim.report import solver_figures  # noqa: E402
from intersection_cosim.report.reporting import markdown_table  # noqa: E402
from intersection_cosim.report.run_figures import trajectory_figure, velocity_figure  # noqa: E402
from intersection_cosim.report.solver_figures import draw_ecdf  # noqa: E402
from intersection_cosim.results.units import write_units  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ["case1_A", "case1_B", "case1_C", "case1_D", "case2_A", "case2_B"]
QUICK = ["case1_A", "case2_A"]
CONTROLLERS = {"nash": "NE", "stackelberg": "SE"}  # --coupled: COUPLED_CONTROLLERS
COUPLED_CONTROLLERS = {"nash-coupled": "NE", "stackelberg-coupled": "SE"}  # one N-player game per cluster
PAIRS = {"case1": ["V1-V2", "V1-V3"], "case2": ["V1-V2", "V1-V3", "V3-V4"]}
MIN_CUT = 0.40  # the ETM must cut the mean compute time per step by at least this
MIN_SKIP = 0.20  # ... where it leaves out at least this share of the games played without it (else n/a)
SSM_TABLE_COLUMNS = ("min_ttc", "pet", "min_ttc_ssm", "time_min_ttc_ssm", "pet_ssm")  # per pair, from pairs.csv
SE_SLACK = 0.2  # [s] Stackelberg min TTC may be this much below Nash's
BUDGET_MS = 2000.0  # [ms] default control-step budget of the paper runs (module docstring)
# [s] the paper's min TTC, Tables II and IV: (case, scenario, solver, pair) -> value
PAPER_TTC = {
    **{("case1", s, lab, pair): v for lab, row in (("NE", (3.71, 3.57, 43.62, 10.15, 5.37, 6.81, 0.70, 6.87)),
                                                 ("SE", (3.82, 3.87, 46.58, 10.60, 5.43, 6.85, 0.80, 7.15)))
       for (s, pair), v in zip([(s, p) for s in "ABCD" for p in ("V1-V2", "V1-V3")], row)},
    **{("case2", s, lab, pair): v for lab, row in (("NE", (2.53, 2.39, 30.39, 5.74, None, 18.42)),
                                                 ("SE", (3.93, 2.50, 30.39, 6.28, None, 19.04)))
       for (s, pair), v in zip([(s, p) for s in "AB" for p in ("V1-V2", "V1-V3", "V3-V4")], row)},
}


def run_name(case: str, ctrl: str, etm: bool) -> str:
    return f"{case}-{ctrl}-{'etm' if etm else 'noetm'}"


# ---------------------------------------------------------------- running
REUSE_VERSIONS = ("intersection_cosim", "sumo")  # a run folder made by other versions of these is rerun


def run_settings(case: str, ctrl: str, etm: bool, budget_ms: float) -> dict:
    """The resolved settings that :func:`play`'s ``run`` command records in summary.json."""
    from intersection_cosim.experiments.run_tables import resolved_settings
    from intersection_cosim.scenario import load_scenario, with_overrides

    scn = with_overrides(load_scenario(ROOT / "scenarios" / f"{case}.toml"), controller=ctrl, budget_ms=budget_ms,
                         etm=None if etm else False)
    return json.loads(json.dumps(resolved_settings(scn)))  # as read back from summary.json


def _flat(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        out.update(_flat(v, f"{prefix}{k}.") if isinstance(v, dict) else {f"{prefix}{k}": v})
    return out


def rerun_reason(run_dir: Path, settings: dict, versions: dict) -> str | None:
    """Why ``run_dir`` cannot stand for a run with ``settings`` under ``versions``; None: reuse it."""
    f = Path(run_dir) / "summary.json"
    if not f.is_file():
        return "no finished run"
    try:
        summary = json.loads(f.read_text())
        old = _flat(summary["settings"])
        made_by = summary.get("versions") or {}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return "unreadable summary.json"
    new = _flat(settings)
    differ = sorted(k for k in old.keys() | new.keys() if old.get(k, "(none)") != new.get(k, "(none)"))
    if differ:
        shown = ", ".join(f"{k} {old.get(k, '(none)')} -> {new.get(k, '(none)')}" for k in differ[:3])
        return f"settings differ: {shown}" + (f" and {len(differ) - 3} more" if len(differ) > 3 else "")
    for name in REUSE_VERSIONS:
        if made_by.get(name) != versions.get(name):
            return f"made by {name} {made_by.get(name)}, this is {versions.get(name)}"
    return None


def play(out: Path, case: str, ctrl: str, etm: bool, budget_ms: float, settings: dict,
         versions: dict) -> tuple[str, str, str | None]:
    """Run one simulation in a fresh process unless its folder holds the same run (``settings``,
    ``versions``) already; returns (name, what was done, error or None)."""
    name = run_name(case, ctrl, etm)
    run_dir = out / "runs" / name
    reason = rerun_reason(run_dir, settings, versions)
    if reason is None:
        return name, "reused (same settings and versions)", None
    finished = (run_dir / "summary.json").is_file()
    if run_dir.exists() and not finished:
        shutil.rmtree(run_dir)  # a partial folder from an interrupted run
    cmd = [sys.executable, "-m", "intersection_cosim", "run", str(ROOT / "scenarios" / f"{case}.toml"),
           "--controller", ctrl, "--budget-ms", f"{budget_ms:g}", "--out", str(run_dir)] + ([] if etm else ["--no-etm"])
    cmd += ["--force"] if finished else []  # replaced only once the new run has finished
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    log = out / "logs" / f"{name}.log"
    log.parent.mkdir(parents=True, exist_ok=True)
    log.write_text(f"$ {shlex.join(cmd)}\n--- stdout\n{proc.stdout}\n--- stderr\n{proc.stderr}")
    done = f"rerun ({reason})" if finished else "ran"
    if proc.returncode != 0 or not (run_dir / "summary.json").is_file():
        return name, done, f"exit code {proc.returncode} (see logs/{name}.log)"
    return name, done, None


def play_all(out: Path, cases: list[str], workers: int, budget_ms: float, progress: bool = True) -> dict[str, str]:
    """Play (or reuse) every run, with a progress bar and the time left on stderr (tqdm); returns the
    failed runs' errors by name."""
    from tqdm import tqdm

    from intersection_cosim.experiments.run_tables import versions

    jobs = [(c, k, e) for c in cases for k in CONTROLLERS for e in (True, False)]
    now = versions()
    settings = [run_settings(*j, budget_ms) for j in jobs]  # here: the registry's first use is not thread-safe
    failures = {}
    bar = tqdm(total=len(jobs), unit="run", desc="runs", file=sys.stderr, disable=not progress, dynamic_ncols=True)
    with bar, ThreadPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(play, out, *j, budget_ms, s, now) for j, s in zip(jobs, settings)]
        for fut in as_completed(futures):
            name, done, err = fut.result()
            bar.write(f"{name}: {done}" + ("" if err is None else f", FAILED {err}"), file=sys.stdout)
            bar.update()
            if err:
                failures[name] = err
    return dict(sorted(failures.items()))


def check_out(out: Path) -> str | None:
    """The problem with ``out`` as the report folder (None: usable); nothing is created."""
    if out.exists():
        if not out.is_dir():
            return "is a file, not a folder"
        return None if os.access(out, os.W_OK | os.X_OK) else "cannot be written (permission denied)"
    parent = out.parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        return f"cannot be made: {parent} is a file, not a folder"
    if not os.access(parent, os.W_OK | os.X_OK):
        return f"cannot be made: {parent} cannot be written (permission denied)"
    return None


# ---------------------------------------------------------------- loading
class Runs:
    def __init__(self, out: Path):
        self.out = out

    def dir(self, case, ctrl, etm=True) -> Path:
        return self.out / "runs" / run_name(case, ctrl, etm)

    def ok(self, case, ctrl, etm=True) -> bool:
        return (self.dir(case, ctrl, etm) / "summary.json").is_file()

    def csv(self, case, ctrl, what, etm=True) -> pd.DataFrame | None:
        f = self.dir(case, ctrl, etm) / f"{what}.csv"
        return pd.read_csv(f, dtype={"vehicle": str, "vehicle_a": str, "vehicle_b": str}) if f.is_file() else None

    def summary(self, case, ctrl, etm=True) -> dict | None:
        f = self.dir(case, ctrl, etm) / "summary.json"
        return json.loads(f.read_text()) if f.is_file() else None

    def pairs(self, case, ctrl, etm=True) -> pd.DataFrame | None:
        p = self.csv(case, ctrl, "pairs", etm)
        if p is not None:
            p["pair"] = ["-".join(sorted((a, b))) for a, b in zip(p["vehicle_a"], p["vehicle_b"])]
        return p

    def vehicle(self, case, ctrl, vid, col):
        v = self.csv(case, ctrl, "vehicles")
        row = None if v is None else v.loc[v["vehicle"] == vid]
        return None if row is None or row.empty else row[col].iloc[0]

    def ttc(self, case, ctrl, pair, col="min_ttc"):
        """[s] ``col`` of a pair (min_ttc: ours; pet_ssm: SUMO's SSM), None if absent or NaN."""
        p = self.pairs(case, ctrl)
        row = None if p is None else p.loc[p["pair"] == pair]
        if row is None or row.empty or not np.isfinite(float(row[col].iloc[0])):
            return None
        return float(row[col].iloc[0])


# ---------------------------------------------------------------- tables
def ttc_table(runs: Runs, cases: list[str], family: str) -> pd.DataFrame:
    rows = []
    for case in [c for c in cases if c.startswith(family)]:
        for ctrl, label in CONTROLLERS.items():
            p = runs.pairs(case, ctrl)
            for pair in PAIRS[family]:
                row = None if p is None else p.loc[p["pair"] == pair]
                vals = ([row[c].iloc[0] if c in row else np.nan for c in SSM_TABLE_COLUMNS]
                        if row is not None and not row.empty else ["/"] * len(SSM_TABLE_COLUMNS))
                paper = PAPER_TTC.get((family, case.split("_")[1], label, pair))
                rows.append([case.split("_")[1], label, pair, "/" if paper is None else paper, *vals])
    return pd.DataFrame(rows, columns=["scenario", "solver", "pair", "paper_min_ttc", *SSM_TABLE_COLUMNS])


def ssm_start_note(runs: Runs, cases: list[str]) -> str:
    """A sentence on the pairs whose SSM min TTC was taken before the controller's first decision
    acted (at or before the run's first control step): the vehicles' speeds as inserted."""
    hits, total = [], 0
    for case in cases:
        for ctrl, lab in CONTROLLERS.items():
            p, steps = runs.pairs(case, ctrl), runs.csv(case, ctrl, "steps")
            if p is None or steps is None or not len(steps) or "time_min_ttc_ssm" not in p:
                continue
            timed = p[p["min_ttc_ssm"].notna()]
            total += len(timed)
            early = timed[timed["time_min_ttc_ssm"] <= steps["time"].iloc[0] + 1e-9]
            hits += [f"{case} {lab} {r.pair} {r.min_ttc_ssm:.2f} s at t = {r.time_min_ttc_ssm:.2f} s"
                     for r in early.itertuples()]
    if not hits:
        return ""
    return (f"SSM's min TTC of {len(hits)} of the {total} pairs with one was taken before the first decision acted "
            f"({'; '.join(hits)}): the vehicles' speeds as inserted put them in the conflict area at once. After "
            "the first decisions they no longer would at constant speed, and SSM defines no crossing TTC then, "
            "so these cells are the scenario's initial state, the same for every kappa and equilibrium, not a "
            "margin the controller kept (ours, `min_ttc`, is taken over the whole approach).")


def ratio_table(runs: Runs, cases: list[str]) -> pd.DataFrame:
    """Each scenario's margin against scenario A of its case: the paper's min TTC ratio beside ours
    (min TTC and PET), per equilibrium and pair (issue 20's measure of how strongly kappa acts)."""
    rows = []
    for case in cases:
        family, scen = case.split("_")
        if scen == "A" or f"{family}_A" not in cases:
            continue
        for ctrl, label in CONTROLLERS.items():
            for pair in PAIRS[family]:
                paper = [PAPER_TTC.get((family, x, label, pair)) for x in (scen, "A")]
                ours = [[runs.ttc(f"{family}_{x}", ctrl, pair, col) for x in (scen, "A")] for col in ("min_ttc", "pet")]
                ratio = [a / b if a is not None and b else None for a, b in (paper, *ours)]
                if all(r is None for r in ratio):
                    continue
                rows.append([family, f"{scen}/A", label, pair, *["/" if r is None else r for r in ratio]])
    return pd.DataFrame(rows, columns=["case", "ratio", "solver", "pair", "ratio_paper_min_ttc", "ratio_min_ttc",
                                       "ratio_pet"])


def travel_times(runs: Runs, cases: list[str]) -> pd.DataFrame:
    frames = []
    for case in cases:
        for ctrl, label in CONTROLLERS.items():
            for etm in (True, False):
                v = runs.csv(case, ctrl, "vehicles", etm)
                if v is not None:
                    fam, scen = case.split("_")
                    frames.append(v.assign(case=fam, scenario=scen, solver=label, etm=etm))
    cols = ["case", "scenario", "solver", "etm", "vehicle", "kappa", "travel_time", "exit_lane"]
    return pd.concat(frames)[cols] if frames else pd.DataFrame(columns=cols)


def orderings(runs: Runs, cases: list[str], all_runs: list[tuple]) -> pd.DataFrame:
    rows = []

    def add(check, solver, desc, values, holds):
        rows.append([check, solver, desc, values, "n/a" if holds is None else bool(holds)])

    def f(x):
        return "missing" if x is None else (f"{x:.2f}" if isinstance(x, float) else str(x))

    def cmp(ok, *vals):  # None when any value is missing
        return None if any(v is None for v in vals) else ok

    for ctrl, lab in CONTROLLERS.items():
        a, c = runs.vehicle("case1_A", ctrl, "V1", "travel_time"), runs.vehicle("case1_C", ctrl, "V1", "travel_time")
        add(1, lab, "Case 1: V1 travel time C < A", f"C {f(c)} s, A {f(a)} s", cmp(c is not None and a is not None and c < a, a, c))
        vals, ok = [], True
        for vid in ("V2", "V3"):
            a, b = (runs.vehicle(f"case1_{s}", ctrl, vid, "travel_time") for s in "AB")
            vals.append(f"{vid}: B {f(b)} s, A {f(a)} s")
            ok = None if None in (a, b) or ok is None else ok and b > a
        add(2, lab, "Case 1: V2, V3 travel times B > A", "; ".join(vals), ok)
        # (3) and (4) by our min TTC (the paper's measure), then by SUMO's SSM PET (independent)
        for col, name in (("min_ttc", "min TTC"), ("pet_ssm", "SSM PET")):
            vals, ok = [], True
            for pair in PAIRS["case1"]:
                a, b = runs.ttc("case1_A", ctrl, pair, col), runs.ttc("case1_B", ctrl, pair, col)
                vals.append(f"{pair}: B {f(b)} s, A {f(a)} s")
                ok = None if None in (a, b) or ok is None else ok and b > a
            add(3, lab, f"Case 1: V1-V2, V1-V3 {name} B > A", "; ".join(vals), ok)
            t = {s: runs.ttc(f"case1_{s}", ctrl, "V1-V2", col) for s in "ABCD"}
            ok = None if None in t.values() else t["D"] <= min(t.values())
            add(4, lab, f"Case 1: V1-V2 {name} smallest in D", ", ".join(f"{s} {f(v)}" for s, v in t.items()), ok)
    for case in cases:
        vals, ok = [], True
        for pair in PAIRS[case.split("_")[0]]:
            ne, se = (runs.ttc(case, ctrl, pair) for ctrl in CONTROLLERS)  # the Nash controller first
            if ne is None and se is None:
                continue
            vals.append(f"{pair}: SE {f(se)}, NE {f(ne)}")
            ok = None if None in (ne, se) or ok is None else ok and se >= ne - SE_SLACK
        add(5, "both", f"{case}: SE min TTC >= NE min TTC - {SE_SLACK} s", "; ".join(vals), ok)
    for ctrl, lab in CONTROLLERS.items():
        lane = runs.vehicle("case2_A", ctrl, "V3", "exit_lane")
        add(6, lab, "Case 2 A: V3 exits on the middle lane", f"V3 exit_lane {f(lane)}", cmp(lane == "middle", lane))
        lane = runs.vehicle("case2_B", ctrl, "V3", "exit_lane")
        p = runs.pairs("case2_B", ctrl)
        has13 = None if p is None else bool((p["pair"] == "V1-V3").any())
        add(7, lab, "Case 2 B: V3 exits inner, no V1-V3 conflict", f"V3 exit_lane {f(lane)}, V1-V3 row {f(has13)}",
            cmp(lane == "inner" and not has13, lane, has13))
    coll = arrived = total = 0
    missing = [run_name(*r) for r in all_runs if not runs.ok(*r)]
    for r in all_runs:
        s = runs.summary(*r)
        if s:
            coll += s["counts"]["collisions"]
            arrived += s["counts"]["arrived"]
            total += s["counts"]["vehicles"]
    add(8, "both", f"zero collisions, all vehicles arrived ({len(all_runs)} runs)",
        f"collisions {coll}, arrived {arrived}/{total}" + (f", missing runs {len(missing)}" if missing else ""),
        coll == 0 and arrived == total and not missing)
    for case in QUICK:
        for ctrl, lab in CONTROLLERS.items():
            add(9, lab, *etm_check(runs, case, ctrl))
    return pd.DataFrame(rows, columns=["check", "solver", "description", "values", "holds"]).sort_values(
        "check", kind="stable")


def steady_steps(steps: pd.DataFrame) -> pd.DataFrame:
    """A run's control steps after the first: the first (the warm-up: first solves, caches) is left
    out of every compute-time number of the report, in the checks and the figures alike."""
    return steps.iloc[1:]


def etm_check(runs: Runs, case: str, ctrl: str) -> tuple[str, str, bool | None]:
    """Check 9, (description, values, holds): the trigger cuts the mean compute time per control step
    [ms] by MIN_CUT or more, where it has games to leave out (it leaves out MIN_SKIP or more of the
    games played without it); elsewhere holds is None (n/a) and the values say why."""
    desc = f"{case}: the ETM cuts the mean compute time per step by >= {MIN_CUT:.0%} (where it has games to leave out)"
    on, off = runs.csv(case, ctrl, "steps", True), runs.csv(case, ctrl, "steps", False)
    if on is None or off is None or len(on) < 2 or len(off) < 2:
        return desc, "missing", None
    on, off = steady_steps(on), steady_steps(off)
    m_on, m_off = on["compute_ms"].mean(), off["compute_ms"].mean()  # [ms]
    g_on, g_off = int(on["games"].sum()), int(off["games"].sum())
    skip = 1 - g_on / g_off if g_off else 0.0
    values = (f"compute per step {m_on:.2f} ms with the ETM, {m_off:.2f} ms without (cut {1 - m_on / m_off:.1%}); "
              f"games {g_on} vs {g_off} (left out {skip:.0%})")
    if "qp_solves" in on and "qp_solves" in off:  # the work, load-free
        q_on, q_off = on["qp_solves"].mean(), off["qp_solves"].mean()
        values += f"; QPs per step {q_on:.2f} vs {q_off:.2f}"
    if skip < MIN_SKIP:
        return desc, (f"not applicable: the trigger fired for {g_on} of the {g_off} games played without it; "
                      f"without it the controller already plays only the pairs whose paths meet, and here these "
                      f"were at risk on almost every step until they passed, so there is (almost) no game to leave "
                      f"out (the paper's cut is against one game of all vehicles); {values}"), None
    return desc, values, 1 - m_on / m_off >= MIN_CUT


# ---------------------------------------------------------------- figures
def run_figures(runs: Runs, cases: list[str], figdir: Path) -> list[Path]:
    pngs = []
    for case in cases:
        for ctrl, lab in CONTROLLERS.items():
            if runs.ok(case, ctrl):
                d, name = runs.dir(case, ctrl), run_name(case, ctrl, True)
                pngs.append(trajectory_figure(d, figdir / f"trajectory_{name}.png", f"{case}, {lab}"))
                pngs.append(velocity_figure(d, figdir / f"velocity_{name}.png", f"{case}, {lab}"))
    return [Path(p) for p in pngs]


ETM_STYLES = {"NE": "tab:blue", "SE": "tab:orange"}


def compute_time_figure(runs: Runs, cases: list[str], out_png: Path) -> Path:
    """Fig. 7 as distributions: per case and equilibrium, the ECDF of the compute time per control
    step with the trigger against without it (log axis). The first control step (the warm-up:
    first solves, caches) is left out and its time given in the title; the legend also gives the
    QPs per step, the same comparison without the machine's load."""
    fig, axes = plt.subplots(len(cases), len(CONTROLLERS), figsize=(11, 3.6 * len(cases)), squeeze=False,
                             sharex=True, layout="constrained")
    warmups = []
    for row, case in enumerate(cases):
        for col, (ctrl, lab) in enumerate(CONTROLLERS.items()):
            samples, styles, extra = {}, {}, {}
            for etm in (True, False):
                s = runs.csv(case, ctrl, "steps", etm)
                if s is None or not len(s):
                    continue
                name = "ETM" if etm else "no ETM"
                warmups.append(float(s["compute_ms"].iloc[0]))
                samples[name] = steady_steps(s)["compute_ms"].to_numpy(float)
                styles[name] = {"color": ETM_STYLES[lab], "ls": "-" if etm else "--"}
                if "qp_solves" in s:  # (absent from runs of versions before the column)
                    extra[name] = f"{steady_steps(s)['qp_solves'].mean():.2f} QPs per step"
            draw_ecdf(axes[row, col], samples, styles, extra)
            axes[row, col].set_title(f"{case}, {lab}", fontsize=10)
            if row < len(cases) - 1:
                axes[row, col].set_xlabel("")
    warm = f": {min(warmups):.1f}-{max(warmups):.1f} ms" if warmups else ""
    fig.suptitle("Compute time per control step, with the event trigger (ETM) and without; the first step "
                 f"left out (the warm-up{warm})", fontsize=11)
    fig.savefig(out_png, dpi=120)
    plt.close(fig)
    return out_png


def stopping_rule(runs: Runs, case: str, ctrl: str) -> dict:
    """The run's convergence limits from its recorded settings (else SolverSettings' defaults): tol
    [m/s^2] (nash_tol / stackelberg_tol), the guard [m/s^2] and relative gain of the cost criterion."""
    from intersection_cosim.games.settings import SolverSettings

    recorded = ((runs.summary(case, ctrl) or {}).get("settings") or {}).get("controller_settings") or {}
    solver = recorded.get("solver") or {}
    default = SolverSettings()

    def get(key):
        return float(solver.get(key, getattr(default, key)))

    # both equilibria also stop on a relative cost gain < nash_cost_rtol below nash_cost_guard
    return {"tol": get("stackelberg_tol" if ctrl.startswith("stackelberg") else "nash_tol"), "guard": get("nash_cost_guard"),
            "rtol": get("nash_cost_rtol")}


def convergence_figure(runs: Runs, case: str, out_png: Path) -> Path:
    panels = [(f"{case}, {lab}", runs.csv(case, ctrl, "convergence"), stopping_rule(runs, case, ctrl))
              for ctrl, lab in CONTROLLERS.items()]
    return solver_figures.convergence_figure(panels, out_png, f"{case}: convergence of each pair's longest game "
                                      "(residual = max change of any player's plan between iterations)")


# ---------------------------------------------------------------- report
def md_table(df: pd.DataFrame) -> str:
    """A table of settings: values as they are (only long floats shortened)."""
    def cell(x):
        if isinstance(x, float):
            return "/" if np.isnan(x) else f"{x:.3g}" if abs(x) < 1e-3 and x else f"{x:.3f}".rstrip("0").rstrip(".")
        return str(x)

    lines = ["| " + " | ".join(map(str, df.columns)) + " |", "|" + "---|" * len(df.columns)]
    lines += ["| " + " | ".join(cell(x) for x in row) + " |" for row in df.itertuples(index=False)]
    return "\n".join(lines)


def defaults(runs: Runs, cases: list[str]) -> tuple[dict, dict, str]:
    nash = next(iter(CONTROLLERS))
    s = next((runs.summary(c, nash) for c in cases if runs.ok(c, nash)), None) or {}
    model, tables = s.get("settings", {}).get("model") or {}, s.get("settings", {}).get("controller_settings")
    note = "from summary.json"
    if tables is None:  # the CLI's --controller override leaves it null; the controller uses these
        from intersection_cosim.control.game.settings import GameControllerSettings

        tables, note = dataclasses.asdict(GameControllerSettings()), "summary.json has null; the defaults"
    solver = {f"{table}.{key}": value for table, fields in tables.items() for key, value in fields.items()}
    return model, solver, note


def write_report(out: Path, cases, tables, figs, failures, wall, budget_ms, model, solver, note) -> None:
    parts = ["# Hang et al., Section V: reproduction with intersection-cosim", "",
             f"Made by `{shlex.join(['python', *sys.argv])}` in {wall:.0f} s; scenarios: {', '.join(cases)}; "
             f"control-step budget {budget_ms:g} ms; ETM on unless stated; 'ours' is this package's measure, 'SSM' "
             "SUMO's SSM device (an empty cell: no conflict recorded).", ""]
    if failures:
        parts += ["## Failed runs", ""] + [f"- {n}: {e}" for n, e in failures.items()] + [""]
    for title, df, note in tables:  # units in the headers, every column rounded alike (report/reporting.py)
        parts += [f"## {title}", "", markdown_table(df), ""] + ([note, ""] if note else [])
    parts += ["## Figures", ""] + [f"![{p.stem}]({p.relative_to(out).as_posix()})" for p in figs] + [""]
    parts += ["## Defaults", "", "Calibrated defaults, `settings.model`:", "",
              md_table(pd.DataFrame(list(model.items()), columns=["field", "value"])), "",
              f"`settings.controller_settings`, the `[controller.game]`, `[controller.solver]`, "
              f"`[controller.policy]` and `[controller.safety]` tables ({note}):", "",
              md_table(pd.DataFrame([(k, str(v)) for k, v in solver.items()], columns=["field", "value"])), ""]
    tmp = out / "report.md.tmp"
    tmp.write_text("\n".join(parts))
    tmp.replace(out / "report.md")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="report", help="report folder (default: report)")
    ap.add_argument("--workers", type=int, default=2, help="parallel runs (default: 2)")
    ap.add_argument("--quick", action="store_true", help="only case1_A and case2_A")
    ap.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    ap.add_argument("--coupled", action="store_true",
                    help="the coupled controllers (nash-coupled, stackelberg-coupled) instead of the pairwise ones")
    ap.add_argument("--budget-ms", type=float, default=BUDGET_MS,
                    help=f"control-step budget of every run [ms] (default: {BUDGET_MS:g}, never binds; "
                         "100 = the HIL box)")
    args = ap.parse_args(argv)
    if args.coupled:
        global CONTROLLERS
        CONTROLLERS = COUPLED_CONTROLLERS
    if not args.budget_ms > 0:
        print(f"reproduce_paper: --budget-ms: budget_ms = {args.budget_ms:g}: must be > 0", file=sys.stderr)
        return 2
    out = Path(args.out).resolve()
    problem = check_out(out)
    if problem is None:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            problem = f"cannot be made ({exc.strerror})"
    if problem:
        print(f"reproduce_paper: --out: out = {str(args.out)!r}: {problem}", file=sys.stderr)
        return 2
    cases = QUICK if args.quick else SCENARIOS
    t0 = time.perf_counter()
    failures = play_all(out, cases, max(1, args.workers), args.budget_ms, progress=not args.no_progress)
    runs = Runs(out)
    all_runs = [(c, k, e) for c in cases for k in CONTROLLERS for e in (True, False)]

    t2, t4 = ttc_table(runs, cases, "case1"), ttc_table(runs, cases, "case2")
    tt, order = travel_times(runs, cases), orderings(runs, cases, all_runs)
    for name, df in (("table_ii", t2), ("table_iv", t4), ("travel_times", tt), ("orderings", order)):
        df.to_csv(out / f"{name}.csv", index=False)
        write_units(out, {f"{name}.csv": df.columns})
    figdir = out / "figures"
    figdir.mkdir(exist_ok=True)
    for stale in figdir.glob("*.png"):  # figures of an earlier call (names may have changed)
        stale.unlink()
    figs = [compute_time_figure(runs, [c for c in QUICK if c in cases], figdir / "compute_time.png"),
            convergence_figure(runs, "case1_A", figdir / "convergence_case1_A.png")]
    figs += run_figures(runs, cases, figdir)
    tt_on = tt[tt["etm"]].drop(columns="etm")
    ratios = ratio_table(runs, cases)
    ratios.to_csv(out / "ratios.csv", index=False)
    write_units(out, {"ratios.csv": ratios.columns})
    write_report(out, cases, [("Table II (Case 1): min TTC and PET, the paper's beside ours", t2,
                               ssm_start_note(runs, [c for c in cases if c.startswith("case1")])),
                              ("Table IV (Case 2): min TTC and PET, the paper's beside ours", t4,
                               ssm_start_note(runs, [c for c in cases if c.startswith("case2")])),
                              ("Margins against scenario A: the paper's min TTC ratio beside ours", ratios, ""),
                              ("Travel times (ETM on)", tt_on, ""), ("Orderings", order, "")],
                 figs, failures, time.perf_counter() - t0, args.budget_ms, *defaults(runs, cases))
    print(order.to_string(index=False))
    print(f"report: {out / 'report.md'} ({time.perf_counter() - t0:.0f} s)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
