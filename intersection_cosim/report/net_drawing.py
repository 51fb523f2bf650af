"""A net's outline (network.outline: lanes, junction areas, the junctions' internal lanes) drawn
into matplotlib axes, for the figures and the animation alike (no pyplot: the animation draws
on its own Agg canvas)."""

from __future__ import annotations

from matplotlib.patches import Polygon

from intersection_cosim.network.outline import NetOutline


def draw_outline(ax, outline: NetOutline, road: str, marking: str, path_line: str, path_width: float = 0.6) -> None:
    """Junction areas (z-order 0) and lanes (1) filled with ``road``, the lanes edged with
    ``marking``; zebra crossings (1) striped in ``marking``; the internal lanes' centre lines (2)
    dotted in ``path_line``, ``path_width`` [pt] wide."""
    for poly in outline.junctions:
        ax.add_patch(Polygon(poly, closed=True, facecolor=road, edgecolor="none", zorder=0))
    for poly in outline.lanes:
        ax.add_patch(Polygon(poly, closed=True, facecolor=road, edgecolor=marking, lw=0.6, zorder=1))
    for poly in outline.crossings:
        ax.add_patch(Polygon(poly, closed=True, facecolor=road, edgecolor=marking, hatch="|||", lw=0.0, zorder=1))
    for line in outline.internal:
        ax.plot(line[:, 0], line[:, 1], color=path_line, lw=path_width, ls=":", zorder=2)
