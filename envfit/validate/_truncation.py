r"""The truncation part of ``envfit validate`` (Fig. 8): SH truncation at degree L on the
full map and all axes, HSH truncation on the map downscaled to ``hsh_max_height`` rows and
the first ``hsh_axes`` axes, each curve a stored cell with its worst-case error E(L)
(Eqs. 51–52), the band-limited E′(L) of prediction (b′), and the QMC-equivalent N."""
from __future__ import annotations

import math
import time
from typing import Sequence

import numpy as np

from envfit.base import progress_bar
from envfit.predict import PredictionContext, QuadratureRule, predict
from envfit.shading import hsh_truncation_curve, rmse_over_axes, sh_truncation_curve
from envfit.shading import shading_integral, weight_function
from envfit.shading import sh_truncation_curve_transfer
from envfit.theory import TheoryParameterError
from envfit.theory import equivalent_qmc_points, truncation_error_curve

__all__ = ["truncation_curves", "TRUNCATION_PREDICTIONS", "qmc_equivalents"]

#: what a stored truncation cell's refined prediction means (a cell with another is redone)
TRUNCATION_REFINED_MODEL = "band-limited fit; SH weighted by the lookup transfer"
#: the predictors that apply to a truncation curve and the key of their RMSE: (c) needs the
#: rule's error power per degree, which a curve does not keep
TRUNCATION_PREDICTIONS = {"plain": "predicted_rmse", "bandlimited": "predicted_rmse_refined"}


def _bandlimited_curve(wf, ctx: PredictionContext, Ls: list[int], basis: str,
                       band_l: int) -> list[float | None]:
    """E′(L) of (b′) for the curve's L on a map of band limit ``band_l``."""
    if band_l > max(Ls) and basis == "sh":
        # SH truncation errs on degrees l > L of the interpolant: weighted by τ_l
        bc = sh_truncation_curve_transfer(wf, ctx.s_bandlimited, max(Ls), band_l, ctx.transfer)
        return [float(bc[L]) for L in Ls]
    if band_l > max(Ls):
        # HSH (on the downscaled map) is not diagonal in l: no transfer (its error lives at
        # degrees <= ~20, where τ > 0.97 on 128 rows)
        bc = truncation_error_curve(wf, ctx.s_bandlimited, max(Ls), basis, lmax=band_l)
        return [float(bc[L]) for L in Ls]
    return [None] * len(Ls)


def _measure_curve(run, ctx: PredictionContext, b: str, basis: str, Ls: list[int], hsh) -> dict:
    """One truncation cell: measured RMSE(L), E(L), E′(L), QMC-equivalent N. ``hsh`` is
    ``(map, axes, truth cache)`` of the HSH measurement."""
    cfg, t0 = run.cfg, time.perf_counter()
    wf = weight_function(b, cfg.shininess)
    if basis == "sh":
        est = sh_truncation_curve(run.scaled, run.axes, b, Ls, shininess=cfg.shininess)
        r = rmse_over_axes(est, run.truth(b))
        m_axes, height = run.axes.shape[0], run.scaled.height
    else:
        hsh_env, hsh_axes, hsh_truth = hsh
        if b not in hsh_truth:
            t1 = time.perf_counter()
            hsh_truth[b] = shading_integral(hsh_env, hsh_axes, b, cfg.shininess)
            run.timings["truth"] += time.perf_counter() - t1
        est = hsh_truncation_curve(hsh_env, hsh_axes, b, Ls, shininess=cfg.shininess)
        r = rmse_over_axes(est, hsh_truth[b])
        m_axes, height = hsh_axes.shape[0], hsh_env.height
    wce_curve = truncation_error_curve(wf, ctx.s, max(Ls), basis)
    wce = [float(wce_curve[L]) for L in Ls]
    band_l = height - 1
    wce_band = _bandlimited_curve(wf, ctx, Ls, basis, band_l)
    t_eq = time.perf_counter()
    equiv = qmc_equivalents(wce, wf, ctx.s, cfg.equivalent_nmax)
    run.timings["equivalents"] += time.perf_counter() - t_eq
    return {"brdf": b, "basis": basis, "L": Ls, "measured_rmse": np.atleast_1d(r.total).tolist(),
            "predicted_wce": wce, "predicted_wce_bandlimited": wce_band, "band_lmax": band_l,
            "qmc_equivalent_n": equiv, "axes": int(m_axes), "map_height": int(height),
            "s": ctx.s, "s_refined": ctx.s_bandlimited,
            "refined_model": TRUNCATION_REFINED_MODEL, "seconds": time.perf_counter() - t0}


def _is_current(cell: dict | None, Ls: list[int], ctx: PredictionContext) -> bool:
    return (cell is not None and cell.get("L") == Ls and abs(cell.get("s", -1) - ctx.s) <= 1e-12
            and abs(cell.get("s_refined", -1) - ctx.s_bandlimited) <= 1e-12
            and cell.get("refined_model") == TRUNCATION_REFINED_MODEL)


def _predict_curve(cell: dict, ctx: PredictionContext) -> dict:
    """The cell with each of :data:`TRUNCATION_PREDICTIONS` per L (a truncation keeps
    :math:`b_0` exactly: its rule has no weights, so (b′) has no mean term)."""
    cell = dict(cell)
    for name, key in TRUNCATION_PREDICTIONS.items():
        cell[key] = [predict(name, ctx, QuadratureRule(n=L, wce=w, wce_bandlimited=wb)).rmse
                     for L, w, wb in zip(cell["L"], cell["predicted_wce"],
                                         cell["predicted_wce_bandlimited"])]
    return cell


def truncation_curves(run, ctx: PredictionContext) -> list[dict]:
    """The SH / HSH truncation curves (Fig. 8) with their predictions and QMC equivalents.

    ``run`` is the pipeline's state (``cfg``, ``scaled``, ``axes``, ``truth(brdf)``,
    ``store``, ``quiet``, ``on_cell``, ``timings``); resumed cells are reused when their L,
    s, ŝ′ and refined model match.
    """
    cfg = run.cfg
    jobs = []
    for b in cfg.brdfs:
        jobs.append((b, "sh", list(cfg.sh_L)))
        jobs.append((b, "hsh", list(cfg.diffuse_hsh_L if b == "diffuse" else cfg.hsh_L)))
    hsh = (run.scaled.resized(min(cfg.hsh_max_height, run.scaled.height)),
           run.axes[:min(cfg.hsh_axes, run.axes.shape[0])], {})
    out = []
    bar = progress_bar(len(jobs), desc="validate: truncation", quiet=run.quiet, unit="curve")
    try:
        for b, basis, Ls in jobs:
            key = f"trunc_{b}_{basis}"
            cell = run.store.get(key)
            resumed = _is_current(cell, Ls, ctx)
            if not resumed:
                cell = _measure_curve(run, ctx, b, basis, Ls, hsh)
                run.store.put(key, cell)
            if run.on_cell:
                run.on_cell(key, resumed)
            out.append(_predict_curve(cell, ctx))
            bar.update(1)
    finally:
        bar.close()
    return out


def qmc_equivalents(wces: Sequence[float], wf, s: float, nmax: int) -> list[int | None]:
    """QMC-equivalent N (morphed SF, equal weights; :func:`envfit.theory._truncation.equivalent_qmc_points`)
    of each worst-case error; None for 0 or beyond ``nmax``. Equal targets are searched once,
    and once a target needs more than ``nmax`` points every smaller one is skipped."""
    found: dict[float, int | None] = {}
    beyond = 0.0                           # largest target known to need > nmax points
    out = []
    for v in wces:
        if v is None or not (v > 0 and math.isfinite(v)) or v <= beyond:
            out.append(None)
            continue
        if v not in found:
            try:
                found[v] = int(equivalent_qmc_points(v, wf, s, nmax=nmax))
            except TheoryParameterError:
                found[v] = None
                beyond = v
        out.append(found[v])
    return out
