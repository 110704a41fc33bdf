"""Figures 1–5 of the paper and the BNOT check, drawn from :mod:`envfit.theory._figures` data;
the error spectrum of one rule (``envfit theory wce --out``) and Table 1's E(L) curves
(``envfit theory table1 --out``).

Every function takes the data object and a PNG path, saves the figure atomically and
returns the path. Captions (figure titles) state the parameters and whether the points
were morphed for the BRDF (importance sampling, Sec. 7.2).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from envfit.defaults import WEIGHTINGS

from . import matplotlib  # noqa: F401  (selects the Agg backend)
from ._save import save_figure
from ._ticks import count_log_axis, integer_axis

__all__ = ["plot_power_spectra", "plot_low_order_closeup", "plot_error_spectra",
           "plot_convergence", "plot_truncation", "plot_bnot", "plot_wce_spectrum", "plot_table1"]

_STYLE = {"sobol": ("C0", "o"), "bnot": ("C1", "s"), "lp": ("C2", "^"), "sf": ("C3", "v"),
          "random": ("C7", "x"), "jitter": ("C4", "D")}
_LABEL = {"sobol": "Sobol", "bnot": "BNOT", "lp": "LP", "sf": "SF", "random": "Random",
          "jitter": "SJ"}
_WEIGHTS = {"equal": "equal weights", "osw": "optimal weights (OSW)"}


def _morph_text(morphed: bool) -> str:
    return ("points morphed for the BRDF (importance sampling, Sec. 7.2)" if morphed
            else "points NOT morphed (uniform on the hemisphere)")


def _positive(x):
    """Values ≤ 0 are not drawable on a log axis: mask them."""
    x = np.asarray(x, dtype=np.float64)
    return np.where(x > 0, x, np.nan)


def _semilogy_spectrum(ax, l, y, ps, **kw):
    c, m = _STYLE.get(ps, ("k", "."))
    ax.semilogy(l[1:], _positive(y[1:]), color=c, lw=0.8, label=_LABEL.get(ps, ps), **kw)


def _floor_log_axis(ax, decades: float = 14.0):
    """Keep rounding-level values (e.g. d_l² ≈ 1e-33 where b_l = c_l0 exactly) from
    stretching a log axis: show at most ``decades`` decades below the largest value."""
    ys = [np.nanmax(_positive(line.get_ydata())) for line in ax.get_lines()
          if np.isfinite(_positive(line.get_ydata())).any()]
    if ys:
        top = max(ys)
        lo, hi = ax.get_ylim()
        ax.set_ylim(max(lo, top * 10.0 ** -decades), hi)


def plot_power_spectra(data, path: str | Path) -> Path:
    """Fig. 1: d_l² (equal weights), C_l² (equal weights), C_l² (OSW); rows diffuse / glossy."""
    import matplotlib.pyplot as plt
    rows = data.brdfs
    fig, axes = plt.subplots(len(rows), 3, figsize=(14, 4.0 * len(rows)), squeeze=False,
                             sharex=True, layout="constrained")
    panels = (("equal", "d2", r"$d_l^2$, equal weights"), ("equal", "C2", r"$C_l^2$, equal weights"),
              ("osw", "C2", r"$C_l^2$, optimal weights (OSW)"))
    for i, brdf in enumerate(rows):
        for j, (wt, key, title) in enumerate(panels):
            ax = axes[i, j]
            if wt not in data.weightings:
                ax.set_visible(False)
                continue
            for ps in data.pointsets:
                r = data.get(brdf, wt, ps)
                _semilogy_spectrum(ax, r.l, getattr(r, key), ps)
            _floor_log_axis(ax)
            lab = "diffuse" if brdf == "diffuse" else f"glossy n = {data.shininess:g}"
            ax.set_title(f"({chr(97 + 3 * i + j)}) {lab}: {title}", fontsize=9)
            ax.grid(True, which="major", alpha=0.3)
            if i == len(rows) - 1:
                ax.set_xlabel("degree l")
        axes[i, 0].legend(fontsize=7, ncol=2)
    fig.suptitle(f"Fig. 1 — power spectra of quadrature rules, N = {data.n} (one realization, "
                 f"seed {data.seed}); {_morph_text(data.morphed)}", fontsize=10)
    return save_figure(fig, path)


def plot_low_order_closeup(closeup, n: int, morphed: bool, path: str | Path) -> Path:
    """Fig. 2: the first C_l² (l = 1…10), equal weights vs OSW, on one shared linear axis."""
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True, layout="constrained")
    for ax, (wt, vals) in zip(axes, (("equal", closeup.C2_equal), ("osw", closeup.C2_osw))):
        for ps, y in vals.items():
            c, m = _STYLE.get(ps, ("k", "."))
            ax.plot(closeup.l, y, color=c, marker=m, ms=4, lw=0.8, label=_LABEL.get(ps, ps))
        ax.set_title(f"({'a' if wt == 'equal' else 'b'}) {closeup.brdf}: $C_l^2$, {_WEIGHTS[wt]}",
                     fontsize=9)
        ax.set_xlabel("degree l")
        ax.set_xticks(closeup.l)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)
    red = ", ".join(f"{_LABEL.get(k, k)} ×{v:.2g}" for k, v in closeup.reduction.items())
    fig.suptitle(f"Fig. 2 — first {closeup.l.size} anisotropic PSCs, N = {n}; {_morph_text(morphed)}\n"
                 f"Σ C² (OSW) / Σ C² (equal): {red}", fontsize=9)
    return save_figure(fig, path)


def plot_error_spectra(data, path: str | Path) -> Path:
    """Fig. 3: e_l² = a_l (d_l² + C_l²), equal vs OSW; rows diffuse / glossy."""
    import matplotlib.pyplot as plt
    rows = data.brdfs
    cols = [w for w in WEIGHTINGS if w in data.weightings]
    fig, axes = plt.subplots(len(rows), len(cols), figsize=(5.5 * len(cols), 4.0 * len(rows)),
                             squeeze=False, sharex=True, layout="constrained")
    for i, brdf in enumerate(rows):
        ymin, ymax = np.inf, 0.0
        for j, wt in enumerate(cols):
            ax = axes[i, j]
            for ps in data.pointsets:
                r = data.get(brdf, wt, ps)
                _semilogy_spectrum(ax, r.l, r.e2, ps)
                y = _positive(r.e2[1:])
                ymin, ymax = min(ymin, np.nanmin(y)), max(ymax, np.nanmax(y))
            lab = "diffuse" if brdf == "diffuse" else f"glossy n = {data.shininess:g}"
            ax.set_title(f"({chr(97 + len(cols) * i + j)}) {lab}: $e_l^2$, {_WEIGHTS[wt]}", fontsize=9)
            ax.grid(True, which="major", alpha=0.3)
            if i == len(rows) - 1:
                ax.set_xlabel("degree l")
        for j in range(len(cols)):
            if np.isfinite(ymin) and ymax > 0:
                axes[i, j].set_ylim(ymin / 2, ymax * 2)
        axes[i, 0].legend(fontsize=7, ncol=2)
    fig.suptitle(f"Fig. 3 — error spectra $e_l^2 = a_l(d_l^2 + C_l^2)$, s = {data.s:g}, N = {data.n} "
                 f"(seed {data.seed}); {_morph_text(data.morphed)}", fontsize=10)
    return save_figure(fig, path)


def plot_convergence(data, path: str | Path) -> Path:
    """Fig. 4: worst-case error vs N, equal (left) / OSW (right), diffuse (top) / glossy
    (bottom); fitted slopes in the legends. Raw values (the paper scaled Random by 0.5)."""
    import matplotlib.pyplot as plt
    rows, cols = data.brdfs, data.weightings
    fig, axes = plt.subplots(len(rows), len(cols), figsize=(5.5 * len(cols), 4.2 * len(rows)),
                             squeeze=False,
                             layout="constrained")
    lo, hi = data.fit_range
    for i, brdf in enumerate(rows):
        for j, wt in enumerate(cols):
            ax = axes[i, j]
            for ps in data.pointsets:
                c, m = _STYLE.get(ps, ("k", "."))
                k = data.slopes[(brdf, wt, ps)]
                ax.loglog(data.ns, data.wce[(brdf, wt, ps)], color=c, marker=m, ms=4, lw=0.9,
                          label=f"{_LABEL.get(ps, ps)}  $N^{{{k:.2f}}}$")
            lab = "diffuse" if brdf == "diffuse" else f"glossy n = {data.shininess:g}"
            ax.set_title(f"({chr(97 + len(cols) * i + j)}) {lab}, {_WEIGHTS[wt]}", fontsize=9)
            ax.set_xlabel("number of samples N")
            count_log_axis(ax.xaxis, data.ns, fontsize=7)
            ax.set_ylabel("worst-case error (Eq. 41)")
            ax.grid(True, which="major", alpha=0.3)
            ax.legend(fontsize=7, title=f"slope fitted over N = {lo:g}…{hi:g}", title_fontsize=7)
    reps = ("one realization" if data.realizations == 1
            else f"RMS over {data.realizations} realizations")
    fig.suptitle(f"Fig. 4 — worst-case error vs N, s = {data.s:g} ({reps} of the stochastic sets, "
                 f"seed {data.seed}; no rescaling of Random); {_morph_text(data.morphed)}",
                 fontsize=10)
    return save_figure(fig, path)


def plot_truncation(data, path: str | Path) -> Path:
    """Fig. 5: E(L) (left axis, red) and the QMC-equivalent N (right axis, blue) per case."""
    import matplotlib.pyplot as plt
    cases = list(data.wce)
    fig, axes = plt.subplots(1, len(cases), figsize=(5.2 * len(cases), 4.2), squeeze=False,
                             layout="constrained")
    titles = {"diffuse-sh": "diffuse, SH", "glossy-sh": f"glossy n = {data.shininess:g}, SH",
              "glossy-hsh": f"glossy n = {data.shininess:g}, HSH"}
    for j, case in enumerate(cases):
        ax = axes[0, j]
        ax.semilogy(data.L, _positive(data.wce[case]), "o-", color="C3", ms=3, label="E(L)")
        ax.set_xlabel("cut-off degree L")
        integer_axis(ax.xaxis)
        ax.set_ylabel("worst-case error E(L)", color="C3")
        ax.tick_params(axis="y", colors="C3")
        ax.grid(True, which="major", alpha=0.3)
        ax2 = ax.twinx()
        ax2.semilogy(data.L, data.qmc_points[case], "s-", color="C0", ms=3,
                     label="QMC-equivalent N")
        ext = data.qmc_points_extrapolated[case]
        if np.isfinite(ext).any():
            # join the extrapolated part to the last tabulated point
            q = data.qmc_points[case]
            last = np.nonzero(np.isfinite(q))[0]
            xs, ys = data.L[np.isfinite(ext)], ext[np.isfinite(ext)]
            if last.size:
                xs, ys = np.r_[data.L[last[-1]], xs], np.r_[q[last[-1]], ys]
            ax2.semilogy(xs, ys, "s--", color="C0", ms=3, mfc="none", alpha=0.7,
                         label="extrapolated (power law)")
        ax2.set_ylabel("QMC points N with the same E", color="C0")
        ax2.tick_params(axis="y", colors="C0")
        ax.set_title(f"({chr(97 + j)}) {titles.get(case, case)}", fontsize=9)
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, fontsize=7, loc="center left", framealpha=0.8)
    nmax = max(int(v[0].max()) for v in data.qmc_curve.values())
    fig.suptitle(f"Fig. 5 — truncation error vs cut-off L (s = {data.s:g}); QMC: spherical Fibonacci, "
                 f"equal weights, {_morph_text(data.morphed)}; tabulated to N = {nmax}", fontsize=9)
    return save_figure(fig, path)


def plot_bnot(data, path: str | Path) -> Path:
    """BNOT vs random on the unit square: the two point sets and their radial power spectra."""
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), gridspec_kw={"width_ratios": [1, 1, 1.6]},
                             layout="constrained")
    for ax, pts, name, d in ((axes[0], data.bnot_points, "BNOT", data.diagnostics_bnot),
                             (axes[1], data.random_points, "random", data.diagnostics_random)):
        ax.scatter(pts[:, 0], pts[:, 1], s=4, color="k")
        ax.set_xlim(0, 1)
        ax.set_ylim(0, 1)
        ax.set_aspect("equal")
        ax.set_title(f"{name}, N = {data.n}\nmax |N·area − 1| = {d.max_relative_area_error:.1e}, "
                     f"centroid residual {d.centroid_residual:.3g}", fontsize=8)
    ax = axes[2]
    ax.plot(data.radius, data.power_random, color="C7", lw=0.9, label="random")
    ax.plot(data.radius, data.power_bnot, color="C1", lw=1.2, label="BNOT")
    ax.axhline(1.0, color="k", lw=0.6, ls=":")
    ax.axvline(data.low_band, color="k", lw=0.6, ls="--",
               label=f"|k| < √N/2: mean P = {data.low_power_bnot:.3g} (BNOT), "
                     f"{data.low_power_random:.3g} (random)")
    ax.set_xlabel("frequency |k|")
    ax.set_ylabel("radially averaged power P(|k|)")
    ax.set_yscale("log")
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=7)
    fig.suptitle(f"BNOT check on the unit square (before the Lambert lift; seed {data.seed})",
                 fontsize=10)
    return save_figure(fig, path)


def plot_wce_spectrum(sp, path: str | Path, title: str) -> Path:
    r"""``envfit theory wce --out``: the rule's power spectra :math:`d_l^2`, :math:`C_l^2` and
    its error spectrum :math:`e_l^2 = a_l(d_l^2 + C_l^2)` (Eq. 42) against l (left), and the
    partial worst-case error :math:`\sqrt{\sum_{k\le l} e_k^2}` rising to the closed form
    E of Eq. 41 (right; the gap is the tail beyond lmax)."""
    import matplotlib.pyplot as plt
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    l = np.asarray(sp.l)
    for y, style, lab in ((sp.d2, "C0", r"$d_l^2$ (zonal)"), (sp.C2, "C1", r"$C_l^2$ (anisotropic)"),
                          (sp.e2, "k", r"$e_l^2 = a_l(d_l^2 + C_l^2)$")):
        ax.semilogy(l[1:], _positive(np.asarray(y)[1:]), color=style, lw=0.9, label=lab)
    _floor_log_axis(ax)
    ax.set_xlabel("degree l")
    ax.set_ylabel("power")
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=8)
    ax2.plot(l, np.sqrt(np.cumsum(sp.e2)), color="k", lw=1.2, label=r"$\sqrt{\sum_{k \leq l}\, e_k^2}$")
    ax2.axhline(sp.wce, color="C3", ls="--", lw=1.0, label=f"E (Eq. 41) = {sp.wce:.4g}")
    ax2.set_xlabel("degree l")
    ax2.set_ylabel("worst-case error summed to l")
    ax2.set_ylim(bottom=0)
    ax2.grid(True, alpha=0.3)
    ax2.legend(fontsize=8, loc="lower right")
    fig.suptitle(title, fontsize=9)
    return save_figure(fig, path)


def plot_table1(table, path: str | Path) -> Path:
    """``envfit theory table1 --out``: E(L) of every case (Eqs. 51–52) against the cut-off
    L, the target and its paper's reading (target × (1 + rtol)) as horizontal lines, each
    case's strict L (filled) and paper's-reading L (open) marked; L on integer ticks."""
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.5, 4.3))
    for k, r in enumerate(table.rows):
        e = np.asarray(r.wce_by_L, dtype=float)
        line, = ax.semilogy(np.arange(e.size), _positive(e), "o-", ms=3, lw=1.0, color=f"C{k}",
                            label=f"{r.case}: L = {r.L} (strict), {r.L_paper_reading} (reading)")
        ax.plot([r.L], [e[r.L]], "o", ms=8, color=line.get_color())
        ax.plot([r.L_paper_reading], [e[r.L_paper_reading]], "o", ms=11, mfc="none",
                color=line.get_color())
    ax.axhline(table.target, color="k", lw=0.9, label=f"target E = {table.target:g}")
    ax.axhline(table.target * (1 + table.rtol_paper_reading), color="k", lw=0.8, ls=":",
               label=f"paper's reading: {1 + table.rtol_paper_reading:g} x target")
    integer_axis(ax.xaxis)
    ax.set_xlabel("cut-off degree L")
    ax.set_ylabel("worst-case truncation error E(L)")
    ax.set_title(f"Table 1: s = {table.s:g}, glossy n = {table.shininess:g}", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    return save_figure(fig, path)
