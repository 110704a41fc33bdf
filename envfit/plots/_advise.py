"""The figure of ``envfit advise --out DIR``: the renderer rules' predicted RMSE against N.

:func:`plot_advise` takes plain data — the dict of ``envfit advise``'s JSON
(:meth:`envfit.advisor._result.Advice.to_dict`: ``map``, ``map_size``, ``brdf``,
``shininess``, ``target_rmse`` and the ``renderer`` section, whose ``rows`` each hold
``strategy``, ``pointset``, ``n`` (None when not reached), ``predicted_rmse``, ``curve``
``{"n": [...], "predicted": [...]}`` and, after ``--check``, ``measured_rmse``,
``measured_low``, ``measured_high``) — and draws on log-log axes one line per rule (colour
per strategy, line style per point set), the target as a horizontal line, each row's chosen
N as a filled marker on its line and the measured RMSE with its 95 % interval as an error
bar; the title names the map, its size and the lobe. Written atomically
(:func:`envfit.plots._save.save_figure`). It imports neither shading nor predict nor the
advisor (layering): only the dict.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import matplotlib  # noqa: F401  (selects the Agg backend)
from ._save import save_figure

__all__ = ["plot_advise", "STRATEGY_COLOURS", "POINTSET_LINES"]

STRATEGY_COLOURS = {"brdf": "C0", "map": "C1", "mis": "C2", "split": "C3"}
#: point set → (marker, line style)
POINTSET_LINES = {"sobol": ("s", "-"), "sf": ("^", "--"), "random": ("o", ":"),
                  "jitter": ("D", "-."), "lp": ("v", (0, (5, 1))), "bnot": ("P", (0, (1, 3)))}


def _lobe(d: dict) -> str:
    return "diffuse" if d.get("brdf") == "diffuse" else f"glossy n = {d.get('shininess'):g}"


def _row(ax, r: dict) -> None:
    """One rule: its curve, the chosen N and the measured point with its interval."""
    colour = STRATEGY_COLOURS.get(r["strategy"], "k")
    marker, style = POINTSET_LINES.get(r["pointset"], ("x", "-"))
    c = r.get("curve") or {}
    n = np.asarray(c.get("n", []), dtype=float)
    p = np.asarray(c.get("predicted", []), dtype=float)
    ok = p > 0
    label = f"{r['strategy']}/{r['pointset']}" + ("" if r.get("n") is not None else " (not reached)")
    ax.plot(n[ok], p[ok], linestyle=style, color=colour, lw=1.3, label=label)
    if r.get("n") is not None and r.get("predicted_rmse"):
        ax.plot([r["n"]], [r["predicted_rmse"]], marker=marker, color=colour, ms=8,
                markeredgecolor="k", linestyle="none")
    m = r.get("measured_rmse")
    if m is not None and r.get("n") is not None and m > 0:
        lo, hi = r.get("measured_low", m), r.get("measured_high", m)
        ax.errorbar([r["n"] * 1.04], [m], yerr=[[max(m - lo, 0.0)], [max(hi - m, 0.0)]],
                    marker=marker, mfc="none", color=colour, capsize=3, linestyle="none")


def plot_advise(d: dict, path: str | Path) -> Path:
    """Write the renderer rules' figure of the advise dict ``d`` (module docstring) to
    ``path`` (PNG, atomic); returns the path.

    Raises
    ------
    ValueError
        ``d`` has no renderer section.
    """
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    ren = d.get("renderer")
    if not ren:
        raise ValueError("the advise result has no renderer section")
    fig, ax = plt.subplots(figsize=(8.5, 5.5))
    for r in ren["rows"]:
        _row(ax, r)
    target = float(d.get("target_rmse") or ren.get("target_rmse"))
    ax.axhline(target, color="k", lw=1.0, linestyle="-", alpha=0.7)
    ax.text(float(max(2, ren.get("nmin", 2))), target * 1.08,
            f"target {target:.3g}", fontsize=8)
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("N (samples per shading point)")
    ax.set_ylabel("RMSE over axes (predicted: lines; measured: error bars)")
    w, h = (d.get("map_size") or [0, 0])[:2]
    ax.set_title(f"{d.get('map', 'map')}: {w}x{h}, {_lobe(d)} — renderer rules")
    handles, labels = ax.get_legend_handles_labels()
    handles += [Line2D([], [], marker="o", color="grey", markeredgecolor="k", linestyle="none"),
                Line2D([], [], marker="o", mfc="none", color="grey", linestyle="none")]
    labels += ["chosen N (predicted)", "measured, 95 % interval"]
    ax.legend(handles, labels, fontsize=7, ncol=2, loc="best")
    ax.grid(True, which="both", alpha=0.25)
    return save_figure(fig, path)
