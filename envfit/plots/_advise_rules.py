"""The figure every ``envfit advise --out DIR`` writes (``advise_rules.png``): what each rule
costs to reach the target.

:func:`plot_advise_rules` takes the dict of ``envfit advise``'s JSON
(:meth:`envfit.advisor._result.Advice.to_dict`: ``map``, ``map_size``, ``brdf``,
``shininess``, ``target_rmse`` and ``rows``, each with ``label``, ``method``, ``n``, ``L``,
``cost`` (None when not reached), ``searched_max``, ``reached``, ``recommendable``,
``predicted_rmse_used``, ``measured_rmse``) and draws one horizontal bar per rule, in the
table's order (cheapest first): its cost — N samples per shading point, or (L+1)² SH/HSH
coefficients — on a log axis, quadrature and truncation in two colours, the recommended
row outlined, a rule that does not reach the target hatched up to the largest N/L searched;
each bar is labelled with N or L, the predicted RMSE and, after ``--check``, the measured
one. Written atomically (:func:`envfit.plots._save.save_figure`); plain data only.
"""
from __future__ import annotations

from pathlib import Path

from . import matplotlib  # noqa: F401  (selects the Agg backend)
from ._save import save_figure
from ._ticks import count_log_axis

__all__ = ["plot_advise_rules"]

_COLOURS = {"quadrature": "C0", "sh": "C2", "hsh": "C4"}


def _searched_cost(r: dict) -> float:
    """The cost at the largest N or L searched (a rule that does not reach the target)."""
    m = r.get("searched_max") or 1
    return float(m if r["method"] == "quadrature" else (m + 1) ** 2)


def _text(r: dict) -> str:
    what = (f"N = {r['n']}" if r["method"] == "quadrature" else f"L = {r['L']}") if r["reached"] \
        else f"{'N' if r['method'] == 'quadrature' else 'L'} > {r.get('searched_max')}"
    pred = r.get("predicted_rmse_used")
    text = what + ("" if pred is None else f", predicted {pred:.3g}")
    if r.get("measured_rmse") is not None:
        text += f", measured {r['measured_rmse']:.3g}"
    return text


def plot_advise_rules(d: dict, path: str | Path) -> Path:
    """Write the rules' cost figure of the advise dict ``d`` (module docstring) to ``path``
    (PNG, atomic); returns the path."""
    import matplotlib.pyplot as plt
    rows = d["rows"]
    best = next((k for k, r in enumerate(rows) if r["reached"] and r.get("recommendable", True)),
                None)
    fig, ax = plt.subplots(figsize=(8.0, 1.2 + 0.38 * max(len(rows), 1)))
    for k, r in enumerate(rows):
        cost = float(r["cost"]) if r["reached"] else _searched_cost(r)
        ax.barh(k, cost, color=_COLOURS.get(r["method"], "0.5"), alpha=0.85 if r["reached"] else 0.3,
                hatch=None if r["reached"] else "//", edgecolor="k" if k == best else "none",
                lw=1.8 if k == best else 0)
        mark = ("  <- recommended" if k == best else
                "" if r.get("recommendable", True) else "  (not recommended)")
        ax.text(cost * 1.08, k, _text(r) + mark,
                va="center", fontsize=7)
    ax.set_yticks(range(len(rows)), [r["label"] for r in rows], fontsize=8)
    ax.invert_yaxis()
    ax.set_xscale("log")
    right = max([float(r["cost"]) if r["reached"] else _searched_cost(r) for r in rows] or [10.0])
    ax.set_xlim(0.8, right * 40)
    count_log_axis(ax.xaxis)
    ax.set_xlabel("cost: N samples per shading point, or (L+1)² SH/HSH coefficients")
    ax.grid(True, axis="x", which="both", alpha=0.25)
    w, h = (d.get("map_size") or [0, 0])[:2]
    lobe = "diffuse" if d.get("brdf") == "diffuse" else f"glossy n = {d.get('shininess'):g}"
    ax.set_title(f"{d.get('map', 'map')}: {w}x{h}, {lobe}; cost to reach RMSE "
                 f"{d['target_rmse']:.3g} ({d.get('scale', '')} scale; hatched: not reached)",
                 fontsize=9)
    return save_figure(fig, path)
