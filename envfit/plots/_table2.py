"""Table 2 and fit figures."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import matplotlib  # noqa: F401  (selects the Agg backend)
from ._save import save_figure


def plot_table2(result, path: str | Path) -> Path:
    """Log-log RMSE vs N, one line per s (per-pixel solid, solid-angle weighted dashed)."""
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4.2))
    t = result.rmse_table("rmse")
    tw = result.rmse_table("rmse_solid_angle")
    for i, s in enumerate(result.s_values):
        line, = ax.loglog(result.n_values, t[i], "o-", label=f"s = {s:g}")
        ax.loglog(result.n_values, tw[i], "--", color=line.get_color(), alpha=0.6)
    ax.set_xlabel("number of samples N")
    ax.set_ylabel(f"RMSE ({result.scale} scale)")
    ax.set_title(f"Kernel reconstruction of {result.map}\n(solid: per pixel, dashed: solid-angle weighted)",
                 fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    return save_figure(fig, path)


def plot_fit_curve(fit, path: str | Path) -> Path:
    """The fit criterion against s, with the estimate and its interval."""
    import matplotlib.pyplot as plt
    s = np.array([c["s"] for c in fit.curve])
    v = np.array([c["score"] for c in fit.curve])
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(s, v, "o-", ms=3)
    ax.axvline(fit.s, color="k", lw=1, label=f"s = {fit.s:.3f}")
    ax.axvspan(fit.s_interval[0], fit.s_interval[1], color="C1", alpha=0.2, label="95 % interval")
    ax.set_xlabel("Sobolev smoothness s")
    ax.set_ylabel(fit.score_name)
    ax.set_title(f"envfit fit ({fit.method}, N = {fit.n}, {fit.scale} scale)", fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend()
    return save_figure(fig, path)
