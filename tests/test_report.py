"""Tests of envfit.validate._report and its parts (_report_predicates, _report_verdicts,
_report_template): every judgement of report.md is a verdict of a named predicate.

Each condition of :data:`envfit.validate._report_predicates.CONDITIONS` is rendered both ways
from a small synthetic result dict (the keys ``run_validation`` returns, only those the
sentence reads): the sentence for the outcome the numbers satisfy appears, with the numbers
given, and the other one does not; the verdict list (the data ``validate.json`` carries)
holds that statement with that outcome. A real quick run on a 16-row GP map checks that the
rendered report prints no sentence whose condition its own numbers fail, that every bullet
of the report is its verdicts' sentences, that each verdict's outcome is its predicate on
its inputs, and that the result's stored verdicts are the report's.
"""
from __future__ import annotations

import ast
import inspect
import json
import math

import pytest
from envfit.base._atomic import to_jsonable
from envfit.data_gen._gp import gaussian_process_map

from envfit.maps._envmap import EnvMap
from envfit.validate import _config as VC
from envfit.validate import _pipeline as V
from envfit.validate import _report as R
from envfit.validate import _report_predicates as C
from envfit.validate import _report_template as T
from envfit.validate import _report_verdicts as RV
from envfit.validate._report import render_report, report_verdicts, write_report
from envfit.validate._report_predicates import CONDITIONS, RENDERER_CONDITIONS, fact, judge


def _result(agreement=None, results=None, map_stats=None, truncation=None):
    """A minimal result dict in the shape of ``run_validation``'s, with the parts given."""
    agr = {"slopes": [], "rank": [], "shape_fit": {"constant": {}, "residual_dex": {}, "method": ""},
           "s_choice": {}, "absolute": {}, "truncation": [], "acceptance": {},
           "slope_range": [64, 1024]}
    agr.update(agreement or {})
    return {"map": "m", "map_size": [32, 16], "channels": 1, "s": 1.5, "sigma": 1.0,
            "sigma_channels": [1.0], "scale": "linear", "scale_description": "linear",
            "fit": {"source": "given", "n": 10},
            "config": {"brdfs": ["diffuse"], "pointsets": [], "weights": [], "n_values": [],
                       "shininess": 30.0, "truncation": False},
            "axes": 100, "seed": 0, "results": results or [], "truncation": truncation or [],
            "agreement": agr, "map_stats": map_stats or {}, "timings": {"total": 1.0}, "notes": []}


def _slope(pointset, diff, diff_refined=None, brdf="diffuse"):
    return {"brdf": brdf, "pointset": pointset, "weights": "equal", "measured": -1.0 + diff,
            "predicted": -1.0, "difference": diff, "predicted_refined": None,
            "difference_refined": diff_refined}


def _range(median, lo, hi, fraction, cells=10):
    return {"cells": cells, "median_ratio": median, "min_ratio": lo, "max_ratio": hi,
            "fraction_within": fraction}


def _absolute(b, refined=None, spectral=None):
    return {"absolute": {"tolerance": 0.2, "slope_range": b, "slope_range_refined": refined,
                         "slope_range_spectral": spectral}}


def _kurt(k, se=0.05):
    return [{"error_kurtosis": [k], "measured_rel_se": [se], "band_lmax": 15}]


def _rank(tau, measured, predicted, levels):
    return {"rank": [{"brdf": "diffuse", "weights": "equal", "kendall_tau": tau,
                      "measured_order": measured, "predicted_order": predicted,
                      "pointsets": list(levels), "measured_level": list(levels.values())}]}


def _s_choice(used, best, res_used, res_best):
    res = {f"{used:.4f}": {"residual_dex": res_used}, f"{best:.4f}": {"residual_dex": res_best}}
    return {"s_choice": {"glossy": {"used_s": used, "best_s": best, "residual_by_s": res}}}


def _hsh_truncation(residue):
    cur = {"brdf": "diffuse", "basis": "hsh", "L": [0, 1, 2], "measured_rmse": [0.2, residue, residue],
           "predicted_rmse": [0.13, 0.0, 0.0], "qmc_equivalent_n": [8, None, None], "axes": 12,
           "map_height": 16}
    agr = {"truncation": [{"brdf": "diffuse", "basis": "hsh", "L": [0, 1, 2],
                           "predicted_over_measured": [0.65, None, None], "shape_residual_dex": 0.0}]}
    return {"agreement": agr, "truncation": [cur]}


def _acceptance(**acc):
    return {"acceptance": {"slope_tolerance": 0.1, **acc}}


# name -> outcome -> (result, sentence that must appear, sentences that must not)
CASES = {
    "slopes_verdict": {
        True: (_result(_acceptance(slopes_within=2, slopes_checked=2, max_abs_slope_difference=0.05)),
               "2/2 (max abs difference 0.050) → yes", ["2/2 (max abs difference 0.050) → no"]),
        False: (_result(_acceptance(slopes_within=1, slopes_checked=2, max_abs_slope_difference=0.3)),
                "1/2 (max abs difference 0.300) → no", ["1/2 (max abs difference 0.300) → yes"])},
    "refined_slopes_verdict": {
        True: (_result(_acceptance(max_abs_slope_difference_refined=0.065)),
               "| max abs difference 0.065 → yes |", ["0.065 → no"]),
        False: (_result(_acceptance(max_abs_slope_difference_refined=0.25)),
                "| max abs difference 0.250 → no |", ["0.250 → yes"])},
    "rank_verdict": {
        True: (_result(_acceptance(min_kendall_tau=1.0)), "min τ = 1.000 → yes", ["1.000 → no"]),
        False: (_result(_acceptance(min_kendall_tau=0.8)), "min τ = 0.800 → no", ["0.800 → yes"])},
    "absolute_verdict": {
        True: (_result({**_acceptance(), **_absolute(_range(1.0, 0.9, 1.1, 1.0, cells=7))}),
               "median ratio 1.00, range 0.90 … 1.10, 100% of 7 cells within → yes", ["cells within → no"]),
        False: (_result({**_acceptance(), **_absolute(_range(2.38, 0.69, 8.72, 0.12, cells=100))}),
                "median ratio 2.38, range 0.69 … 8.72, 12% of 100 cells within → no",
                ["cells within → yes"])},
    "slopes_agree": {
        True: (_result({"slopes": [_slope("sf", 0.05), _slope("random", -0.08)]}),
               "All 2 fitted slopes agree within 0.1 with the prediction.", ["Slopes off by more than"]),
        False: (_result({"slopes": [_slope("sf", -0.26, 0.01), _slope("random", 0.05)]}),
                "Slopes off by more than 0.1: diffuse/sf/equal (-0.26).", ["fitted slopes agree within"])},
    "band_limit_explains_slopes": {
        True: (_result({"slopes": [_slope("sf", -0.26, 0.01), _slope("lp", -0.3, 0.02),
                                   _slope("sobol", -0.4, -0.2)]}, results=_kurt(3.0)),
               "brings 2 of these 3 within 0.1: the band limit accounts for most of them.",
               ["brings only", "at most half"]),
        False: (_result({"slopes": [_slope("sf", -0.26, 0.01), _slope("lp", -0.3, -0.2)]},
                        results=_kurt(3.0)),
                "brings only 1 of these 2 within 0.1: the band limit accounts for at most half of them.",
                ["accounts for most of them"])},
    "rougher_than_s": {
        True: (_result({"slopes": [_slope("sf", 0.3, brdf="glossy")], **_s_choice(1.5, 1.1, 0.3, 0.1)}),
               "The shape fit of glossy prefers a rougher s (1.10 < fitted 1.500): the map is rougher",
               ["does not prefer a rougher s"]),
        False: (_result({"slopes": [_slope("sf", 0.3, brdf="glossy")], **_s_choice(1.5, 1.9, 0.3, 0.1)}),
                "The shape fit of glossy does not prefer a rougher s (best s = 1.90, fitted 1.500)",
                ["prefers a rougher s (", "the map is rougher"])},
    "rank_identical": {
        True: (_result(_rank(1.0, ["sf", "random"], ["sf", "random"], {"sf": 1.0, "random": 2.0})),
               "The rank order of the point sets is the predicted one for all 1 BRDF/weighting pairs "
               "(Kendall τ = 1).", ["Rank order differs"]),
        False: (_result(_rank(0.8, ["sf", "lp", "random"], ["lp", "sf", "random"],
                              {"sf": 1.0, "lp": 1.02, "random": 2.0})),
                "Rank order differs for diffuse/equal (τ = 0.80): measured sf < lp < random, "
                "predicted lp < sf < random.", ["is the predicted one for all"])},
    "swaps_within_resolution": {
        True: (_result(_rank(0.8, ["sf", "lp", "random"], ["lp", "sf", "random"],
                             {"sf": 1.0, "lp": 1.1, "random": 2.0}), results=_kurt(3.0, se=0.05)),
               "The swapped sets differ by at most 10.0% in measured level (lp/sf), within 3× the "
               "statistical resolution (5.0%): noise can swap them.", ["more than 3×"]),
        False: (_result(_rank(0.8, ["sf", "lp", "random"], ["lp", "sf", "random"],
                              {"sf": 1.0, "lp": 1.5, "random": 2.0}), results=_kurt(3.0, se=0.05)),
                "The swapped sets lp/sf differ by 50.0% in measured level, more than 3× the "
                "statistical resolution (5.0%): the map's spectrum differs", ["noise can swap them"])},
    "absolute_all_within": {
        True: (_result(_absolute(_range(1.02, 0.85, 1.15, 1.0))),
               "(b) σ·wce is within 20% for every cell with N = 64…1024 (ratio predicted/measured "
               "0.85 … 1.15, median 1.02).", ["of the cells with N"]),
        False: (_result(_absolute(_range(2.38, 0.69, 8.72, 0.12))),
                "(b) σ·wce is within 20% for 12% of the cells with N = 64…1024 (ratio "
                "predicted/measured 0.69 … 8.72, median 2.38).", ["for every cell"])},
    "spectral_agrees": {
        True: (_result(_absolute(_range(1.0, 0.9, 1.1, 1.0), spectral=_range(0.97, 0.88, 1.12, 1.0))),
               "ratio 0.88 … 1.12, median 0.97 — within 15% everywhere: the error spectra and the "
               "measurement agree.", ["off by more than 15% somewhere"]),
        False: (_result(_absolute(_range(1.0, 0.9, 1.1, 1.0), spectral=_range(0.95, 0.45, 1.24, 0.86))),
                "ratio 0.45 … 1.24, median 0.95 — off by more than 15% somewhere: even the map's own "
                "spectrum does not predict", ["within 15% everywhere"])},
    "map_departs_from_model": {
        True: (_result(_absolute(_range(1.0, 0.9, 1.1, 1.0), refined=_range(0.7, 0.5, 1.1, 0.6),
                                 spectral=_range(0.97, 0.88, 1.12, 1.0))),
               "As (c) agrees and (b′) misses 40% of the cells, what (b′) misses is the map departing "
               "from the l^(-2s) model", []),
        False: (_result(_absolute(_range(1.0, 0.9, 1.1, 1.0), refined=_range(0.7, 0.5, 1.1, 0.6),
                                  spectral=_range(0.95, 0.45, 1.24, 0.86))),
                "(c) spectral, from the map's own power spectrum: ratio 0.45 … 1.24", ["what (b′) misses"])},
    "model_overpredicts": {
        True: (_result(_absolute(_range(2.38, 0.69, 8.72, 0.12))),
               "The measured errors are smaller than σ̂·wce (median ratio 2.38 > 1.25).",
               ["are larger than σ̂·wce"]),
        False: (_result(_absolute(_range(1.2, 0.9, 1.3, 0.9))),
                "median 1.20).", ["are smaller than σ̂·wce", "are larger than σ̂·wce"])},
    "band_limit_explains_level": {
        True: (_result(_absolute(_range(2.38, 0.69, 8.72, 0.12), refined=_range(0.93, 0.44, 1.2, 0.86)),
                       results=_kurt(3.0)),
               "has median ratio 0.93: the band limit of the pixel grid and the smoothing of bilinear "
               "interpolation near it account for the difference.", ["the band limit alone does not"]),
        False: (_result(_absolute(_range(2.38, 0.69, 8.72, 0.12), refined=_range(1.9, 1.4, 3.0, 0.0)),
                        results=_kurt(3.0)),
                "still has median ratio 1.90, outside 0.8…1.25: the band limit alone does not account "
                "for the difference.", ["near it account for the difference"])},
    "model_underpredicts": {
        True: (_result(_absolute(_range(0.5, 0.3, 0.7, 0.0))),
               "The measured errors are larger than σ̂·wce (median ratio 0.50 < 0.8).",
               ["are smaller than σ̂·wce"]),
        False: (_result(_absolute(_range(0.85, 0.8, 1.0, 1.0))),
                "median 0.85).", ["are larger than σ̂·wce", "are smaller than σ̂·wce"])},
    "few_features_explain_level": {
        True: (_result(_absolute(_range(0.5, 0.3, 0.7, 0.0)), results=_kurt(8.4)),
               "The per-axis errors are heavy-tailed (median kurtosis 8.4): σ̂ is fitted to the map's "
               "typical variation", ["are not heavy-tailed"]),
        False: (_result(_absolute(_range(0.5, 0.3, 0.7, 0.0)), results=_kurt(3.3)),
                "The per-axis errors are not heavy-tailed (median kurtosis 3.3), so the excess is not "
                "carried by a few features", ["are heavy-tailed ("])},
    "errors_gaussian": {
        True: (_result(results=_kurt(3.4)),
               "The per-axis errors look Gaussian (median kurtosis 3.4; 3 for a Gaussian field)",
               ["are not Gaussian"]),
        False: (_result(results=_kurt(5.2)),
                "The per-axis errors are not Gaussian: median kurtosis 5.2, against 3 for a Gaussian "
                "field.", ["look Gaussian", "Tails that heavy"])},
    "heavy_tails": {
        True: (_result(results=_kurt(8.0)),
               "median kurtosis 8.0, against 3 for a Gaussian field. Tails that heavy mean the squared "
               "error is concentrated on a few axes", ["look Gaussian"]),
        False: (_result(results=_kurt(5.9)), "median kurtosis 5.9, against 3", ["Tails that heavy"])},
    "display_clips": {
        True: (_result(map_stats={"peak_over_mean": 250.0, "solid_angle_fraction_half_energy": 0.02,
                                  "display_clipped_fraction": 0.004}),
               "peak/mean luminance 250; half of the linear energy lies in 2 % of the sphere; the "
               "display transform clips 0.4 % of the sphere at 1 (a clipped sun", ["clips none"]),
        False: (_result(map_stats={"peak_over_mean": 3.0, "solid_angle_fraction_half_energy": 0.3,
                                   "display_clipped_fraction": 0.0}),
                "; the display transform clips none of the sphere.", ["a clipped sun"])},
    "power_rises": {
        True: (_result(map_stats={"power_ratio_low_degrees": {"1": 0.5, "2": 0.9, "3": 1.4, "4": 2.0}}),
               "It rises with l (from 0.50 at l = 1 to 2.00 at l = 4; Spearman ρ = 1.00): the map's "
               "spectrum decays more slowly", ["does not rise"]),
        # the review's real map: ratios 0.17–0.92, not rising
        False: (_result(map_stats={"power_ratio_low_degrees": {"1": 0.17, "2": 0.92, "3": 0.41,
                                                               "4": 0.55, "5": 0.3}}),
                "It does not rise with l (0.17–0.92; Spearman ρ = 0.10, last/first 1.76).",
                ["It rises with l", "compact, very bright source"])},
    "low_degrees_match": {
        True: (_result(map_stats={"power_ratio_low_degrees": {"1": 1.0, "2": 1.1, "3": 0.9}}),
               "The lowest 3 degrees hold 1.00× the model's power, within 30% of it.", ["rules whose error"]),
        False: (_result(map_stats={"power_ratio_low_degrees": {"1": 2.0, "2": 2.0, "3": 2.3}}),
                "The lowest 3 degrees hold 2.10× the model's power: rules whose error lives there",
                ["within 30% of it"])},
    "fitted_s_best": {
        True: (_result(_s_choice(1.5, 1.5, 0.064, 0.064)),
               "glossy (wce): the fitted s = 1.500 gives the best shape match among the candidates "
               "(0.064 dex).", ["match best for", "equally well"]),
        False: (_result(_s_choice(1.5, 1.9, 0.294, 0.132)),
                "glossy (wce): the predicted shapes match best for s = 1.90", ["gives the best shape match"])},
    "s_shapes_tie": {
        True: (_result(_s_choice(1.5, 1.7, 0.064, 0.061)),
               "glossy (wce): the fitted s = 1.500 and s = 1.70 match the measured shapes equally well "
               "(0.064 vs 0.061 dex).", ["match best for"]),
        False: (_result(_s_choice(1.5, 1.9, 0.294, 0.132)),
                "glossy (wce): the predicted shapes match best for s = 1.90 (residual 0.132 dex) rather "
                "than the fitted s = 1.500 (0.294 dex)", ["equally well"])},
    "truncation_exact": {
        True: (_result(**_hsh_truncation(1.0e-6)),
               "Exact for L ≥ 1 (b̃_l = 0 for l ≥ 2): the measured residue at L ≥ 1, 1e-06 (5e-06 of "
               "the L = 0 error), is the ground truth's own accuracy.", ["yet the measured residue"]),
        False: (_result(**_hsh_truncation(0.01)),
                "Exact for L ≥ 1 in theory (b̃_l = 0 for l ≥ 2), yet the measured residue at L ≥ 1 is "
                "0.01 (0.05 of the L = 0 error)", ["is the ground truth's own accuracy"])},
}


def test_every_condition_has_cases():
    assert set(CASES) == set(CONDITIONS)


@pytest.mark.parametrize("holds", [True, False])
@pytest.mark.parametrize("name", sorted(CASES))
def test_condition_both_ways(name, holds):
    """The synthetic numbers satisfy (or fail) the predicate; the matching sentence, with those
    numbers, appears; the other outcome's does not."""
    result, present, absent = CASES[name][holds]
    md = render_report(result)
    assert present in md, f"{name}={holds}: {present!r} not in the report"
    for text in absent:
        assert text not in md, f"{name}={holds}: {text!r} printed"
    outcomes = {v.holds for v in report_verdicts(result) if v.statement == name}
    assert holds in outcomes, f"{name}: no verdict with holds={holds} in the data"


# ----------------------------------------------------------------------------- the predicates

def test_predicates_thresholds():
    assert C.rises_with_degree([1.0, 3.0, 2.0, 4.0])                 # ρ = 0.8, ×4
    assert not C.rises_with_degree([1.0, 1.2, 1.4])                  # ρ = 1 but ×1.4
    assert not C.rises_with_degree([1.0, 2.0])                       # too few degrees
    assert not C.rises_with_degree([0.17, 0.92, 0.41, 0.55, 0.3])    # the review's map
    assert C.looks_gaussian(2.0) and C.looks_gaussian(4.0) and not C.looks_gaussian(5.2)
    assert C.heavy_tailed(6.01) and not C.heavy_tailed(6.0)
    assert C.spectral_agrees(0.85, 1.15) and not C.spectral_agrees(0.84, 1.0)
    assert C.band_limit_explains(2, 3) and not C.band_limit_explains(1, 2)
    assert C.overpredicts(1.26) and not C.overpredicts(1.25)
    assert C.underpredicts(0.79) and not C.underpredicts(0.8)
    assert C.rank_identical([1.0 - 1e-12]) and not C.rank_identical([0.8]) and not C.rank_identical([])
    assert C.spearman([1, 2, 3, 4], [4, 3, 2, 1]) == pytest.approx(-1.0)
    assert C.spearman([1, 2, 3], [1, 1, 1]) == 0.0


def test_sentence_of_the_outcome():
    """A verdict prints the template of its outcome, filled with its values; "" where that
    outcome prints nothing; a fact prints its one template."""
    v = judge("errors_gaussian", (3.0,), kurtosis=3.0)
    assert v.holds is True and v.inputs == (3.0,)
    assert T.sentence(v).startswith("The per-axis errors look Gaussian (median kurtosis 3.0;")
    assert T.sentence(judge("rank_identical", ([0.5],), n=1)) == ""        # nothing when false
    assert T.sentence(fact("slopes_slower", count=2, rules=["a/b/c", "d/e/f"])) == (
        "2 converge *slower* than predicted: a/b/c, d/e/f.")
    assert T.bullets([fact("map_range", peak=2.0, half=50.0),
                      judge("rank_identical", ([0.5],), n=1)], "") == [
        "Map dynamic range: peak/mean luminance 2; half of the linear energy lies in 50 % of the "
        "sphere."]


def test_missing_numbers_print_a_dash():
    """``!m`` / :func:`fmt`: "–" for None and non-finite values, the value as it is where the
    format does not apply (an int format on a float)."""
    assert [T.fmt(x) for x in (None, math.nan, math.inf, 0.12345)] == ["–", "–", "–", "0.123"]
    assert T.fmt(3, "d") == "3" and T.fmt(2.5, "d") == "2.5" and T.fmt(0.25, ".0%") == "25%"
    v = judge("rank_verdict", ([],), tau=None)
    assert v.holds is False and T.sentence(v) == "min τ = – → no"


def test_every_statement_has_its_sentences():
    """The template tables cover exactly the judgements and the facts the verdicts use; every
    list field has an item template of a statement that exists."""
    assert set(T.JUDGED) == set(CONDITIONS) | set(RENDERER_CONDITIONS)
    assert not set(T.FACTS) & set(T.JUDGED)
    assert {s for s, _ in T.ITEMS} <= set(T.JUDGED) | set(T.FACTS)
    for name, (yes, no) in T.JUDGED.items():
        assert yes is not None or no is not None, name


# ----------------------------------------------------------------------------- a real quick run

@pytest.fixture(scope="module")
def quick_result():
    env = EnvMap(gaussian_process_map(1.5, 16, seed=4, channels=2), name="gp16")
    res = V.run_validation(env, VC.quick_config(axes=60, fit_n=150, hsh_axes=12, hsh_max_height=16,
                                               equivalent_nmax=256, scale="linear", s=1.5))
    return res.to_json() if hasattr(res, "to_json") else res


def _expect(md: str, name: str, holds: bool, true_text: str, false_text: str | None):
    """The sentence of the outcome ``holds`` is in ``md``, the other one is not."""
    yes, no = (true_text, false_text) if holds else (false_text, true_text)
    if yes is not None:
        assert yes in md, f"{name}: expected {yes!r}"
    if no is not None:
        assert no not in md, f"{name}: {no!r} printed but its condition is {not holds}"


def test_real_report_prints_no_sentence_whose_condition_fails(quick_result, tmp_path):
    r = quick_result
    md = write_report(r, tmp_path / "report.md").read_text()
    assert md == render_report(r)
    kurts = sorted(k for e in r["results"] for k in e["error_kurtosis"] if k is not None)
    kurt = RV.median(kurts)
    _expect(md, "errors_gaussian", C.looks_gaussian(kurt),
            f"The per-axis errors look Gaussian (median kurtosis {kurt:.1f};",
            f"The per-axis errors are not Gaussian: median kurtosis {kurt:.1f}")
    _expect(md, "heavy_tails", C.heavy_tailed(kurt), "Tails that heavy", None)
    pr = r["map_stats"]["power_ratio_low_degrees"]
    rho = [pr[k] for k in sorted(pr, key=int)]
    _expect(md, "power_rises", C.rises_with_degree(rho), "It rises with l (",
            f"It does not rise with l ({min(rho):.2f}–{max(rho):.2f};")
    low = sum(rho[:3]) / 3
    _expect(md, "low_degrees_match", C.low_degrees_match(low),
            f"hold {low:.2f}× the model's power, within 30% of it.",
            f"hold {low:.2f}× the model's power: rules whose error")
    ab = r["agreement"]["absolute"]
    d, dc = ab["slope_range"], ab["slope_range_spectral"]
    _expect(md, "absolute_all_within", C.all_within(d["fraction_within"]),
            "for every cell with N", f"for {d['fraction_within']:.0%} of the cells with N")
    _expect(md, "spectral_agrees", C.spectral_agrees(dc["min_ratio"], dc["max_ratio"]),
            "everywhere: the error spectra and the measurement agree", "off by more than 15% somewhere")
    _expect(md, "model_overpredicts", C.overpredicts(d["median_ratio"]),
            f"smaller than σ̂·wce (median ratio {d['median_ratio']:.2f}", None)
    _expect(md, "model_underpredicts", C.underpredicts(d["median_ratio"]),
            f"larger than σ̂·wce (median ratio {d['median_ratio']:.2f}", None)
    diffs = [s["difference"] for s in r["agreement"]["slopes"] if s["difference"] is not None]
    _expect(md, "slopes_agree", C.all_agree(diffs, 0.1), "fitted slopes agree within",
            "Slopes off by more than 0.1")
    taus = [k["kendall_tau"] for k in r["agreement"]["rank"]]
    _expect(md, "rank_identical", C.rank_identical(taus), "is the predicted one for all", None)
    for b, v in r["agreement"]["s_choice"].items():
        best, used = v["best_s"], v["used_s"]
        _expect(md, "fitted_s_best", C.fitted_s_is_best(best, used),
                f"{b} (wce): the fitted s = {used:.3f} gives the best shape match",
                f"{b} (wce): the predicted shapes match best" if not C.shapes_tie(
                    v["residual_by_s"][f"{used:.4f}"]["residual_dex"],
                    v["residual_by_s"][f"{best:.4f}"]["residual_dex"]) else None)


def test_real_report_numbers(quick_result):
    """Numbers in the judgement sentences are the result's (the (b) range, the kurtosis)."""
    md = render_report(quick_result)
    d = quick_result["agreement"]["absolute"]["slope_range"]
    assert f"ratio predicted/measured {d['min_ratio']:.2f} … {d['max_ratio']:.2f}, median " \
           f"{d['median_ratio']:.2f})" in md
    assert not any(math.isnan(x) for x in [d["min_ratio"], d["max_ratio"]])


def test_functions_fit_a_screen():
    """No function of the report modules is over 60 lines; render_report and report_verdicts
    are a handful of calls."""
    lengths = {n.name: n.end_lineno - n.lineno + 1 for m in (R, C, T, RV)
               for n in ast.walk(ast.parse(inspect.getsource(m))) if isinstance(n, ast.FunctionDef)}
    assert max(lengths.values()) <= 60, lengths
    assert lengths["render_report"] <= 30 and lengths["report_verdicts"] <= 30


def test_real_report_is_its_verdicts(quick_result):
    """Every bullet of "What disagrees and why" is the sentences of one bullet's verdicts;
    every verdict's outcome is its predicate on its inputs; the run's stored verdicts (the
    ``verdicts`` of validate.json) are the report's."""
    md = render_report(quick_result)
    verdicts = report_verdicts(quick_result)
    section = md.split("## What disagrees and why\n\n")[1].split("\n\n")[0].splitlines()
    assert section == [f"- {b}" for b in T.bullets(verdicts, "disagreements")] and section
    for v in verdicts:
        if v.holds is not None:
            assert bool(CONDITIONS[v.statement](*v.inputs)) == v.holds, v
        if T.sentence(v):
            assert T.sentence(v) in md, v
    assert {v.section for v in verdicts} == {"acceptance", "disagreements"}
    assert quick_result["verdicts"] == [v.to_json() for v in verdicts]
    assert json.loads(json.dumps(to_jsonable(quick_result["verdicts"]))) == quick_result["verdicts"]


def test_real_report_names_public_functions_only(quick_result, tmp_path):
    """Every function report.md cites is one a user can import: no private module
    (``envfit.x._y``) is named (the report once cited two that the house made private)."""
    import importlib
    import re
    md = write_report(quick_result, tmp_path / "report.md").read_text()
    cited = set(re.findall(r"`(envfit(?:\.\w+)+)`", md))
    assert cited, "the report cites no envfit name"
    for name in sorted(cited):
        assert not re.search(r"\._", name), f"report.md cites the private {name}"
        mod, _, attr = name.rpartition(".")
        assert hasattr(importlib.import_module(mod), attr), name
