"""The traffic engineer's figure of a run: control delay per approach against the HCM level-of-
service bands (results/engineer.py), each bar coloured by its LOS."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no display; must precede pyplot
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from intersection_cosim.report.figure_style import save_figure  # noqa: E402
from intersection_cosim.results.engineer import TABLES  # noqa: E402

LOS_COLOURS = {"A": "#1a9850", "B": "#91cf60", "C": "#d9ef8b", "D": "#fee08b", "E": "#fc8d59", "F": "#d73027",
               "": "#bdbdbd"}


def approach_delay_figure(approaches: pd.DataFrame, out_png: Path, title: str) -> Path | None:
    """Horizontal bars: the control delay [s] of each junction's approach (all movements), coloured
    by LOS, with the band bounds of the run's HCM table; None if the run has no approach."""
    rows = approaches[approaches["movement"] == "all"]
    if rows.empty:
        return None
    labels = [f"{j} / {a}" if j else str(a) for j, a in zip(rows["junction"].fillna(""), rows["approach"])]
    fig, ax = plt.subplots(figsize=(7.0, 1.2 + 0.35 * len(rows)))
    ax.barh(range(len(rows)), rows["control_delay"].fillna(0.0),
            color=[LOS_COLOURS.get(str(x) if isinstance(x, str) else "", "#bdbdbd") for x in rows["los"]])
    ax.set_yticks(range(len(rows)), labels, fontsize=7)
    ax.invert_yaxis()
    table = str(rows["los_table"].iloc[0])
    for bound, letter in TABLES.get(table, ()):
        ax.axvline(bound, color="0.5", lw=0.6, ls=":")
        ax.text(bound, -0.6, f"{letter}|", ha="right", va="bottom", fontsize=7, color="0.4")
    ax.set_xlabel(f"control delay [s] (SUMO time loss); bands: {table}")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    return save_figure(fig, out_png)
