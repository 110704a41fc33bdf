"""The figure of ``envfit validate --renderer``: renderer rules, measured and predicted RMSE vs N.

:func:`plot_renderer` takes plain data — the ``renderer`` section of ``envfit validate``'s
JSON (:meth:`envfit.validate._renderer.RendererValidation.to_json`: ``map``, ``map_size``,
``scale``, ``config`` and ``cells``, each cell a dict with ``lobe``, ``strategy``,
``pointset``, ``n``, ``predicted_rmse``, ``measured_rmse``, ``measured_low``,
``measured_high``) — and writes one panel per lobe on log-log axes: the measured RMSE as
markers with the 95 % interval as error bars, the predicted RMSE as lines; one colour per
strategy, one marker and line style per point set. Written atomically
(:func:`envfit.plots._save.save_figure`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from envfit.defaults import DEFAULT_SHININESS
from . import matplotlib  # noqa: F401  (selects the Agg backend)
from ._save import save_figure

__all__ = ["plot_renderer", "STRATEGY_COLOURS", "POINTSET_STYLES"]

STRATEGY_COLOURS = {"brdf": "C0", "map": "C1", "mis": "C2", "split": "C3"}
#: point set → (marker, line style)
POINTSET_STYLES = {"random": ("o", "-"), "sobol": ("s", "--"), "sf": ("^", ":"),
                   "jitter": ("D", "-."), "lp": ("v", (0, (5, 1))), "bnot": ("P", (0, (1, 3)))}
_STRATEGY_NAMES = {"brdf": "BRDF sampling", "map": "map sampling", "mis": "MIS",
                   "split": "sources + MIS"}


def _series(cells: list[dict], lobe: str) -> dict[tuple[str, str], dict[str, np.ndarray]]:
    """Per (strategy, point set) of ``lobe``: arrays over N sorted (n, predicted, measured,
    low, high), NaN where a value is missing."""
    out: dict[tuple[str, str], list[dict]] = {}
    for c in cells:
        if c["lobe"] == lobe:
            out.setdefault((c["strategy"], c["pointset"]), []).append(c)

    def arr(cs, key):
        return np.array([np.nan if c.get(key) is None else float(c[key]) for c in cs])
    series = {}
    for key, cs in out.items():
        cs = sorted(cs, key=lambda c: c["n"])
        series[key] = {"n": np.array([c["n"] for c in cs], dtype=float),
                       **{k: arr(cs, k) for k in ("predicted_rmse", "measured_rmse",
                                                  "measured_low", "measured_high")}}
    return series


def _panel(ax, series: dict, title: str, ylabel: str) -> None:
    """One lobe: error bars of the measured values, lines of the predicted ones."""
    for (strategy, pointset), s in series.items():
        colour = STRATEGY_COLOURS.get(strategy)
        marker, style = POINTSET_STYLES.get(pointset, ("x", "-"))
        ok = np.isfinite(s["measured_rmse"]) & (s["measured_rmse"] > 0)
        if ok.any():
            y = s["measured_rmse"][ok]
            err = np.vstack([np.clip(y - s["measured_low"][ok], 0, None),
                             np.clip(s["measured_high"][ok] - y, 0, None)])
            ax.errorbar(s["n"][ok], y, yerr=np.nan_to_num(err), fmt=marker, color=colour,
                        ms=4.5, capsize=2.5, lw=1.0, mfc="none" if pointset == "random" else colour)
        ok = np.isfinite(s["predicted_rmse"]) & (s["predicted_rmse"] > 0)
        if ok.any():
            ax.plot(s["n"][ok], s["predicted_rmse"][ok], linestyle=style, color=colour, lw=1.2)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ns = sorted({float(n) for s in series.values() for n in s["n"]})
    if ns:
        ax.set_xticks(ns, [f"{n:g}" for n in ns])
        ax.xaxis.set_minor_locator(plt_ticker().NullLocator())
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("number of samples N")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)


def plt_ticker():
    """``matplotlib.ticker`` (imported when drawing)."""
    import matplotlib.ticker
    return matplotlib.ticker


def _legend(fig, strategies: list[str], pointsets: list[str]) -> None:
    """Two legends: the colours (strategies) and the marker/line styles (point sets)."""
    from matplotlib.lines import Line2D
    handles = [Line2D([], [], color=STRATEGY_COLOURS.get(s), lw=2,
                      label=_STRATEGY_NAMES.get(s, s)) for s in strategies]
    handles += [Line2D([], [], color="0.3", marker=POINTSET_STYLES.get(p, ("x", "-"))[0],
                       linestyle=POINTSET_STYLES.get(p, ("x", "-"))[1], label=p)
                for p in pointsets]
    handles += [Line2D([], [], color="0.3", marker="o", linestyle="none",
                       label="measured (95 % interval)"),
                Line2D([], [], color="0.3", linestyle="-", label="predicted")]
    fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 5), fontsize=7,
               bbox_to_anchor=(0.5, -0.02), frameon=False)


def plot_renderer(renderer: dict, path: str | Path) -> Path:
    """Write the figure of a ``renderer`` section (see the module docstring) to ``path``.

    Parameters
    ----------
    renderer : dict
        ``map``, ``map_size`` [W, H], ``scale``, ``config`` (``shininess``) and ``cells``.
    path : str or Path
        The PNG to write.

    Returns
    -------
    Path
        ``path``.
    """
    import matplotlib.pyplot as plt
    cells = renderer["cells"]
    lobes = list(dict.fromkeys(c["lobe"] for c in cells)) or ["(no cells)"]
    strategies = list(dict.fromkeys(c["strategy"] for c in cells))
    pointsets = list(dict.fromkeys(c["pointset"] for c in cells))
    fig, axes = plt.subplots(1, len(lobes), figsize=(5.4 * len(lobes), 4.6), squeeze=False)
    shin = renderer.get("config", {}).get("shininess", DEFAULT_SHININESS)
    for ax, lobe in zip(axes[0], lobes):
        title = f"glossy (n = {shin:g})" if lobe == "glossy" else lobe
        _panel(ax, _series(cells, lobe), title, f"RMSE over random axes ({renderer['scale']} scale)")
    _legend(fig, strategies, pointsets)
    w, h = renderer["map_size"]
    fig.suptitle(f"{renderer['map']} ({w}×{h}): renderer rules, measured RMSE (markers, 95 % "
                 "interval) and predicted (lines)", fontsize=9)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    return save_figure(fig, path)
