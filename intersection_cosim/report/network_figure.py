"""The network figure of a run with several managed junctions: the net's roads, each managed
junction a disc coloured by the mean delay of the vehicles that passed it (results.junction_metrics)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no display; must precede pyplot
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from intersection_cosim.report.figure_style import DPI  # noqa: E402

ROAD = "#b8b8b8"


def junction_delay_figure(net_file: Path, table: pd.DataFrame, out_png: Path, title: str) -> Path:
    """``table``: results.junction_metrics.junction_table's rows (junction, vehicles, mean_delay [s])."""
    import sumolib

    net = sumolib.net.readNet(str(net_file), withInternal=False)
    fig, ax = plt.subplots(figsize=(7.5, 6.5))
    for edge in net.getEdges():
        for lane in edge.getLanes():
            shape = np.asarray([p[:2] for p in lane.getShape()], float)
            ax.plot(shape[:, 0], shape[:, 1], color=ROAD, lw=1.2, zorder=0)
    xy = np.asarray([net.getNode(j).getCoord()[:2] for j in table["junction"]], float)
    delay = table["mean_delay"].to_numpy(float)
    top = max(float(np.nanmax(delay)) if np.isfinite(delay).any() else 1.0, 1e-6)
    dots = ax.scatter(xy[:, 0], xy[:, 1], c=delay, cmap="YlOrRd", vmin=0.0, vmax=top, s=900,
                      edgecolors="black", linewidths=0.8, zorder=2)
    for (x, y), j, d, n in zip(xy, table["junction"], delay, table["vehicles"]):
        label = f"{j}\n{d:.1f} s" if np.isfinite(d) else f"{j}\nno traffic"  # no vehicle passed it
        ax.annotate(label, (x, y), ha="center", va="center", fontsize=8, zorder=3,
                    color="white" if np.isfinite(d) and d > 0.6 * top else "black")
    fig.colorbar(dots, ax=ax, shrink=0.8, label="mean delay per vehicle passing the junction [s]")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    out_png = Path(out_png)
    out_png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png, dpi=DPI)
    plt.close(fig)
    return out_png
