"""The figure of ``envfit validate MAP --renderer mitsuba3|cycles``: the rendered RMSE and the
predicted one against spp, one panel per sampler.

:func:`plot_rendered` takes the JSON of :meth:`envfit.validate._rendered.RenderValidation.to_dict`
(``map``, ``options``, ``rows``: ``sampler``, ``strategy``, ``spp_used``, ``measured_rmse``,
``low``, ``high``, ``predicted``) and draws, on log-log axes, the measured RMSE as markers
with the 95 % interval as error bars and the prediction as lines with a tick at each spp,
one colour per strategy
(the colours of ``envfit validate --renderer``'s figure). Written atomically
(:func:`envfit.plots._save.save_figure`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import matplotlib  # noqa: F401  (selects the Agg backend)
from ._renderer import STRATEGY_COLOURS, _legend, _panel
from ._save import save_figure

__all__ = ["plot_rendered"]


def _series(rows: list, sampler: str) -> dict:
    """Per (strategy, "random"): arrays over spp in the layout of ``_renderer._panel``."""
    out: dict = {}
    for r in sorted((r for r in rows if r["sampler"] == sampler), key=lambda r: r["spp_used"]):
        s = out.setdefault((r["strategy"], "random"), {k: [] for k in (
            "n", "predicted_rmse", "measured_rmse", "measured_low", "measured_high")})
        for key, val in (("n", r["spp_used"]), ("predicted_rmse", r["predicted"]),
                         ("measured_rmse", r["measured_rmse"]), ("measured_low", r["low"]),
                         ("measured_high", r["high"])):
            s[key].append(float(val))
    return {k: {name: np.array(v) for name, v in s.items()} for k, s in out.items()}


def plot_rendered(result: dict, path: str | Path) -> Path:
    """Write the figure of a rendered validation (``RenderValidation.to_dict()``) to ``path``
    (a PNG) and return ``path``."""
    import matplotlib.pyplot as plt
    rows, o = result["rows"], result["options"]
    samplers = list(dict.fromkeys(r["sampler"] for r in rows)) or ["(no cells)"]
    fig, axes = plt.subplots(1, len(samplers), figsize=(5.0 * len(samplers), 4.4),
                             squeeze=False)
    for ax, sampler in zip(axes[0], samplers):
        series = _series(rows, sampler)
        _panel(ax, series, sampler, "RMSE over the sphere's pixels")
        for (strategy, _), s in series.items():         # a tick: visible at a single spp
            ax.plot(s["n"], s["predicted_rmse"], marker="_", ms=14, mew=1.6,
                    linestyle="none", color=STRATEGY_COLOURS.get(strategy))
        ax.set_xlabel("samples per pixel (spp)")
    _legend(fig, list(dict.fromkeys(r["strategy"] for r in rows)), [])
    bsdf = o["brdf"] if o["alpha"] is None else f"{o['brdf']} alpha {o['alpha']:g}"
    fig.suptitle(f"{result['map']}: {o['renderer']} renders ({bsdf}), measured RMSE (markers, "
                 f"95 % interval) and envfit's prediction (lines); {result['inside']} of "
                 f"{result['cells']} inside", fontsize=9)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    return save_figure(fig, path)
