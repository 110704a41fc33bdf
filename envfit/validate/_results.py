r"""The result of ``envfit validate``: :class:`ValidationResult` (its :meth:`~ValidationResult.to_json`
is the JSON-ready dict the report, the plots, ``--json`` and ``validate.json`` read), and the
per-rule entries of ``results`` with every quadrature-rule predictor of
:data:`envfit.predict.PREDICTORS`.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Sequence

import numpy as np

from envfit.base import html_result
from envfit.base import s_key
from envfit.maps import EnvMap
from envfit.predict import PredictionContext, QuadratureRule, predict, predictors_for

from envfit.validate._agreement import loglog_slope, measured_equivalent_n
from envfit.validate._cells import rule_from_cell
from envfit.validate._keys import prediction_keys

__all__ = ["ValidationResult", "rule_entry", "fill_shape", "fill_measured_equivalents",
           "compute_costs", "map_statistics"]


@dataclass
class ValidationResult:
    r"""What :func:`envfit.validate._pipeline.run_validation` returns.

    Attributes
    ----------
    map, map_size, channels : the map's name, [W, H] and C.
    s, sigma, sigma_channels : the paper's fit (or the given s): ŝ, σ̂ (RMS over channels), σ̂_c.
    s_refined, sigma_refined, sigma_refined_channels : the band-limited fit behind (b′).
    fit, fit_refined : the two fit cells (interval, method, samples, notes, seconds).
    lookup_transfer : τ_l, l = 0…H − 1, of the bilinear lookup.
    scale, scale_description : the value scale of the integrand.
    config, quick_description : :meth:`ValidateConfig.to_dict` and what ``--quick`` changed.
    axes, seed : M and the seed.
    results : one dict per (BRDF, point set, weighting), lists over N: ``measured_rmse``,
        ``predicted_wce``, one key per predictor field (:data:`envfit.validate._keys.PREDICTION_KEYS`:
        ``predicted_rmse``, ``predicted_rmse_refined``, ``predicted_rmse_spectral``, …),
        ``predicted_shape`` (a), slopes, per-channel and per-s values, seconds.
    truncation : one dict per (BRDF, basis): lists over L.
    agreement : :func:`envfit.validate._agreement.agreement` of the two.
    map_stats, timings, costs : diagnostics, seconds per stage, seconds per point set /
        weighting / N.
    notes : what the reader should know (map, store, fits).
    unwritten : [key, reason] of the cells that could not be written (resumability lost).
    renderer : the ``--renderer`` section (:meth:`envfit.validate._renderer.RendererValidation.to_json`:
        config, sources, cells, per-rule and per-lobe summaries, timings), or None.
    verdicts : every statement ``report.md`` makes on this result, as data
        (:func:`envfit.validate._report_verdicts.report_verdicts`, each
        :meth:`~envfit.validate._report_predicates.Verdict.to_json`: section, bullet,
        statement, holds, values, inputs).
    """

    map: str
    map_size: list[int]
    channels: int
    s: float
    sigma: float
    sigma_channels: list[float]
    s_refined: float
    sigma_refined: float
    sigma_refined_channels: list[float]
    fit_refined: dict
    lookup_transfer: list[float]
    scale: str
    scale_description: str
    fit: dict
    config: dict
    quick_description: str | None
    axes: int
    seed: int
    results: list[dict] = field(default_factory=list)
    truncation: list[dict] = field(default_factory=list)
    agreement: dict = field(default_factory=dict)
    map_stats: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    costs: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    unwritten: list[list] = field(default_factory=list)
    renderer: dict | None = None
    verdicts: list[dict] = field(default_factory=list)

    def to_json(self) -> dict:
        """The JSON-ready dict (every field, in order; the nested values are shared, not
        copied): what ``write_report``, ``plot_all``, ``emit_json`` and ``validate.json`` take."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def _repr_html_(self) -> str:
        """Jupyter: the fits and, per rule at its largest N, the measured RMSE and the
        ratios predicted/measured of (b), (b′) and (c)."""
        def at_max(e, key):
            p, m = (e.get(key) or [None])[-1], e["measured_rmse"][-1]
            return None if p is None or not m else p / m
        w, h = self.map_size[:2]
        return html_result(f"ValidationResult: {self.map} ({w}x{h}, {self.scale} scale)", [
            ("s, sigma (b)", (self.s, self.sigma)),
            ("s', sigma' (b', band-limited)", (self.s_refined, self.sigma_refined)),
            ("axes", self.axes)],
            (["BRDF", "point set", "weights", "N", "measured RMSE", "(b)/measured",
              "(b')/measured", "(c)/measured"],
             [[e["brdf"], e["pointset"], e["weights"], e["n"][-1], e["measured_rmse"][-1],
               *(at_max(e, k) for k in ("predicted_rmse", "predicted_rmse_refined",
                                        "predicted_rmse_spectral"))] for e in self.results]))

    def rule(self, brdf: str, pointset: str, weights: str) -> dict:
        """The entry of ``results`` for one (BRDF, point set, weighting); KeyError if none."""
        for e in self.results:
            if (e["brdf"], e["pointset"], e["weights"]) == (brdf, pointset, weights):
                return e
        raise KeyError(f"no result for {brdf}/{pointset}/{weights}")


def _predictions(rules, ctx: PredictionContext) -> dict:
    """Every predictor of a quadrature rule (:func:`envfit.predict.predictors_for`) for each
    rule, by :func:`envfit.predict.predict`: {result key: list over N}."""
    out = {}
    for name in predictors_for(QuadratureRule):
        preds = [predict(name, ctx, r) for r in rules]
        for attr, key in prediction_keys(name).items():
            out[key] = [getattr(p, attr) for p in preds]
    return out


def rule_entry(brdf: str, pointset: str, weights: str, n_values: Sequence[int],
               cells: Sequence[dict], ctx: PredictionContext, s_list: Sequence[float]) -> dict:
    """The ``results`` entry of one rule from its cells (one per N): the measured values,
    the wce at ŝ, every predictor's prediction, the per-s values and the fitted slopes."""
    rules = [rule_from_cell(c, ctx.s) for c in cells]
    n = [int(x) for x in n_values]
    wce = [r.wce for r in rules]
    entry = {"brdf": brdf, "pointset": pointset, "weights": weights, "n": n,
             "measured_rmse": [c["measured_rmse"] for c in cells], "predicted_wce": wce,
             **_predictions(rules, ctx), "band_lmax": ctx.band_lmax}
    for key in ("measured_rmse_channels", "measured_rel_se", "error_kurtosis", "weight_sum"):
        entry[key] = [c[key] for c in cells]
    for key in ("wce", "wce_bandlimited_by_s"):
        entry["wce_by_s" if key == "wce" else key] = {
            k: [c[key].get(k) for c in cells] for k in map(s_key, s_list)}
    entry["errors"] = [c.get("error") for c in cells]
    entry["seconds"] = [c.get("seconds") for c in cells]
    entry["slope_measured"] = loglog_slope(n, entry["measured_rmse"])
    entry["slope_predicted"] = loglog_slope(n, wce)
    entry["slope_predicted_refined"] = loglog_slope(n, entry["predicted_rmse_refined"])
    return entry


def fill_shape(results: list[dict], truncation: list[dict], agreement: dict) -> None:
    """Prediction (a), ``predicted_shape`` = c_p·wce with the fitted constant c_p of each BRDF."""
    for e in [*results, *truncation]:
        c = agreement["shape_fit"]["constant"].get(e["brdf"])
        e["predicted_shape"] = [None if (c is None or v is None) else c * v
                                for v in e["predicted_wce"]]


def fill_measured_equivalents(results: list[dict], truncation: list[dict]) -> None:
    """The measured QMC equivalent of each truncation, from the measured SF/equal curve."""
    for t in truncation:
        ref = next((e for e in results if e["brdf"] == t["brdf"] and e["pointset"] == "sf"
                    and e["weights"] == "equal"), None)
        t["measured_qmc_equivalent_n"] = [
            None if ref is None else measured_equivalent_n(ref["n"], ref["measured_rmse"], v)
            for v in t["measured_rmse"]]


def compute_costs(results: list[dict]) -> dict:
    """Seconds of the quadrature cells summed per point set, weighting and N."""
    costs = {"by_pointset": {}, "by_weights": {}, "by_n": {}}
    for e in results:
        for n, sec in zip(e["n"], e["seconds"]):
            if sec is None:
                continue
            for key, name in (("by_pointset", e["pointset"]), ("by_weights", e["weights"]),
                              ("by_n", str(n))):
                costs[key][name] = costs[key].get(name, 0.0) + float(sec)
    return costs


def map_statistics(envmap: EnvMap, scaled: EnvMap, scale) -> dict:
    r"""Diagnostics for the report: dynamic range (peak / mean luminance on the linear map),
    the fraction of solid angle holding half of the linear energy, and, on the display
    scale, the fraction of pixels clipped at 1 (where the display transform flattens a sun).
    """
    y = envmap.luminance()
    om = envmap.solid_angles()
    e = y * om
    tot = float(e.sum())
    mean = tot / float(om.sum())
    stats_: dict = {"peak_over_mean": float(y.max() / mean) if mean > 0 else None}
    if tot > 0:
        order = np.argsort(e.ravel())[::-1]
        cum = np.cumsum(e.ravel()[order])
        k = int(np.searchsorted(cum, 0.5 * tot)) + 1
        stats_["solid_angle_fraction_half_energy"] = float(om.ravel()[order[:k]].sum() / om.sum())
    else:
        stats_["solid_angle_fraction_half_energy"] = None
    if scale.name == "display":
        clipped = np.any(envmap.data * scale.exposure >= 1.0, axis=2)
        stats_["display_clipped_fraction"] = float((om * clipped).sum() / om.sum())
    else:
        stats_["display_clipped_fraction"] = None
    sd = scaled.data
    stats_["scaled_min"] = float(sd.min())
    stats_["scaled_max"] = float(sd.max())
    return stats_
