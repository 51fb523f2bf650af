"""Mean travel time against av_share, per controller, next to sumo-priority: a figure of run folders.

    python scripts/plot_av_share.py RUN_DIR... --out av_share.png

Each RUN_DIR is a run folder (``run --out``) whose name contains ``av<share>`` (for example
``medium_av0.5-nash-s1``) or ``av_share_<share>`` (the run folders of ``compare --av-share``, for
example ``.../runs/nash-seed1-av_share_0.50``), or is a run of a baseline of any name; its controller comes from its summary.json. Runs of one controller and
share (the seeds) are averaged, with their spread as error bars; a controller that does not
command vehicles (sumo-priority: SUMO drives every vehicle, whatever av_share) is drawn as a
horizontal band (mean +- std over all its runs). The realised AV share (vehicles.csv's driver
column) is printed per point next to the nominal one.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

BASELINES = ("sumo", "sumo-priority", "sumo-allway-stop", "sumo-tls")  # SUMO drives every vehicle


def _runs(folders: list[str]) -> pd.DataFrame:
    rows = []
    for folder in map(Path, folders):
        match = re.search(r"av(?:_share_)?([0-9]+(?:\.[0-9]+)?)(?:-|$)", folder.name)
        summary = folder / "summary.json"
        s = json.loads(summary.read_text()) if summary.exists() else None
        baseline = s is not None and s["controller"] in BASELINES  # its share does not matter
        if s is None or (match is None and not baseline):
            print(f"skipped {folder} (no av<share> in its name or no summary.json)", file=sys.stderr)
            continue
        vehicles = pd.read_csv(folder / "vehicles.csv")
        if "driver" not in vehicles:  # a run from before vehicles.csv had the column: its route file
            types = [el.get("type") for el in ET.parse(folder / "scenario.rou.xml").getroot().iter("vehicle")]
            vehicles = pd.DataFrame({"driver": ["human" if t == "human" else "av" for t in types]})
        rows.append({"controller": s["controller"], "share": float(match.group(1)) if match else float("nan"),
                     "travel_time": s["metrics"]["mean_travel_time"], "collisions": s["counts"]["collisions"],
                     "realised": float((vehicles["driver"] == "av").mean())})
    return pd.DataFrame(rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--out", required=True)
    ap.add_argument("--title", default="Mean travel time against the share of AVs")
    args = ap.parse_args(argv)
    df = _runs(args.runs)
    if df.empty:
        print("no runs", file=sys.stderr)
        return 2
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for n, (ctrl, g) in enumerate(df.groupby("controller")):
        if ctrl in BASELINES:
            m, sd = g["travel_time"].mean(), g["travel_time"].std(ddof=0)
            ax.axhspan(m - sd, m + sd, color="grey", alpha=0.25)
            ax.axhline(m, color="grey", lw=2, ls="--", label=f"{ctrl} (SUMO drives all; {len(g)} runs)")
            print(f"{ctrl}: {m:.2f} +- {sd:.2f} s over {len(g)} runs")
            continue
        by = g.groupby("share").agg(tt=("travel_time", "mean"), sd=("travel_time", lambda x: x.std(ddof=0)),
                                    runs=("travel_time", "size"), coll=("collisions", "sum"),
                                    realised=("realised", "mean")).reset_index()
        offset = 0.006 * (n - 0.5)  # [-] keep the two controllers' error bars apart
        ax.errorbar(by["share"] + offset, by["tt"], yerr=by["sd"], marker="o", capsize=3, lw=2,
                    label=f"{ctrl} ({int(by['runs'].max())} seeds)")
        for r in by.itertuples():
            print(f"{ctrl} av_share {r.share:g} (realised {r.realised:.2f}): {r.tt:.2f} +- {r.sd:.2f} s, "
                  f"{r.runs} runs, {r.coll} collisions")
    ax.set_xlabel("av_share (probability a vehicle is an AV) [-]")
    ax.set_ylabel("mean travel time [s]")
    ax.set_title(args.title)
    ax.set_xticks(sorted(df.loc[~df.controller.isin(BASELINES), "share"].unique()))
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
