"""The figure of ``envfit advise DIR --renderer NAME --out OUT``: the spp each map needs.

:func:`plot_advise_library` takes the library's JSON dict
(:meth:`envfit.batch._library_advise.LibraryAdvice.to_dict`: ``renderer``, ``sampler``,
``strategies``, ``maps`` — each with ``label``, ``spp``, ``reached``, ``searched_max`` and
``answers`` per strategy — and ``coverage``) and draws one point per map and strategy (log2
spp, the maps sorted by the recommended strategy's spp; a map that reached no spp is an open
triangle at its largest spp searched) and the coverage as horizontal lines: the spp that
meets the target on 50, 90 and 100 % of the maps. Written atomically
(:func:`envfit.plots._save.save_figure`); it imports nothing of the advisor (layering).
"""
from __future__ import annotations

from pathlib import Path

from . import matplotlib  # noqa: F401  (selects the Agg backend)
from ._advise import STRATEGY_COLOURS
from ._save import save_figure

__all__ = ["plot_advise_library"]


def _needs(m: dict) -> float:
    return m["spp"] if m["reached"] else float("inf")


def plot_advise_library(d: dict, path: str | Path) -> Path:
    """Write the library figure of ``d`` (module docstring) to ``path``; returns the path."""
    import matplotlib.pyplot as plt
    maps = sorted(d["maps"], key=_needs)
    fig, ax = plt.subplots(figsize=(max(8.5, min(18.5, 5.0 + 0.12 * len(maps))), 4.8))
    x = range(len(maps))
    for k, s in enumerate(d["strategies"]):
        colour = STRATEGY_COLOURS.get(s, f"C{k}")
        ans = [m["answers"][s] for m in maps]
        hit = [(i, a["spp"]) for i, a in zip(x, ans) if a["reached"]]
        miss = [(i, a["searched_max"]) for i, a in zip(x, ans) if not a["reached"]]
        ax.plot([i for i, _ in hit], [v for _, v in hit], "o", color=colour, ms=5,
                label=f"{s}" + (" (recommended)" if k == 0 else ""))
        if miss:
            ax.plot([i for i, _ in miss], [v for _, v in miss], "^", mfc="none", color=colour,
                    ms=6, label=f"{s}: none up to the largest spp searched")
    for c, style in zip(d["coverage"], ("--", "-.", ":")):
        if c["spp"] is not None:
            ax.axhline(c["spp"], color="k", lw=0.9, linestyle=style,
                       label=f"{c['fraction']:.0%} of the maps: {c['spp']} spp")
    ax.set_yscale("log", base=2)
    ax.set_xticks(list(x))
    ax.set_xticklabels([m["label"] for m in maps], rotation=60, ha="right",
                       fontsize=7 if len(maps) <= 40 else 4)
    ax.set_ylabel("spp that meets the map's target")
    ax.set_title(f"{len(maps)} maps: {d['renderer']}, sampler {d['sampler']}")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0),  # beside the
              borderaxespad=0.0)                                    # points, not on them
    ax.grid(True, axis="y", which="both", alpha=0.25)
    fig.tight_layout()
    return save_figure(fig, path)
