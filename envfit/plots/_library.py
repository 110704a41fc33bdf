"""Figures of a library run: how the smoothness s is distributed across the maps.

* :func:`plot_s_histogram` — histogram of the per-map s (continuous fits: bins; Table 2's
  best s: one bar per grid value; the counts on whole-number ticks); with intervals, a
  second panel shows every map's s and its 95 % interval, sorted by s.

PNGs are written atomically (:func:`envfit.plots._save.save_figure`).
"""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from . import matplotlib  # noqa: F401  (selects the Agg backend)
from ._save import save_figure
from ._ticks import integer_axis

__all__ = ["plot_s_histogram"]


def plot_s_histogram(s: Sequence[float], path: str | Path, *, title: str = "",
                     grid: Sequence[float] | None = None,
                     intervals: Sequence[tuple[float, float]] | None = None,
                     labels: Sequence[str] | None = None) -> Path:
    """Histogram of ``s`` across maps; ``grid``: s can only take these values (bars);
    ``intervals``: per-map (low, high), drawn sorted in a second panel (named by ``labels``
    when there are at most 40 maps)."""
    import matplotlib.pyplot as plt
    s = np.asarray(s, dtype=float)
    ncols = 2 if intervals is not None else 1
    fig, axes = plt.subplots(1, ncols, figsize=(6 * ncols, 4), squeeze=False)
    ax = axes[0, 0]
    if grid is not None:
        g = np.asarray(sorted(grid), dtype=float)
        counts = [int(np.sum(np.isclose(s, v))) for v in g]
        width = 0.6 * (np.min(np.diff(g)) if len(g) > 1 else 0.1)
        ax.bar(g, counts, width=width, color="C0")
        ax.set_xticks(g)
    else:
        bins = max(5, min(40, int(np.sqrt(len(s))) * 2))
        lo, hi = (min(s.min(), 1.0), max(s.max(), 2.0)) if len(s) else (1.0, 2.0)
        ax.hist(s, bins=np.linspace(lo, hi, bins + 1), color="C0", edgecolor="white")
    ax.set_xlabel("Sobolev smoothness s")
    ax.set_ylabel("number of maps")
    integer_axis(ax.yaxis)
    ax.set_title(title or f"s across {len(s)} maps", fontsize=9)
    ax.grid(True, axis="y", alpha=0.3)
    if intervals is not None:
        ax2 = axes[0, 1]
        iv = np.asarray(intervals, dtype=float).reshape(-1, 2)
        order = np.argsort(s)
        y = np.arange(len(s))
        ax2.errorbar(s[order], y, xerr=[s[order] - iv[order, 0], iv[order, 1] - s[order]],
                     fmt="o", ms=3, capsize=2)
        if labels is not None and len(s) <= 40:
            ax2.set_yticks(y)
            ax2.set_yticklabels([labels[k] for k in order], fontsize=7)
        else:
            ax2.set_ylabel("maps, sorted by s")
            integer_axis(ax2.yaxis)
        ax2.set_xlabel("s and its 95 % interval")
        ax2.grid(True, axis="x", alpha=0.3)
    return save_figure(fig, path)
