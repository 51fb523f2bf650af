"""What every figure of the report shares (matplotlib, Agg backend): the resolution, the marker
shapes and line styles told apart by vehicle or line, and :func:`save_figure`."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no display; must precede pyplot
import matplotlib.pyplot as plt  # noqa: E402

DPI = 120
TRAJECTORY_MARKERS = ("o", "^", "D", "v", "P", "X", "<", ">", "h", "*")  # one per vehicle
LINE_STYLES = ("-", "--", "-.", ":")  # velocity lines, one per vehicle (besides its colour)


def save_figure(fig, out_png: Path) -> Path:
    out_png = Path(out_png)
    out_png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png, dpi=DPI)
    plt.close(fig)
    return out_png
