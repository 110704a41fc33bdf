"""Figures of ``envfit validate``: measured errors with the predicted curves overlaid.

* :func:`plot_quadrature` — the paper's Fig. 7 for one BRDF (equal weights | OSW): measured
  RMSE vs N per point set (markers) and prediction (a), the fitted factor times the
  worst-case error (dashed, same colour).
* :func:`plot_absolute` — one figure per BRDF: the absolute predictions divided by the
  measured RMSE vs N, one panel per (weighting, point set); in every panel (b) σ·wce,
  (b′) (σ′·wce′ over the degrees the map holds, with the lookup's transfer and the error of
  the map's mean) and (c) (the map's own power spectrum) each in its own colour, line style
  and marker (:data:`PREDICTOR_STYLES`), named in one legend; the ±20 % band shaded. Flat
  at 1 = the absolute prediction holds.
* :func:`plot_truncation` — the paper's Fig. 8: measured RMSE vs the cut-off degree L for
  SH / HSH truncation, predictions (a) dashed and (b) dotted; right axis: the QMC-equivalent
  N (morphed SF, equal weights) predicted (line) and measured (squares).
* :func:`plot_s_choice` — the shape residual of prediction (a) against s.

All take the JSON-ready result of :func:`envfit.validate._pipeline.run_validation` and write PNGs
atomically (:func:`envfit.plots._save.save_figure`). Axes that count are on whole numbers:
N at the sweep's values, L on integer ticks, the QMC-equivalent N as plain integers
(:mod:`envfit.plots._ticks`).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import matplotlib  # noqa: F401  (selects the Agg backend)
from ._save import save_figure
from ._ticks import count_log_axis, integer_axis

__all__ = ["plot_quadrature", "plot_absolute", "plot_truncation", "plot_s_choice", "plot_all",
           "PREDICTOR_STYLES"]

_LABELS = {"sf": "Spherical Fibonacci", "sobol": "Sobol (0,2)", "lp": "Larcher-Pillichshammer",
           "bnot": "BNOT", "random": "Random", "jitter": "Stratified jitter"}
_COLOURS = {"sf": "C0", "sobol": "C1", "lp": "C2", "bnot": "C3", "random": "C4", "jitter": "C5"}
#: result key → (label, colour, line style, marker) of each absolute prediction
PREDICTOR_STYLES = {
    "predicted_rmse": ("(b) σ·wce (Eq. 41)", "C0", "-", "o"),
    "predicted_rmse_refined": ("(b′) band-limited: σ′·wce′ to l = H−1, τ_l, + mean", "C3", "--", "s"),
    "predicted_rmse_spectral": ("(c) the map's own power per degree × the rule's error power", "C2", ":", "^"),
}


def _xy(x, y):
    x = np.asarray(x, dtype=float)
    y = np.asarray([np.nan if v is None else v for v in y], dtype=float)
    keep = np.isfinite(y) & (y > 0)
    return x[keep], y[keep]


def _brdf_title(result, brdf):
    if brdf == "glossy":
        return f"glossy (n = {result['config']['shininess']:g})"
    return brdf


def plot_quadrature(result: dict, path: str | Path, brdf: str) -> Path:
    """Fig. 7 for ``brdf``: measured RMSE (markers) and c·wce (dashed) vs N, one panel per weighting."""
    import matplotlib.pyplot as plt
    entries = [e for e in result["results"] if e["brdf"] == brdf]
    weights = list(dict.fromkeys(e["weights"] for e in entries))
    fig, axes = plt.subplots(1, len(weights), figsize=(5.2 * len(weights), 4.2), squeeze=False,
                             layout="constrained")
    const = result["agreement"]["shape_fit"]["constant"].get(brdf)
    for ax, w in zip(axes[0], weights):
        for e in (x for x in entries if x["weights"] == w):
            col = _COLOURS.get(e["pointset"], None)
            x, y = _xy(e["n"], e["measured_rmse"])
            ax.loglog(x, y, "o-", color=col, ms=4, lw=1.2, label=_LABELS.get(e["pointset"], e["pointset"]))
            x, y = _xy(e["n"], e.get("predicted_shape") or [])
            if x.size:
                ax.loglog(x, y, "--", color=col, lw=1.0, alpha=0.8)
        ax.set_title(f"{_brdf_title(result, brdf)}, {'equal weights' if w == 'equal' else 'OSW'}",
                     fontsize=9)
        ax.set_xlabel("number of samples N")
        count_log_axis(ax.xaxis, _ns(entries))
        ax.set_ylabel(f"RMSE over {result['axes']} axes ({result['scale']} scale)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7, loc="lower left")
    c_txt = "n/a" if const is None else f"{const:.3g}"
    fig.suptitle(f"{result['map']}: measured (markers) vs predicted c·wce (dashed), "
                 f"s = {result['s']:.3f}, c = {c_txt}", fontsize=9)
    return save_figure(fig, path)


def _ns(entries) -> list[int]:
    """The N values of a sweep (the ticks of its N axes)."""
    return sorted({int(n) for e in entries for n in e["n"]})


def _ratio_panel(ax, e: dict, tolerance: float) -> None:
    """predicted / measured RMSE vs N of every prediction of one rule ``e``."""
    ax.axhspan(1 - tolerance, 1 + tolerance, color="0.88", zorder=0)
    ax.axhline(1.0, color="k", lw=0.8)
    for key, (_, colour, style, marker) in PREDICTOR_STYLES.items():
        r = [None if (p is None or m is None or m <= 0) else p / m
             for p, m in zip(e.get(key) or [], e["measured_rmse"])]
        x, y = _xy(e["n"], r)
        if x.size:
            ax.semilogx(x, y, color=colour, linestyle=style, marker=marker, ms=4.5, lw=1.4,
                        mfc="none" if marker == "s" else colour)
    ax.set_xscale("log")
    ax.grid(True, which="major", alpha=0.3)


def plot_absolute(result: dict, path: str | Path, brdf: str, tolerance: float = 0.2) -> Path:
    """One BRDF: predicted/measured RMSE of (b), (b′) and (c) vs N, a panel per (weighting,
    point set) (module docstring)."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    entries = [e for e in result["results"] if e["brdf"] == brdf]
    weights = list(dict.fromkeys(e["weights"] for e in entries))
    pointsets = list(dict.fromkeys(e["pointset"] for e in entries))
    fig, axes = plt.subplots(len(weights), len(pointsets), squeeze=False, sharex=True, sharey=True,
                             figsize=(2.9 * len(pointsets) + 1.0, 2.6 * len(weights) + 1.4),
                             layout="constrained")
    for i, w in enumerate(weights):
        for j, ps in enumerate(pointsets):
            ax = axes[i][j]
            e = next((x for x in entries if x["weights"] == w and x["pointset"] == ps), None)
            if e is not None:
                _ratio_panel(ax, e, tolerance)
            ax.set_title(f"{_LABELS.get(ps, ps)}, {'equal weights' if w == 'equal' else 'OSW'}",
                         fontsize=8)
            if j == 0:
                ax.set_ylabel("predicted / measured RMSE")
            if i == len(weights) - 1:
                ax.set_xlabel("number of samples N")
    count_log_axis(axes[-1][0].xaxis, _ns(entries))
    handles = [Line2D([], [], color=c, linestyle=ls, marker=m, mfc="none" if m == "s" else c,
                      label=lab) for lab, c, ls, m in PREDICTOR_STYLES.values()]
    handles.append(Patch(color="0.88", label=f"±{tolerance:.0%}"))
    fig.legend(handles=handles, loc="outside lower center", ncol=2, fontsize=8, frameon=False)
    fig.suptitle(f"{result['map']}: absolute predictions, {_brdf_title(result, brdf)}; "
                 f"σ = {result['sigma']:.4g}, σ′ = {result.get('sigma_refined', float('nan')):.4g}, "
                 f"map degrees ≤ {_band(result)}", fontsize=9)
    return save_figure(fig, path)


def _band(result):
    for e in result["results"]:
        if e.get("band_lmax") is not None:
            return e["band_lmax"]
    return "H-1"


def plot_truncation(result: dict, path: str | Path) -> Path:
    """Fig. 8: measured RMSE vs L (markers), c·wce (dashed), σ·wce (dotted); QMC-equivalent N on the right."""
    import matplotlib.pyplot as plt
    curves = result["truncation"]
    ncols = min(2, len(curves))
    nrows = (len(curves) + ncols - 1) // ncols
    fig, axes = plt.subplots(nrows, ncols, figsize=(6.0 * ncols, 4.0 * nrows), squeeze=False)
    fig.subplots_adjust(wspace=0.45, hspace=0.35)
    flat = [ax for row in axes for ax in row]
    for ax in flat[len(curves):]:
        ax.set_visible(False)
    for k, (ax, t) in enumerate(zip(flat, curves)):
        L = np.asarray(t["L"], dtype=float)
        x, y = _xy(L, t["measured_rmse"])
        ax.semilogy(x, y, "o-", color="C3", ms=4, label="measured RMSE")
        x, y = _xy(L, t.get("predicted_shape") or [])
        if x.size:
            ax.semilogy(x, y, "--", color="C3", alpha=0.8, label="c·wce (a)")
        x, y = _xy(L, t.get("predicted_rmse") or [])
        if x.size:
            ax.semilogy(x, y, ":", color="k", label="σ·wce (b)")
        ax.set_xlabel("cut-off degree L")
        integer_axis(ax.xaxis)
        ax.set_ylabel("RMSE", color="C3")
        ax.set_title(f"{_brdf_title(result, t['brdf'])}, {t['basis'].upper()} "
                     f"({t['axes']} axes, {t['map_height']} rows)", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax2 = ax.twinx()
        x, y = _xy(L, t.get("qmc_equivalent_n") or [])
        if x.size:
            ax2.semilogy(x, y, "-", color="C0", lw=1.2, label="QMC-equivalent N (theory)")
        x, y = _xy(L, t.get("measured_qmc_equivalent_n") or [])
        if x.size:
            ax2.semilogy(x, y, "s", color="C0", ms=4, mfc="none", label="QMC-equivalent N (measured)")
        ax2.set_ylabel("equivalent N (SF, equal weights)", color="C0")
        count_log_axis(ax2.yaxis)
        if k == 0:
            h1, l1 = ax.get_legend_handles_labels()
            h2, l2 = ax2.get_legend_handles_labels()
            ax.legend(h1 + h2, l1 + l2, fontsize=7, loc="upper right")
    fig.suptitle(f"{result['map']}: Fourier truncation, s = {result['s']:.3f} "
                 "(red: RMSE, left axis; blue: QMC-equivalent N, right axis)", fontsize=9)
    return save_figure(fig, path)


def plot_s_choice(result: dict, path: str | Path) -> Path:
    """Shape residual (dex) of prediction (a) against s, per BRDF, the used s marked."""
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    for i, (b, v) in enumerate(result["agreement"]["s_choice"].items()):
        for suffix, style, extra in (("", "o-", "wce"), ("_bandlimited", "s--", "band-limited wce")):
            items = sorted((float(k), d["residual_dex"]) for k, d in
                           (v.get("residual_by_s" + suffix) or {}).items() if d["residual_dex"] is not None)
            if not items:
                continue
            s, r = zip(*items)
            ax.plot(s, r, style, color=f"C{i}", label=f"{_brdf_title(result, b)}, {extra}")
    ax.axvline(result["s"], color="k", lw=0.8, ls="--", label=f"used s = {result['s']:.3f}")
    ax.set_xlabel("Sobolev smoothness s of the prediction")
    ax.set_ylabel("shape residual (dex, RMS)")
    ax.set_title(f"{result['map']}: which s makes the predicted shapes match best", fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return save_figure(fig, path)


def plot_all(result: dict, folder: str | Path) -> dict[str, str]:
    """Every figure into ``folder``; returns ``{name: path}`` (names are the file names)."""
    folder = Path(folder)
    files: dict[str, str] = {}
    for b in dict.fromkeys(e["brdf"] for e in result["results"]):
        name = f"validate_quadrature_{b}.png"
        files[name] = str(plot_quadrature(result, folder / name, b))
    for b in dict.fromkeys(e["brdf"] for e in result["results"]):
        name = f"validate_absolute_{b}.png"
        files[name] = str(plot_absolute(result, folder / name, b))
    if result.get("truncation"):
        files["validate_truncation.png"] = str(plot_truncation(result, folder / "validate_truncation.png"))
    files["validate_s_choice.png"] = str(plot_s_choice(result, folder / "validate_s_choice.png"))
    return files
