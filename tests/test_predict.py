"""Tests of envfit.predict: the three predictors, their context and rule, the registry and its
dispatcher, and that run_validation really loops over the registry.

Independent references: the formulas re-derived here from envfit.theory (Sobolev
coefficients a_l, the closed-form wce with the other embedding), the map's transfer by
envfit.shading._spectra.map_transfer, and the RMSE measured over Haar-random rotations
(uniform axes, uniform twist) on a tiny map whose bilinear interpolant is nearly
band-limited, with ground truth from envfit.shading._ground_truth.shading_integral. Tiny maps,
few points; never /work/shared.
"""
from __future__ import annotations

import inspect
import math

import numpy as np
import pytest

from envfit.base._errors import ParameterError
from envfit.data_gen._gp import gaussian_process_map
from envfit.data_gen._sht import synthesize
from envfit.maps._envmap import EnvMap
from envfit.predict import (PREDICTORS, Prediction, PredictionContext, QuadratureRule,
                            RendererRule, Rule, predict, predict_bandlimited, predict_plain,
                            predict_random_variance, predict_spectral,
                            predict_warped_spectrum, predictors_for)
from envfit.shading._estimators import quadrature_estimates, rmse_over_axes
from envfit.shading._ground_truth import shading_integral
from envfit.shading._quadrature import random_axes
from envfit.shading._spectra import map_transfer, rule_error_power
from envfit.theory._brdf import Diffuse, Glossy
from envfit.theory._pointsets import generate
from envfit.theory._quadrature import worst_case_error
from envfit.theory._sobolev import sobolev_coefficients
from envfit.theory._weights import optimal_weights


def _osw_rule(wf, n: int, s: float, lmax: int) -> QuadratureRule:
    pts = generate("sf", n, morph=wf.morph)
    return QuadratureRule.from_points(pts, optimal_weights(pts, wf, s), wf, s, lmax)


# ----------------------------------------------------------------------------- registry

def test_registry_holds_six_predictors_of_one_signature():
    assert list(PREDICTORS) == ["plain", "bandlimited", "spectral", "random-variance",
                                "warped-spectrum", "renderer"]
    assert PREDICTORS["plain"] is predict_plain
    assert PREDICTORS["bandlimited"] is predict_bandlimited
    assert PREDICTORS["spectral"] is predict_spectral
    assert PREDICTORS["random-variance"] is predict_random_variance
    assert PREDICTORS["warped-spectrum"] is predict_warped_spectrum
    for f in PREDICTORS.values():
        assert list(inspect.signature(f).parameters) == ["ctx", "rule"]
        assert issubclass(f.rule_type, Rule)


def test_one_rule_concept_two_kinds():
    """Both kinds are Rules; each predictor reads one kind and predict() refuses the other."""
    q, r = QuadratureRule(n=16, wce=0.5), RendererRule("map", "sf", 16)
    assert isinstance(q, Rule) and isinstance(r, Rule) and q.n == r.n == 16
    assert list(predictors_for(QuadratureRule)) == ["plain", "bandlimited", "spectral"]
    assert list(predictors_for(RendererRule)) == ["random-variance", "warped-spectrum"]
    ctx = PredictionContext(s=1.5, sigma=1.0)
    for name in PREDICTORS:
        bad = r if name in predictors_for(QuadratureRule) else q
        with pytest.raises(ParameterError, match=f"predictor '{name}' reads a"):
            predict(name, ctx, bad)
    with pytest.raises(ParameterError, match="needs renderer"):
        predict("warped-spectrum", ctx, r)


def test_dispatcher_calls_the_named_predictor():
    rule = QuadratureRule(n=4, wce=0.3, error_power=[0.0, 0.5, 0.25], weight_sum=1.0)
    ctx = PredictionContext(s=1.5, sigma=2.0, s_bandlimited=1.4, sigma_bandlimited=1.5,
                            sigma_bandlimited_channels=(1.5,), band_lmax=2,
                            map_power=np.array([[1.0, 0.2, 0.1]]), mean_rms=0.5)
    for name, f in predictors_for(QuadratureRule).items():
        p = predict(name, ctx, rule)
        assert isinstance(p, Prediction) and p.name == name
        assert p == f(ctx, rule)


@pytest.mark.parametrize("bad", ["exact", "Plain", "", None, ["plain"]])
def test_unknown_predictor_is_a_parameter_error_listing_the_names(bad):
    with pytest.raises(ParameterError) as info:
        predict(bad, PredictionContext(s=1.5, sigma=1.0), QuadratureRule(n=4, wce=0.1))
    assert str(info.value).endswith("choose from plain, bandlimited, spectral, random-variance, "
                                    "warped-spectrum, renderer")


def test_a_predictor_names_the_context_fields_it_lacks():
    rule = QuadratureRule(n=4, error_power=[0.0, 1.0], weight_sum=1.0)
    with pytest.raises(ParameterError, match="s_bandlimited, sigma_bandlimited, band_lmax"):
        predict("bandlimited", PredictionContext(s=1.5, sigma=1.0), rule)
    with pytest.raises(ParameterError, match="map_power"):
        predict("spectral", PredictionContext(s=1.5, sigma=1.0), rule)


# ----------------------------------------------------------------------------- (b) plain

def test_plain_is_sigma_times_the_closed_form_wce():
    """σ̂·E with E the closed form (Eq. 41), here by the other embedding of the kernel
    (series against the default), for the very rule."""
    wf = Glossy(30.0)
    pts = generate("sf", 48, morph=wf.morph)
    w = np.full(48, 1 / 48)
    rule = QuadratureRule.from_points(pts, w, wf, 1.5, 20)
    ref = worst_case_error(pts, w, wf, 1.5, embedding="series")
    assert rule.wce == pytest.approx(ref, rel=1e-9)
    p = predict_plain(PredictionContext(s=1.5, sigma=0.7), rule)
    assert p.rmse == 0.7 * rule.wce and p.wce == rule.wce
    assert predict_plain(PredictionContext(s=1.5, sigma=0.7), QuadratureRule(n=48)).rmse is None


# ----------------------------------------------------------------------------- (b') band-limited

def test_bandlimited_is_the_refined_formula():
    r"""R̂ = (σ̂'² Σ_{l≤H−1} a_l(ŝ') τ_l e_l + (Σw − 1)² m̄²)^{1/2}, re-derived term by term."""
    wf = Diffuse()
    L = 15
    rule = _osw_rule(wf, 30, 1.5, L)
    tau = np.linspace(1.0, 0.3, L + 1)
    ctx = PredictionContext(s=1.5, sigma=1.0, s_bandlimited=1.35, sigma_bandlimited=0.8,
                            sigma_bandlimited_channels=(0.6, 0.95), band_lmax=L, transfer=tau,
                            mean_rms=2.5)
    p = predict_bandlimited(ctx, rule)
    e2 = math.fsum(sobolev_coefficients(1.35, L) * tau * np.asarray(rule.error_power))
    me = abs(rule.weight_sum - 1.0) * 2.5
    assert p.wce == pytest.approx(math.sqrt(e2), rel=1e-13)
    assert p.mean_error == pytest.approx(me, rel=1e-13) and me > 0
    assert p.rmse == pytest.approx(math.sqrt(0.64 * e2 + me * me), rel=1e-13)
    assert p.relative_sd is not None and 0 < p.relative_sd < 1
    # a truncation: no weights (no mean term), E' given directly
    t = predict_bandlimited(ctx, QuadratureRule(n=3, wce_bandlimited=0.25))
    assert t.rmse == 0.8 * 0.25 and t.mean_error is None and t.relative_sd is None
    assert predict_bandlimited(ctx, QuadratureRule(n=3)).rmse is None


def test_bandlimited_equals_spectral_on_the_models_spectrum():
    r"""A map whose power per degree is exactly the model's, P̂_{l,c} = σ_c² a_l(s') τ_l
    (plus 4π m_c² at l = 0, the mean): (c) Σ P̂_l e_l is then (b′) term by term — the mean
    term because 4π e_0 = (Σw − 1)² (b_0 = 1/√(4π))."""
    L, s = 24, 1.6
    sig = np.array([0.5, 1.0, 2.0])
    means = np.array([1.0, 3.0, 0.25])
    tau = 1.0 - 0.7 * (np.arange(L + 1) / L) ** 2
    a = sobolev_coefficients(s, L)
    P = sig[:, None] ** 2 * (a * tau)[None, :]
    P[:, 0] += 4 * np.pi * means ** 2
    ctx = PredictionContext(s=s, sigma=1.0, s_bandlimited=s,
                            sigma_bandlimited=float(np.sqrt(np.mean(sig ** 2))),
                            sigma_bandlimited_channels=tuple(sig), band_lmax=L, transfer=tau,
                            map_power=P, mean_rms=float(np.sqrt(np.mean(means ** 2))))
    for wf in (Diffuse(), Glossy(30.0)):
        rule = _osw_rule(wf, 40, s, L)
        assert rule.weight_sum != 1.0
        b = predict("bandlimited", ctx, rule)
        c = predict("spectral", ctx, rule)
        assert b.rmse == pytest.approx(c.rmse, rel=1e-10)


# ----------------------------------------------------------------------------- (c) spectral

def test_spectral_is_the_realised_power_formula():
    P = np.array([[3.0, 0.5, 0.25, 0.1], [1.0, 2.0, 0.5, 0.0]])
    e = np.array([1e-3, 0.2, 0.05, 0.4])
    p = predict_spectral(PredictionContext(s=1.5, sigma=1.0, map_power=P), QuadratureRule(n=8, error_power=e))
    assert p.rmse == pytest.approx(math.sqrt((P @ e).mean()), rel=1e-15)
    assert p.wce is None and p.mean_error is None
    assert predict_spectral(PredictionContext(s=1.5, sigma=1.0, map_power=P), QuadratureRule(n=8)).rmse is None


def test_spectral_is_the_mean_over_haar_random_rotations():
    """(c) against the RMSE measured over M = 1500 uniformly random rotations (axes and
    twists) on a tiny two-channel map of degrees ≤ 6 on 48 rows (its bilinear interpolant
    is band-limited to ~1e-3): within 3 standard errors of the measurement, plus 1 %."""
    rng = np.random.default_rng(3)
    c = rng.normal(size=49) / (1.0 + np.repeat(np.arange(7), 2 * np.arange(7) + 1))
    env = EnvMap(np.stack([synthesize(c, 48), synthesize(rng.permutation(c), 48)], axis=2) + 1.0)
    ctx = PredictionContext.from_map(env, 1.5, [1.0, 1.0], 1.5, [1.0, 1.0])
    axes = random_axes(1500, 9)
    for brdf, wf in (("diffuse", Diffuse()), ("glossy", Glossy(30.0))):
        truth = shading_integral(env, axes, brdf, 30.0)
        for ps in ("sf", "random"):
            pts = generate(ps, 12, seed=1, morph=wf.morph)
            w = np.full(12, 1 / 12)
            est = quadrature_estimates(env, axes, pts, w, seed=[4, 5])
            measured = rmse_over_axes(est, truth).total
            e2 = ((est - truth) ** 2).mean(axis=1)
            rel_se = e2.std(ddof=1) / (2 * math.sqrt(e2.size) * e2.mean())
            rule = QuadratureRule(n=12, error_power=rule_error_power(pts, w, wf, ctx.band_lmax),
                        weight_sum=float(w.sum()))
            got = predict("spectral", ctx, rule).rmse
            assert abs(got / measured - 1.0) <= 3 * rel_se + 0.01, (brdf, ps, got / measured)


# ----------------------------------------------------------------------------- context, rule

def test_context_from_a_map():
    env = EnvMap(gaussian_process_map(1.5, 16, seed=2, channels=2) + 3.0)
    ctx = PredictionContext.from_map(env, 1.45, [1.0, 2.0], 1.5, [3.0, 4.0])
    assert ctx.band_lmax == 15 and ctx.map_power.shape == (2, 16)
    assert np.array_equal(ctx.transfer, map_transfer(env))
    assert ctx.mean_rms == pytest.approx(math.sqrt(np.mean(env.mean() ** 2)), rel=1e-15)
    assert ctx.sigma == pytest.approx(math.sqrt(2.5)) and ctx.sigma_bandlimited == pytest.approx(math.sqrt(12.5))
    assert ctx.sigma_bandlimited_channels == (3.0, 4.0) and ctx.s == 1.45


def test_rule_from_points():
    wf = Glossy(30.0)
    pts = generate("random", 20, seed=3, morph=wf.morph)
    w = np.random.default_rng(0).uniform(0.02, 0.08, 20)
    r = QuadratureRule.from_points(pts, w, wf, 1.7, 10)
    assert r.n == 20 and r.weight_sum == pytest.approx(w.sum(), rel=1e-15)
    # the same transform twice: ducc0's threaded sums may round differently between calls
    np.testing.assert_allclose(r.error_power, rule_error_power(pts, w, wf, 10), rtol=1e-12, atol=0)
    assert r.wce == pytest.approx(worst_case_error(pts, w, wf, 1.7), rel=1e-12)


# ----------------------------------------------------------------------------- the pipeline

def test_run_validation_loops_over_the_registry(monkeypatch):
    """A predictor added to PREDICTORS appears in every rule of run_validation's result
    and in the agreement statistics, under predicted_rmse_<name>."""
    from envfit.validate import _pipeline as V

    def predict_double(ctx, rule):
        return Prediction(name="double", rmse=None if rule.wce is None else 2 * ctx.sigma * rule.wce)

    monkeypatch.setitem(PREDICTORS, "double", predict_double)
    env = EnvMap(gaussian_process_map(1.5, 16, seed=0, channels=1), name="gp16")
    cfg = V.ValidateConfig(s=1.5, brdfs=("diffuse",), pointsets=("sf",), weights=("equal",),
                           n_values=(16, 64), axes=30, scale="linear", truncation=False,
                           fit_n=100)
    res = V.run_validation(env, cfg)
    e = res.rule("diffuse", "sf", "equal")
    assert e["predicted_rmse_double"] == [2 * x for x in e["predicted_rmse"]]
    ab = res.agreement["absolute"]
    assert ab["per_rule_double"][0]["predicted_over_measured"] == pytest.approx(
        [2 * x for x in ab["per_rule"][0]["predicted_over_measured"]], rel=1e-14)
    assert "predicted_rmse_double" in res.to_json()["results"][0]
