r"""Agreement between measured and predicted errors: log-log slopes, shape constants, rank
agreement, equivalent N, and the per-cell verdicts that ``report.md`` states.

:func:`agreement` is a handful of named steps, each a public function on the ``results``
entries of :func:`envfit.validate._pipeline.run_validation`: :func:`slope_statistics`,
:func:`shape_statistics` (prediction (a) and the choice of s), :func:`rank_statistics`,
:func:`absolute_statistics` (every predictor of a quadrature rule in :data:`envfit.predict.PREDICTORS`),
:func:`truncation_statistics` and :func:`acceptance_summary`.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from envfit.base import ParameterError
from envfit.predict import QuadratureRule, predictors_for

from envfit.validate._keys import prediction_keys, variant


#: N range of the fitted convergence slopes
SLOPE_RANGE = (64, 4096)


#: relative tolerance of prediction (b) in the acceptance summary
ABSOLUTE_TOLERANCE = 0.2


#: tolerance on |slope measured − slope predicted| in the acceptance summary
SLOPE_TOLERANCE = 0.1

#: point sets whose slopes are part of the acceptance check
SLOPE_CHECK_POINTSETS = ("sf", "random")


def loglog_slope(n, y, n_range: tuple[float, float] | None = SLOPE_RANGE) -> float | None:
    r"""Least-squares slope of :math:`\log y` against :math:`\log N` (``np.polyfit``, degree 1).

    Only N within ``n_range`` (inclusive) and finite positive y are used; None when fewer
    than two remain. A rate :math:`N^{-k}` has slope −k.

    >>> n = np.array([64, 128, 256]); round(loglog_slope(n, 3.0 * n ** -0.75), 12)
    -0.75
    """
    n = np.asarray(n, dtype=np.float64)
    y = np.asarray([np.nan if v is None else v for v in y], dtype=np.float64)
    keep = np.isfinite(y) & (y > 0) & (n > 0)
    if n_range is not None:
        keep &= (n >= n_range[0]) & (n <= n_range[1])
    if keep.sum() < 2:
        return None
    return float(np.polyfit(np.log(n[keep]), np.log(y[keep]), 1)[0])


def _log_pairs(measured, predicted) -> tuple[np.ndarray, np.ndarray]:
    m = np.asarray([np.nan if v is None else v for v in np.ravel(measured)], dtype=np.float64)
    p = np.asarray([np.nan if v is None else v for v in np.ravel(predicted)], dtype=np.float64)
    if m.shape != p.shape:
        raise ParameterError(f"measured and predicted differ in size: {m.shape} vs {p.shape}")
    keep = np.isfinite(m) & np.isfinite(p) & (m > 0) & (p > 0)
    return np.log(m[keep]), np.log(p[keep])


def shape_constant(measured, predicted) -> float | None:
    r"""The factor c of prediction (a): :math:`\log c = \mathrm{mean}(\log R_{meas} - \log E)`.

    The least-squares fit of :math:`\log R_{meas} \approx \log c + \log E` over all given
    pairs (finite, positive), i.e. the geometric mean of the ratios. None if no pair.

    >>> shape_constant([2.0, 8.0], [1.0, 1.0])
    4.0
    """
    lm, lp = _log_pairs(measured, predicted)
    if lm.size == 0:
        return None
    return float(np.exp(np.mean(lm - lp)))


def shape_residual(measured, predicted) -> float | None:
    r"""RMS of :math:`\log_{10}R_{meas} - \log_{10}E - \log_{10}c` (dex) with c from
    :func:`shape_constant`: 0 when measured ∝ predicted; 0.1 ≈ a typical factor 1.26.

    >>> round(shape_residual([1.0, 100.0], [1.0, 1.0]), 12)
    1.0
    """
    lm, lp = _log_pairs(measured, predicted)
    if lm.size == 0:
        return None
    d = (lm - lp) / math.log(10.0)
    return float(np.sqrt(np.mean((d - d.mean()) ** 2)))


def rank_agreement(names: Sequence[str], measured_levels, predicted_levels) -> dict:
    r"""Rank order of point sets, measured vs predicted, and Kendall's τ (``scipy.stats.kendalltau``).

    Lower level = better. Returns ``{"measured_order", "predicted_order", "kendall_tau",
    "p_value"}`` (τ = 1: the same order; −1: reversed; None with fewer than two sets).

    >>> rank_agreement(["a", "b", "c"], [1, 2, 3], [10, 20, 30])["kendall_tau"]
    1.0
    """
    names = list(names)
    m = np.asarray(measured_levels, dtype=np.float64)
    p = np.asarray(predicted_levels, dtype=np.float64)
    keep = np.isfinite(m) & np.isfinite(p)
    names_k = [nm for nm, k in zip(names, keep) if k]
    m, p = m[keep], p[keep]
    out = {"measured_order": [names_k[i] for i in np.argsort(m, kind="stable")],
           "predicted_order": [names_k[i] for i in np.argsort(p, kind="stable")],
           "kendall_tau": None, "p_value": None}
    if len(names_k) >= 2:
        from scipy import stats  # local: scipy.stats costs ~1 s to import
        res = stats.kendalltau(m, p)
        tau = float(res.statistic) if hasattr(res, "statistic") else float(res[0])
        pv = float(res.pvalue) if hasattr(res, "pvalue") else float(res[1])
        out["kendall_tau"] = None if not np.isfinite(tau) else tau
        out["p_value"] = None if not np.isfinite(pv) else pv
    return out


def measured_equivalent_n(n_values, rmse_curve, target: float) -> float | None:
    r"""N at which a measured RMSE(N) curve reaches ``target``, by linear interpolation in
    log-log between the bracketing measured points; None outside the measured range.

    >>> round(measured_equivalent_n([100, 400], [0.1, 0.05], 0.0707106781), 3)
    200.0
    """
    n = np.asarray(n_values, dtype=np.float64)
    y = np.asarray([np.nan if v is None else v for v in rmse_curve], dtype=np.float64)
    if target is None or not np.isfinite(target) or target <= 0:
        return None
    keep = np.isfinite(y) & (y > 0)
    n, y = n[keep], y[keep]
    if n.size < 2:
        return None
    lt = math.log(target)
    ly, ln = np.log(y), np.log(n)
    for i in range(n.size - 1):
        lo, hi = sorted((ly[i], ly[i + 1]))
        if lo <= lt <= hi and ly[i] != ly[i + 1]:
            t = (lt - ly[i]) / (ly[i + 1] - ly[i])
            return float(math.exp(ln[i] + t * (ln[i + 1] - ln[i])))
    return None


def _effective_range(results: list[dict], slope_range: tuple[int, int]) -> tuple[int, int]:
    """``slope_range`` clipped to the N that were run."""
    all_n = [n for e in results for n in e["n"]]
    lo = max(slope_range[0], min(all_n)) if all_n else slope_range[0]
    hi = min(slope_range[1], max(all_n)) if all_n else slope_range[1]
    return lo, hi


def _rule_id(e: dict) -> dict:
    return {"brdf": e["brdf"], "pointset": e["pointset"], "weights": e["weights"]}


def slope_statistics(results: list[dict], lo: int, hi: int,
                     slope_tolerance: float = SLOPE_TOLERANCE) -> tuple[list, list]:
    """Per rule: the measured and predicted (wce; (b′)) log-log slopes over N ∈ [lo, hi]
    and their differences; and the ratio measured/wce per N with its spread max/min over
    [lo, hi] (1 = the theory's shape holds exactly). Returns ``(slopes, ratios)``."""
    slopes, ratios = [], []
    for e in results:
        sm = loglog_slope(e["n"], e["measured_rmse"], (lo, hi))
        sp = loglog_slope(e["n"], e["predicted_wce"], (lo, hi))
        diff = None if (sm is None or sp is None) else sm - sp
        sb = loglog_slope(e["n"], e["predicted_rmse_refined"], (lo, hi)) \
            if e.get("predicted_rmse_refined") is not None else None
        diff_b = None if (sm is None or sb is None) else sm - sb
        slopes.append({**_rule_id(e), "measured": sm, "predicted": sp, "difference": diff,
                       "within_tolerance": None if diff is None else bool(abs(diff) <= slope_tolerance),
                       "predicted_refined": sb, "difference_refined": diff_b})
        ratio = [None if (m is None or p is None or p <= 0) else m / p
                 for m, p in zip(e["measured_rmse"], e["predicted_wce"])]
        in_rng = [r for n, r in zip(e["n"], ratio) if r is not None and lo <= n <= hi and r > 0]
        ratios.append({**_rule_id(e), "n": e["n"], "measured_over_wce": ratio,
                       "spread": (max(in_rng) / min(in_rng)) if len(in_rng) >= 2 else None})
    return slopes, ratios


def shape_statistics(results: list[dict], s_used: float) -> tuple[dict, dict]:
    """Prediction (a) per BRDF: the factor c (:func:`shape_constant` over every rule and N)
    and the residual (:func:`shape_residual`); and per candidate s (``wce_by_s``, and the
    band-limited ``wce_bandlimited_by_s``) the residual, with the best s. Returns
    ``(shape_fit, s_choice)``."""
    shape_fit = {"method": "per BRDF, log c = mean over every point set, weighting and N of "
                           "(log measured RMSE - log wce); residual = RMS of the remaining "
                           "log10 differences",
                 "constant": {}, "residual_dex": {}}
    s_choice = {}
    for b in dict.fromkeys(e["brdf"] for e in results):
        es = [e for e in results if e["brdf"] == b]
        meas = [m for e in es for m in e["measured_rmse"]]
        pred = [p for e in es for p in e["predicted_wce"]]
        shape_fit["constant"][b] = shape_constant(meas, pred)
        shape_fit["residual_dex"][b] = shape_residual(meas, pred)
        entry = {"used_s": s_used}
        for suffix, field_ in (("", "wce_by_s"), ("_bandlimited", "wce_bandlimited_by_s")):
            choice = {}
            s_keys = sorted(set().union(*[set(e.get(field_) or {}) for e in es])) if es else []
            for sk in s_keys:
                pred_s = [p for e in es for p in (e.get(field_) or {}).get(sk, [None] * len(e["n"]))]
                choice[sk] = {"residual_dex": shape_residual(meas, pred_s),
                              "constant": shape_constant(meas, pred_s)}
            valid = {k: v["residual_dex"] for k, v in choice.items() if v["residual_dex"] is not None}
            best = min(valid, key=valid.get) if valid else None
            entry["residual_by_s" + suffix] = choice
            entry["best_s" + suffix] = None if best is None else float(best)
        s_choice[b] = entry
    return shape_fit, s_choice


def _geometric_level(e: dict, lo: int, hi: int, which: int) -> float:
    """Geometric mean over N ∈ [lo, hi] of the measured (``which`` 0) or predicted (1) values,
    over the N where both are positive; NaN if none."""
    pairs = [(m, p) for n, m, p in zip(e["n"], e["measured_rmse"], e["predicted_wce"])
             if lo <= n <= hi and m is not None and p is not None and m > 0 and p > 0]
    vals = [pair[which] for pair in pairs]
    return float(np.exp(np.mean(np.log(vals)))) if vals else np.nan


def rank_statistics(results: list[dict], lo: int, hi: int) -> list[dict]:
    """Per (BRDF, weighting) with at least two point sets: the measured and predicted
    (wce) orders of the point sets by their geometric-mean level over N ∈ [lo, hi]
    (:func:`rank_agreement`, Kendall's τ) and τ per N."""
    out = []
    for b in dict.fromkeys(e["brdf"] for e in results):
        for w in dict.fromkeys(e["weights"] for e in results if e["brdf"] == b):
            es = [e for e in results if e["brdf"] == b and e["weights"] == w]
            if len(es) < 2:
                continue
            names = [e["pointset"] for e in es]
            ml = [_geometric_level(e, lo, hi, 0) for e in es]
            pl = [_geometric_level(e, lo, hi, 1) for e in es]
            rk = rank_agreement(names, ml, pl)
            per_n = {}
            for i, n in enumerate(es[0]["n"]):
                mv = [np.nan if e["measured_rmse"][i] is None else e["measured_rmse"][i] for e in es]
                pv = [np.nan if e["predicted_wce"][i] is None else e["predicted_wce"][i] for e in es]
                per_n[str(n)] = rank_agreement(names, mv, pv)["kendall_tau"]
            out.append({"brdf": b, "weights": w, **rk, "measured_level": ml,
                        "predicted_level": pl, "pointsets": names, "tau_per_n": per_n})
    return out


def _ratio_summary(ratios, tolerance: float) -> dict | None:
    a = np.asarray(ratios, dtype=np.float64)
    return None if a.size == 0 else {
        "cells": int(a.size), "median_ratio": float(np.median(a)), "min_ratio": float(a.min()),
        "max_ratio": float(a.max()), "fraction_within": float(np.mean(np.abs(a - 1.0) <= tolerance))}


def _absolute_one(results: list[dict], name: str, lo: int, hi: int, tolerance: float) -> dict:
    """:func:`absolute_statistics` of one predictor, keys with its :func:`variant` suffix."""
    keys, v = prediction_keys(name), variant(name)
    scatter_key = keys.get("relative_sd")
    per_rule, all_ratio, in_range_ratio, in_range_band = [], [], [], []
    for e in results:
        none = [None] * len(e["n"])
        ratio = [None if (m is None or p is None or m <= 0) else p / m
                 for m, p in zip(e["measured_rmse"], e.get(keys["rmse"]) or none)]
        # the spread one map is expected to show about the model (a predictor with a
        # scatter) and the Monte Carlo error of M axes: 2 standard deviations, combined
        sd = none
        if scatter_key:
            sd = [None if sc is None else math.hypot(sc, se or 0.0)
                  for sc, se in zip(e.get(scatter_key) or none, e.get("measured_rel_se") or none)]
        per_rule.append({**_rule_id(e), "n": e["n"], "predicted_over_measured": ratio,
                         **({"expected_relative_sd": sd} if scatter_key else {})})
        all_ratio += [r for r in ratio if r is not None and r > 0]
        for n, r, d in zip(e["n"], ratio, sd):
            if r is not None and r > 0 and lo <= n <= hi:
                in_range_ratio.append(r)
                in_range_band.append(max(tolerance, 2.0 * d) if d is not None else tolerance)
    out = {"per_rule" + v: per_rule, "all" + v: _ratio_summary(all_ratio, tolerance),
           "slope_range" + v: _ratio_summary(in_range_ratio, tolerance)}
    if scatter_key and out["slope_range" + v] is not None:
        # |ratio - 1| within the tolerance or within 2 expected standard deviations
        out["slope_range" + v]["fraction_within_expected_scatter"] = float(np.mean(
            np.abs(np.asarray(in_range_ratio) - 1.0) <= np.asarray(in_range_band)))
    return out


def absolute_statistics(results: list[dict], lo: int, hi: int,
                        tolerance: float = ABSOLUTE_TOLERANCE) -> dict:
    """Every predictor of a quadrature rule (:func:`envfit.predict.predictors_for`) against
    the measured RMSE: per
    rule the ratio predicted/measured per N (with the expected one-map spread where the
    predictor gives one); over all cells and over N ∈ [lo, hi] the median, extremes and
    fraction within ``tolerance``. Keys carry the predictor's suffix
    (:func:`envfit.validate._keys.variant`: ``per_rule``, ``slope_range_refined``, …)."""
    out = {"tolerance": tolerance}
    for name in predictors_for(QuadratureRule):
        out.update(_absolute_one(results, name, lo, hi, tolerance))
    return out


def truncation_statistics(truncation: list[dict] | None) -> list[dict]:
    """Per truncation curve: predicted/measured for (b) and (b′) per L, and the shape
    residual of the wce curve."""
    out = []
    for t in truncation or []:
        rp = [None if (m is None or p is None or m <= 0 or p <= 0) else p / m
              for m, p in zip(t["measured_rmse"], t.get("predicted_rmse", []))]
        rb = [None if (m is None or p is None or m <= 0 or p <= 0) else p / m
              for m, p in zip(t["measured_rmse"],
                              t.get("predicted_rmse_refined") or [None] * len(t["L"]))]
        out.append({"brdf": t["brdf"], "basis": t["basis"], "L": t["L"],
                    "predicted_over_measured": rp, "predicted_refined_over_measured": rb,
                    "shape_residual_dex": shape_residual(t["measured_rmse"], t["predicted_wce"])})
    return out


def acceptance_summary(slopes: list[dict], rank: list[dict], absolute: dict,
                       slope_tolerance: float = SLOPE_TOLERANCE) -> dict:
    """The issue's checks: the slopes of :data:`SLOPE_CHECK_POINTSETS` within
    ``slope_tolerance`` (for the wce and for (b′)), identical rank orders (τ = 1), (b) and
    (b′) within the absolute tolerance over the slope range, the median ratio of (c)."""
    chk = [s for s in slopes if s["pointset"] in SLOPE_CHECK_POINTSETS and s["difference"] is not None]
    taus = [r["kendall_tau"] for r in rank if r["kendall_tau"] is not None]
    plain = absolute["slope_range" + variant("plain")]
    band = absolute["slope_range" + variant("bandlimited")]
    spectral = absolute["slope_range" + variant("spectral")]
    return {
        "slope_tolerance": slope_tolerance,
        "slopes_checked": len(chk),
        "slopes_within": sum(1 for s in chk if s["within_tolerance"]),
        "max_abs_slope_difference": max((abs(s["difference"]) for s in chk), default=None),
        "slopes_ok": bool(chk) and all(s["within_tolerance"] for s in chk),
        "rank_ok": bool(taus) and all(t >= 1.0 - 1e-12 for t in taus),
        "min_kendall_tau": min(taus) if taus else None,
        "absolute_ok": None if plain is None else bool(plain["fraction_within"] == 1.0),
        "max_abs_slope_difference_refined": max(
            (abs(s["difference_refined"]) for s in chk if s["difference_refined"] is not None),
            default=None),
        "slopes_ok_refined": bool(chk) and all(
            s["difference_refined"] is not None and abs(s["difference_refined"]) <= slope_tolerance
            for s in chk),
        "absolute_ok_refined": None if band is None else bool(band["fraction_within"] == 1.0),
        "spectral_median_ratio": None if spectral is None else spectral["median_ratio"],
    }


def agreement(results: list[dict], truncation: list[dict] | None = None, *, s_used: float,
              slope_range: tuple[int, int] = SLOPE_RANGE,
              slope_tolerance: float = SLOPE_TOLERANCE,
              absolute_tolerance: float = ABSOLUTE_TOLERANCE) -> dict:
    r"""Agreement statistics between measured and predicted errors (see the module docstring).

    ``results`` entries need ``brdf``, ``pointset``, ``weights``, ``n``, ``measured_rmse``,
    ``predicted_wce``, ``predicted_rmse`` and (for the s comparison) ``wce_by_s``; the other
    predictors' keys (:data:`envfit.validate._keys.PREDICTION_KEYS`) where present.

    Returns a dict with

    * ``slope_range``: the range used (clipped to the N run), ``s``: the used s;
    * ``slopes``, ``ratios``: :func:`slope_statistics`;
    * ``shape_fit``, ``s_choice``: :func:`shape_statistics`;
    * ``rank``: :func:`rank_statistics`;
    * ``absolute``: :func:`absolute_statistics` (every predictor);
    * ``truncation``: :func:`truncation_statistics`;
    * ``acceptance``: :func:`acceptance_summary`.
    """
    lo, hi = _effective_range(results, slope_range)
    slopes, ratios = slope_statistics(results, lo, hi, slope_tolerance)
    shape_fit, s_choice = shape_statistics(results, s_used)
    rank = rank_statistics(results, lo, hi)
    absolute = absolute_statistics(results, lo, hi, absolute_tolerance)
    return {"slope_range": [lo, hi], "s": s_used, "shape_fit": shape_fit, "slopes": slopes,
            "ratios": ratios, "rank": rank, "s_choice": s_choice, "absolute": absolute,
            "truncation": truncation_statistics(truncation),
            "acceptance": acceptance_summary(slopes, rank, absolute, slope_tolerance)}
