r"""Agreement between measured and predicted errors: log-log slopes, shape constants, rank
agreement, equivalent N, and the per-cell verdicts that ``report.md`` states.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np


from envfit.base.errors import ParameterError
from envfit.shading.spectra import (bandlimited_worst_case_error, bandlimited_worst_case_errors,  # noqa: F401
                      low_degree_power_ratio, lookup_transfer, map_degree_power, model_scatter,
                      pixel_degree_power, rule_error_power, sh_truncation_curve_transfer,
                      spectral_rmse)


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


def agreement(results: list[dict], truncation: list[dict] | None = None, *, s_used: float,
              slope_range: tuple[int, int] = SLOPE_RANGE,
              slope_tolerance: float = SLOPE_TOLERANCE,
              absolute_tolerance: float = ABSOLUTE_TOLERANCE) -> dict:
    r"""Agreement statistics between measured and predicted errors (see the module docstring).

    ``results`` entries need ``brdf``, ``pointset``, ``weights``, ``n``, ``measured_rmse``,
    ``predicted_wce``, ``predicted_rmse`` and (for the s comparison) ``wce_by_s``.

    Returns a dict with

    * ``slopes``: per rule, measured and predicted slope over ``slope_range``, difference;
    * ``ratios``: per rule, measured/predicted_wce per N and its spread max/min over the
      slope range (1 = the theory's shape holds exactly);
    * ``shape_fit``: per BRDF the factor c (:func:`shape_constant` over every rule and N)
      and the residual in dex (:func:`shape_residual`); ``s_choice``: the residual per
      candidate s and the best one;
    * ``rank``: per (BRDF, weighting) the measured and predicted orders of the point sets
      by their geometric-mean level over the slope range, Kendall's τ, and τ per N;
    * ``absolute``: prediction (b) σ·wce against the measured RMSE: per rule the ratio
      predicted/measured per N; overall median, worst, fraction within the tolerance;
    * ``truncation``: per curve the ratio predicted_rmse/measured and the shape residual;
    * ``acceptance``: the issue's checks (slopes of sf and random within
      ``slope_tolerance``, identical rank orders, (b) within ``absolute_tolerance``).
    """
    all_n = [n for e in results for n in e["n"]]
    lo = max(slope_range[0], min(all_n)) if all_n else slope_range[0]
    hi = min(slope_range[1], max(all_n)) if all_n else slope_range[1]
    slope_range = (lo, hi)
    out: dict = {"slope_range": [lo, hi], "s": s_used,
                 "shape_fit": {"method": "per BRDF, log c = mean over every point set, "
                                         "weighting and N of (log measured RMSE - log wce); "
                                         "residual = RMS of the remaining log10 differences",
                               "constant": {}, "residual_dex": {}},
                 "slopes": [], "ratios": [], "rank": [], "s_choice": {}, "absolute": {},
                 "truncation": [], "acceptance": {}}
    brdfs = list(dict.fromkeys(e["brdf"] for e in results))
    # slopes and ratios
    for e in results:
        sm = loglog_slope(e["n"], e["measured_rmse"], slope_range)
        sp = loglog_slope(e["n"], e["predicted_wce"], slope_range)
        diff = None if (sm is None or sp is None) else sm - sp
        sb = loglog_slope(e["n"], e["predicted_rmse_refined"], slope_range) \
            if e.get("predicted_rmse_refined") is not None else None
        diff_b = None if (sm is None or sb is None) else sm - sb
        out["slopes"].append({"brdf": e["brdf"], "pointset": e["pointset"], "weights": e["weights"],
                              "measured": sm, "predicted": sp, "difference": diff,
                              "within_tolerance": None if diff is None else bool(abs(diff) <= slope_tolerance),
                              "predicted_refined": sb, "difference_refined": diff_b})
        ratio = [None if (m is None or p is None or p <= 0) else m / p
                 for m, p in zip(e["measured_rmse"], e["predicted_wce"])]
        in_rng = [r for n, r in zip(e["n"], ratio) if r is not None and lo <= n <= hi and r > 0]
        out["ratios"].append({"brdf": e["brdf"], "pointset": e["pointset"], "weights": e["weights"],
                              "n": e["n"], "measured_over_wce": ratio,
                              "spread": (max(in_rng) / min(in_rng)) if len(in_rng) >= 2 else None})
    # shape fit (a) and the choice of s
    for b in brdfs:
        es = [e for e in results if e["brdf"] == b]
        meas = [m for e in es for m in e["measured_rmse"]]
        pred = [p for e in es for p in e["predicted_wce"]]
        out["shape_fit"]["constant"][b] = shape_constant(meas, pred)
        out["shape_fit"]["residual_dex"][b] = shape_residual(meas, pred)
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
        out["s_choice"][b] = entry
    # rank order
    for b in brdfs:
        for w in dict.fromkeys(e["weights"] for e in results if e["brdf"] == b):
            es = [e for e in results if e["brdf"] == b and e["weights"] == w]
            if len(es) < 2:
                continue
            names = [e["pointset"] for e in es]
            ml, pl = [], []
            for e in es:
                mm = [m for n, m, p in zip(e["n"], e["measured_rmse"], e["predicted_wce"])
                      if lo <= n <= hi and m is not None and p is not None and m > 0 and p > 0]
                pp = [p for n, m, p in zip(e["n"], e["measured_rmse"], e["predicted_wce"])
                      if lo <= n <= hi and m is not None and p is not None and m > 0 and p > 0]
                ml.append(float(np.exp(np.mean(np.log(mm)))) if mm else np.nan)
                pl.append(float(np.exp(np.mean(np.log(pp)))) if pp else np.nan)
            rk = rank_agreement(names, ml, pl)
            per_n = {}
            for i, n in enumerate(es[0]["n"]):
                mv = [e["measured_rmse"][i] for e in es]
                pv = [e["predicted_wce"][i] for e in es]
                mv = [np.nan if v is None else v for v in mv]
                pv = [np.nan if v is None else v for v in pv]
                per_n[str(n)] = rank_agreement(names, mv, pv)["kendall_tau"]
            out["rank"].append({"brdf": b, "weights": w, **rk, "measured_level": ml,
                                "predicted_level": pl, "pointsets": names, "tau_per_n": per_n})
    # absolute prediction (b), and (b') band-limited
    ab = {"tolerance": absolute_tolerance}
    for variant, key in (("", "predicted_rmse"), ("_refined", "predicted_rmse_refined"),
                         ("_spectral", "predicted_rmse_spectral")):
        per_rule, all_ratio, in_range_ratio, in_range_band = [], [], [], []
        for e in results:
            preds = e.get(key) or [None] * len(e["n"])
            ratio = [None if (m is None or p is None or m <= 0) else p / m
                     for m, p in zip(e["measured_rmse"], preds)]
            # the spread one map is expected to show about the model (refined only) and the
            # Monte Carlo error of M axes: 2 standard deviations, combined
            sd = [None] * len(e["n"])
            if variant == "_refined":
                sd = [None if sc is None else math.hypot(sc, se or 0.0)
                      for sc, se in zip(e.get("model_scatter") or [None] * len(e["n"]),
                                        e.get("measured_rel_se") or [None] * len(e["n"]))]
            per_rule.append({"brdf": e["brdf"], "pointset": e["pointset"], "weights": e["weights"],
                             "n": e["n"], "predicted_over_measured": ratio,
                             **({"expected_relative_sd": sd} if variant == "_refined" else {})})
            all_ratio += [r for r in ratio if r is not None and r > 0]
            for n, r, d in zip(e["n"], ratio, sd):
                if r is not None and r > 0 and lo <= n <= hi:
                    in_range_ratio.append(r)
                    in_range_band.append(max(absolute_tolerance, 2.0 * d) if d is not None
                                         else absolute_tolerance)
        ab["per_rule" + variant] = per_rule
        for name, arr in (("all", all_ratio), ("slope_range", in_range_ratio)):
            a = np.asarray(arr, dtype=np.float64)
            ab[name + variant] = None if a.size == 0 else {
                "cells": int(a.size), "median_ratio": float(np.median(a)),
                "min_ratio": float(a.min()), "max_ratio": float(a.max()),
                "fraction_within": float(np.mean(np.abs(a - 1.0) <= absolute_tolerance))}
            if variant == "_refined" and name == "slope_range" and a.size:
                # |ratio - 1| within the tolerance or within 2 expected standard deviations
                ab[name + variant]["fraction_within_expected_scatter"] = float(
                    np.mean(np.abs(a - 1.0) <= np.asarray(in_range_band)))
    out["absolute"] = ab
    # truncation
    for t in truncation or []:
        rp = [None if (m is None or p is None or m <= 0 or p <= 0) else p / m
              for m, p in zip(t["measured_rmse"], t.get("predicted_rmse", []))]
        rb = [None if (m is None or p is None or m <= 0 or p <= 0) else p / m
              for m, p in zip(t["measured_rmse"],
                              t.get("predicted_rmse_refined") or [None] * len(t["L"]))]
        out["truncation"].append({"brdf": t["brdf"], "basis": t["basis"], "L": t["L"],
                                  "predicted_over_measured": rp,
                                  "predicted_refined_over_measured": rb,
                                  "shape_residual_dex": shape_residual(t["measured_rmse"], t["predicted_wce"])})
    # acceptance summary
    chk = [s for s in out["slopes"] if s["pointset"] in SLOPE_CHECK_POINTSETS and s["difference"] is not None]
    taus = [r["kendall_tau"] for r in out["rank"] if r["kendall_tau"] is not None]
    out["acceptance"] = {
        "slope_tolerance": slope_tolerance,
        "slopes_checked": len(chk),
        "slopes_within": sum(1 for s in chk if s["within_tolerance"]),
        "max_abs_slope_difference": max((abs(s["difference"]) for s in chk), default=None),
        "slopes_ok": bool(chk) and all(s["within_tolerance"] for s in chk),
        "rank_ok": bool(taus) and all(t >= 1.0 - 1e-12 for t in taus),
        "min_kendall_tau": min(taus) if taus else None,
        "absolute_ok": None if ab["slope_range"] is None else bool(ab["slope_range"]["fraction_within"] == 1.0),
        "max_abs_slope_difference_refined": max(
            (abs(s["difference_refined"]) for s in chk if s["difference_refined"] is not None),
            default=None),
        "slopes_ok_refined": bool(chk) and all(
            s["difference_refined"] is not None and abs(s["difference_refined"]) <= slope_tolerance
            for s in chk),
        "absolute_ok_refined": None if ab["slope_range_refined"] is None else bool(
            ab["slope_range_refined"]["fraction_within"] == 1.0),
        "spectral_median_ratio": None if ab["slope_range_spectral"] is None else
        ab["slope_range_spectral"]["median_ratio"],
    }
    return out
