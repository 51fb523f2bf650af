"""Figures of how the controller's solver did (matplotlib, Agg backend): :func:`convergence_figure`
(residual per iteration against the tolerance, the paper's Fig. 3), :func:`draw_ecdf` (compute-time
distributions, Fig. 7) and :func:`compute_time_histogram`; for runs and sweeps alike.
"""

from __future__ import annotations

from pathlib import Path
from typing import Mapping

import matplotlib

matplotlib.use("Agg")  # no display; must precede pyplot
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from intersection_cosim.report.figure_style import save_figure  # noqa: E402


def compute_time_histogram(samples: Mapping[str, np.ndarray], out_png: Path, title: str | None = None,
                           budget_ms: float | None = None) -> Path:
    """Histogram of per-step controller compute times [ms], one per label (e.g. per controller),
    on log-spaced bins; the deadline ``budget_ms`` as a vertical line when given."""
    fig, ax = plt.subplots(figsize=(7.0, 4.0), layout="constrained")
    values = {k: np.asarray(v, float)[np.isfinite(v)] for k, v in samples.items()}
    allv = np.concatenate([v for v in values.values() if len(v)] or [np.zeros(0)])
    pos = allv[allv > 0]
    if len(pos):
        lo, hi = pos.min(), max(pos.max(), budget_ms or 0.0)
        bins = np.geomspace(lo / 1.5, hi * 1.5, 50)
        for label, v in values.items():
            ax.hist(np.clip(v, bins[0], None), bins=bins, histtype="step", lw=1.6, label=f"{label} (n = {len(v)})")
        ax.set_xscale("log")
        if budget_ms:
            ax.axvline(budget_ms, color="#c0392b", ls="--", lw=1.2, label=f"budget {budget_ms:g} ms")
        ax.legend(fontsize=8)
    else:
        ax.text(0.5, 0.5, "no compute-time samples", ha="center", va="center", transform=ax.transAxes)
    ax.set_xlabel("compute time per control step [ms]")
    ax.set_ylabel("control steps")
    ax.grid(alpha=0.3)
    ax.set_title(title or "Controller compute time per step")
    return save_figure(fig, out_png)


RESIDUAL_LABEL = "max change of any player's plan\nbetween iterations [m/s$^2$]"
RESIDUAL_FLOOR = 1e-4  # [m/s^2] bottom of the convergence axis; smaller residuals (and 0) are drawn on it


def draw_convergence(ax, conv: pd.DataFrame | None, tol: float, guard: float | None = None,
                     rtol: float | None = None) -> dict[str, pd.DataFrame]:
    """The residual of every pair's longest solve against the iteration (log y from RESIDUAL_FLOOR,
    integer x), with the tolerance ``tol`` [m/s^2] as a horizontal line and, when given, the guard
    [m/s^2] below which a relative cost gain under ``rtol`` also ends a game (games/settings.py
    nash_cost_guard, nash_cost_rtol); returns the drawn points per pair (iteration, residual as drawn)."""
    drawn: dict[str, pd.DataFrame] = {}
    top, last = tol, 1
    if conv is not None and len(conv):
        conv = conv.assign(pair=conv["vehicle_a"].astype(str) + "-" + conv["vehicle_b"].astype(str))
        for pair, g in conv.groupby("pair"):
            solves = g.groupby("time")
            t = solves.size().idxmax()  # the solve with the most iterations
            s = solves.get_group(t).sort_values("iteration")
            y = s["residual"].to_numpy(float).clip(min=RESIDUAL_FLOOR)
            ax.plot(s["iteration"], y, "o-", ms=6, label=f"{pair}, solve at t = {t:.2f} s ({s['status'].iloc[-1]}, "
                    f"{len(s)} iterations)")
            drawn[pair] = pd.DataFrame({"iteration": s["iteration"].to_numpy(int), "residual": y})
            top, last = max(top, float(y.max())), max(last, int(s["iteration"].max()))
    else:
        ax.text(0.5, 0.5, "no games played", ha="center", va="center", transform=ax.transAxes)
    ax.axhline(tol, color="#c0392b", ls="--", lw=1.3, gid="tolerance", label=f"tolerance {tol:g} m/s$^2$: converged below")
    if guard is not None:
        top = max(top, guard)
        gain = f"a cost gain < {rtol:.1%} " if rtol is not None else "a small cost gain "
        ax.axhline(guard, color="#595959", ls=":", lw=1.3, gid="guard",
                   label=f"{guard:g} m/s$^2$: below it {gain}also ends the game")
    ax.set_yscale("log")
    ax.set_ylim(RESIDUAL_FLOOR / 1.5, top * 2.0)
    ax.set_xlim(0.5, last + 0.5)
    ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    floor = any((d["residual"] <= RESIDUAL_FLOOR).any() for d in drawn.values())
    ax.set_xlabel("iteration" + (f"   (residuals below {RESIDUAL_FLOOR:g}, or 0, drawn at {RESIDUAL_FLOOR:g})"
                                 if floor else ""))
    ax.set_ylabel(RESIDUAL_LABEL)
    ax.grid(alpha=0.3, which="major")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.16), frameon=False)  # below: no point hidden
    return drawn


def convergence_figure(panels: list[tuple[str, pd.DataFrame | None, dict]], out_png: Path,
                       title: str | None = None) -> Path:
    """One :func:`draw_convergence` panel per (title, convergence.csv table, its keyword arguments:
    tol and optionally guard, rtol)."""
    fig, axes = plt.subplots(1, len(panels), figsize=(5.8 * len(panels), 5.4), squeeze=False, layout="constrained")
    for ax, (name, conv, limits) in zip(axes[0], panels, strict=True):
        draw_convergence(ax, conv, **limits)
        ax.set_title(name, fontsize=10)
    fig.suptitle(title or "Convergence of the pair games (the longest solve of each pair)", fontsize=11)
    return save_figure(fig, out_png)


def draw_ecdf(ax, samples: Mapping[str, np.ndarray], styles: Mapping[str, dict] | None = None,
              extra: Mapping[str, str] | None = None) -> dict[str, np.ndarray]:
    """Empirical CDFs of compute times [ms] (log x): the share of control steps that took at most
    x; the legend gives each sample's median and mean (and ``extra[label]``). Returns the sorted
    values drawn per label."""
    drawn = {}
    for label, values in samples.items():
        v = np.sort(np.asarray(values, float)[np.isfinite(values)])
        if not len(v):
            continue
        shown = np.clip(v, 1e-3, None)  # [ms] a log axis has no 0
        y = np.arange(1, len(v) + 1) / len(v)
        more = f", {extra[label]}" if extra and label in extra else ""
        ax.step(np.r_[shown[0], shown], np.r_[0.0, y], where="post", lw=1.6,
                label=f"{label}: median {np.median(v):.2f} ms, mean {v.mean():.2f} ms{more}",
                **(styles or {}).get(label, {}))
        drawn[label] = v
    ax.set_xscale("log")
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("compute time per control step [ms]")
    ax.set_ylabel("share of control steps\ntaking at most this long [-]")
    ax.grid(alpha=0.3, which="both")
    if drawn:
        ax.legend(fontsize=8, loc="lower right")
    return drawn
