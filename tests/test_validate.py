"""Tests of envfit.validate._pipeline (pipeline + agreement statistics), envfit.validate._report, envfit.plots._validate
and the ``envfit validate`` CLI.

Independent references: ``envfit.theory._quadrature.worst_case_error`` / ``error_spectrum`` (the
closed form and the spectral sum), ``envfit.shading._estimators.quadrature_estimates`` (the
one-weight-vector estimator), a direct dense solve for σ̂, ``np.polyfit``, hand-computed
log-mean ratios, ``scipy.stats.kendalltau`` on known orders, and the Gaussian-process
identity E[(Ĩ − I)²] = σ²·wce² checked on a synthesized GP map. Tiny maps, few axes and N;
never /work/shared.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from envfit.data_gen._gp import gaussian_process_map
from envfit.fit import _sigma as SG
from envfit.shading import _quadrature as Q
from envfit.validate import _agreement as AG
from envfit.shading import _spectra as SP
from envfit.validate import _config as VC
from envfit.validate import _pipeline as V
from envfit.base._atomic import to_jsonable
from envfit.maps._envmap import EnvMap
from envfit.maps._io import save_envmap
from envfit.base._errors import ParameterError
from envfit.shading._estimators import quadrature_estimates
from envfit.theory._brdf import Diffuse, Glossy
from envfit.theory._pointsets import generate
from envfit.theory._quadrature import error_spectrum, worst_case_error
from envfit.theory._sobolev import generalized_distance_kernel
from envfit.theory._weights import optimal_weights

TINY = dict(s=1.5, brdfs=("diffuse", "glossy"), pointsets=("sf", "random"),
            weights=("equal", "osw"), n_values=(16, 32, 64), axes=60, scale="linear",
            sh_L=(0, 1, 2, 3, 4), hsh_L=(0, 1, 2, 3), diffuse_hsh_L=(0, 1), hsh_axes=12,
            hsh_max_height=16, equivalent_nmax=256, fit_n=150)


@pytest.fixture(scope="module")
def gp_map():
    return EnvMap(gaussian_process_map(1.5, 24, seed=4, channels=2), name="gp-tiny")


@pytest.fixture(scope="module")
def tiny_result(gp_map):
    return V.run_validation(gp_map, V.ValidateConfig(**TINY))


# ----------------------------------------------------------------------------- JSON shape

def test_pipeline_json_keys_and_shapes(tiny_result):
    assert isinstance(tiny_result, V.ValidationResult)
    r = tiny_result.to_json()
    for key in ("s", "sigma", "scale", "results", "truncation", "agreement"):
        assert key in r
    assert r["s"] == 1.5 and r["scale"] == "linear"
    assert len(r["results"]) == 2 * 2 * 2                     # brdf x pointset x weights
    for e in r["results"]:
        for key in ("brdf", "pointset", "weights", "n", "measured_rmse", "predicted_wce",
                    "predicted_rmse", "slope_measured", "slope_predicted"):
            assert key in e
        assert e["n"] == [16, 32, 64]
        for key in ("measured_rmse", "predicted_wce", "predicted_rmse", "predicted_rmse_refined"):
            assert len(e[key]) == 3 and all(v is not None and v > 0 for v in e[key])
    assert {(t["brdf"], t["basis"]) for t in r["truncation"]} == {
        ("diffuse", "sh"), ("diffuse", "hsh"), ("glossy", "sh"), ("glossy", "hsh")}
    for t in r["truncation"]:
        for key in ("L", "measured_rmse", "predicted_wce", "qmc_equivalent_n"):
            assert len(t[key]) == len(t["L"])
    json.dumps(to_jsonable(r))                                 # serialisable as is


def test_predicted_rmse_is_sigma_times_wce(tiny_result):
    r = tiny_result.to_json()
    assert r["sigma"] == pytest.approx(math.sqrt(np.mean(np.square(r["sigma_channels"]))), rel=1e-15)
    for e in r["results"]:
        assert e["predicted_rmse"] == [r["sigma"] * w for w in e["predicted_wce"]]
    for t in r["truncation"]:
        assert t["predicted_rmse"] == [r["sigma"] * w for w in t["predicted_wce"]]


def test_predicted_wce_matches_theory(tiny_result):
    """The stored wce is the theory's closed form (Eq. 41) for the very rule that was measured."""
    e = next(x for x in tiny_result.results if x["brdf"] == "glossy" and x["pointset"] == "sf"
             and x["weights"] == "osw")
    wf = Glossy(30.0)
    pts = generate("sf", 32, morph=wf.morph)
    w = optimal_weights(pts, wf, 1.5)
    assert e["predicted_wce"][1] == pytest.approx(worst_case_error(pts, w, wf, 1.5), rel=1e-9)
    assert e["weight_sum"][1] == pytest.approx(w.sum(), rel=1e-12)


def test_shape_constant_is_log_mean_ratio(tiny_result):
    r = tiny_result.to_json()
    for b in ("diffuse", "glossy"):
        ratios = [m / p for e in r["results"] if e["brdf"] == b
                  for m, p in zip(e["measured_rmse"], e["predicted_wce"])]
        expect = math.exp(sum(math.log(x) for x in ratios) / len(ratios))
        assert r["agreement"]["shape_fit"]["constant"][b] == pytest.approx(expect, rel=1e-12)
        for e in (x for x in r["results"] if x["brdf"] == b):
            assert e["predicted_shape"] == pytest.approx([expect * p for p in e["predicted_wce"]], rel=1e-12)
    # and directly: log c minimises sum (log m - log c - log p)^2
    m, p = np.array([1.0, 3.0, 0.5]), np.array([2.0, 1.0, 4.0])
    c = AG.shape_constant(m, p)
    assert c == pytest.approx(np.exp(np.mean(np.log(m / p))), rel=1e-14)
    res = lambda cc: np.sum((np.log(m) - np.log(cc) - np.log(p)) ** 2)   # noqa: E731
    assert res(c) < res(c * 1.01) and res(c) < res(c / 1.01)
    assert AG.shape_residual(3.0 * p, p) == pytest.approx(0.0, abs=1e-14)


def test_slopes_equal_polyfit(tiny_result):
    for e in tiny_result.results:
        n = np.array(e["n"], float)
        keep = (n >= 64) & (n <= 4096)
        if keep.sum() < 2:                      # only N = 64 in range: no slope
            assert e["slope_measured"] is None
        # the agreement recomputes over the effective range 64...64 -> None as well
    slopes = tiny_result.agreement["slopes"]
    assert tiny_result.agreement["slope_range"] == [64, 64]
    assert all(s["measured"] is None for s in slopes)
    n = np.array([16, 32, 64, 128, 256, 512], float)
    y = 0.3 * n ** -0.7 * np.exp(0.05 * np.sin(n))
    keep = n >= 64
    assert AG.loglog_slope(n, y) == pytest.approx(np.polyfit(np.log(n[keep]), np.log(y[keep]), 1)[0], rel=1e-12)
    assert AG.loglog_slope(n, y, None) == pytest.approx(np.polyfit(np.log(n), np.log(y), 1)[0], rel=1e-12)
    assert AG.loglog_slope([64], [1.0]) is None


def test_agreement_slopes_and_ratios_on_constructed_results():
    n = [64, 128, 256, 512]
    meas = [2.0 * x ** -0.8 for x in n]
    pred = [x ** -0.75 for x in n]
    res = [{"brdf": "diffuse", "pointset": ps, "weights": "equal", "n": n,
            "measured_rmse": [k * m for m in meas], "predicted_wce": [k * p for p in pred],
            "predicted_rmse": [k * p for p in pred], "predicted_rmse_refined": [k * p for p in pred],
            "wce_by_s": {"1.5000": [k * p for p in pred]}}
           for k, ps in ((1.0, "sf"), (3.0, "random"), (2.0, "sobol"))]
    a = AG.agreement(res, [], s_used=1.5)
    for s in a["slopes"]:
        assert s["measured"] == pytest.approx(-0.8, abs=1e-12)
        assert s["predicted"] == pytest.approx(-0.75, abs=1e-12)
        assert s["within_tolerance"] is True
    assert a["shape_fit"]["constant"]["diffuse"] == pytest.approx(
        math.exp(np.mean([math.log(m / p) for m, p in zip(meas, pred)])), rel=1e-12)
    rk = a["rank"][0]
    assert rk["measured_order"] == ["sf", "sobol", "random"] == rk["predicted_order"]
    assert rk["kendall_tau"] == pytest.approx(1.0)
    assert a["acceptance"]["slopes_ok"] and a["acceptance"]["rank_ok"]
    spread = a["ratios"][0]["spread"]
    assert spread == pytest.approx((512 / 64) ** 0.05, rel=1e-12)


def test_kendall_tau():
    names = ["sf", "sobol", "lp", "random"]
    same = AG.rank_agreement(names, [1, 2, 3, 4], [0.1, 0.2, 0.3, 0.4])
    assert same["kendall_tau"] == pytest.approx(1.0) and same["measured_order"] == names
    rev = AG.rank_agreement(names, [1, 2, 3, 4], [4, 3, 2, 1])
    assert rev["kendall_tau"] == pytest.approx(-1.0)
    one_swap = AG.rank_agreement(names, [1, 2, 3, 4], [1, 3, 2, 4])
    assert one_swap["kendall_tau"] == pytest.approx(4 / 6)      # (5 concordant - 1 discordant) / 6


# ----------------------------------------------------------------------------- building blocks

def test_multi_estimates_equal_single_estimator(gp_map):
    axes = Q.random_axes(30, 3)
    pts = generate("jitter", 20, seed=2, morph=Diffuse().morph)
    w1 = np.full(20, 1 / 20)
    w2 = np.random.default_rng(0).uniform(0, 0.1, 20)
    multi = Q.quadrature_estimates_multi(gp_map, axes, pts, [w1, w2], seed=[1, 2], workers=2, block=64)
    for k, w in enumerate((w1, w2)):
        assert np.allclose(multi[k], quadrature_estimates(gp_map, axes, pts, w, seed=[1, 2]),
                           rtol=0, atol=1e-13)


def test_fast_wce_and_bandlimited_match_theory():
    for wf in (Diffuse(), Glossy(30.0)):
        for ps in ("sf", "random"):
            pts = generate(ps, 40, seed=5, morph=wf.morph)
            for w in (np.full(40, 1 / 40), optimal_weights(pts, wf, 1.3)):
                for s in (1.1, 1.5, 1.9):
                    a = worst_case_error(pts, w, wf, s)
                    b = worst_case_error(pts, w, wf, s, embedding="chebyshev")
                    assert abs(a * a - b * b) < 1e-13
                sp = error_spectrum(pts, w, wf, 1.5, 50)
                assert SP.bandlimited_worst_case_error(pts, w, wf, 1.5, 50) == pytest.approx(
                    math.sqrt(sp.partial), rel=1e-10)


def test_profiled_sigma_matches_dense_solve():
    env = EnvMap(gaussian_process_map(1.5, 16, seed=7, channels=2, scale=3.0))
    n = 120
    sig = SG.profiled_sigma(env, 1.4, n=n, seed=0)
    # independent: explicit kernel from envfit.theory._sobolev, numpy solve, same sampling directions
    from envfit.theory._sphere_points import sphere_points
    from envfit.maps._latlong import local_to_world
    loc = sphere_points("sf", n)
    v = env.lookup(loc @ local_to_world(env.up).T).reshape(n, 2)
    v = v - v.mean(axis=0)
    K = generalized_distance_kernel(1.4, loc, loc)
    expect = np.sqrt(np.einsum("ic,ic->c", v, np.linalg.solve(K, v)) / n)
    assert np.allclose(sig, expect, rtol=1e-8)


def test_measured_equivalent_n_and_combine_sigma():
    assert AG.measured_equivalent_n([10, 100], [1.0, 0.1], 0.1 ** 0.5) == pytest.approx(10 ** 1.5, rel=1e-9)
    assert AG.measured_equivalent_n([10, 100], [1.0, 0.1], 2.0) is None
    assert SG.combine_sigma([1.0, 1.0, 4.0]) == pytest.approx(math.sqrt(6.0))


def test_gp_map_measured_rmse_matches_sigma_wce():
    r"""On a synthesized GP map (linear scale) the measured RMSE of SF/equal is σ̂·wce.

    Tolerance, from the number of axes: with M = 400 axes and C = 3 independent channels
    the relative standard error of an RMSE of independent Gaussian errors is
    1/sqrt(2·M·C) = 2.0 %. Errors at neighbouring axes are correlated and the map is a
    single GP realisation (its power at the few degrees that dominate at N = 32 scatters
    around a_l), so the scatter observed over 8 map seeds when this test was written is
    4 % (H = 64, N = 32); σ̂ from 400 samples adds ≈ 1/sqrt(2·400·3) = 2 %. 15 % is about
    3.5 times the combined scatter. N = 32 on a 64-row map is "moderate": the error comes
    from degrees well below the map's band limit 63, where (b) and (b') coincide to ~6 %;
    the glossy lobe is checked with (b') (its error lives near the band limit).
    """
    env = EnvMap(gaussian_process_map(1.5, 64, seed=11, channels=3), name="gp64")
    cfg = V.ValidateConfig(s=1.5, brdfs=("diffuse", "glossy"), pointsets=("sf",),
                           weights=("equal",), n_values=(32,), axes=400, scale="linear",
                           truncation=False, fit_n=400, seed=5)
    r = V.run_validation(env, cfg)
    d = r.rule("diffuse", "sf", "equal")
    g = r.rule("glossy", "sf", "equal")
    assert d["measured_rmse"][0] == pytest.approx(d["predicted_rmse"][0], rel=0.15)
    assert g["measured_rmse"][0] == pytest.approx(g["predicted_rmse_refined"][0], rel=0.15)
    # the relative standard error the pipeline reports is the 1/sqrt(2MC)-type figure
    assert 0.005 < d["measured_rel_se"][0] < 0.1


def test_resume_skips_finished_cells(gp_map, tmp_path):
    cfg = V.ValidateConfig(**{**TINY, "truncation": False, "n_values": (16, 32)})
    log1, log2, log3 = [], [], []
    r1 = V.run_validation(gp_map, cfg, out=tmp_path, on_cell=lambda k, res: log1.append((k, res)))
    assert not any(res for _, res in log1)
    r2 = V.run_validation(gp_map, cfg, out=tmp_path, on_cell=lambda k, res: log2.append((k, res)))
    assert len(log2) == len(log1) and all(res for _, res in log2)
    assert [e["measured_rmse"] for e in r2.results] == [e["measured_rmse"] for e in r1.results]
    victim = "quad_glossy_random_osw_32"
    (tmp_path / "cells" / f"{victim}.json").unlink()
    r3 = V.run_validation(gp_map, cfg, out=tmp_path, on_cell=lambda k, res: log3.append((k, res)))
    assert [k for k, res in log3 if not res] == [victim]
    e1 = r1.rule("glossy", "random", "osw")
    e3 = r3.rule("glossy", "random", "osw")
    assert e3["measured_rmse"] == pytest.approx(e1["measured_rmse"], rel=1e-12)
    # a different configuration is refused, not mixed
    with pytest.raises(ParameterError):
        V.run_validation(gp_map, V.ValidateConfig(**{**TINY, "axes": 61}), out=tmp_path)


def test_config_validation():
    for bad in ("abc", "2.5", "1", 0.9, "nan"):
        with pytest.raises(ParameterError):
            SG.parse_s(bad)
    with pytest.raises(ParameterError):
        V.ValidateConfig(pointsets=("sf", "halton"))
    with pytest.raises(ParameterError):
        V.ValidateConfig(n_values=(16, 1))
    q = VC.quick_config()
    assert q.axes == 500 and max(q.n_values) == 1024 and "bnot" not in q.pointsets


def test_truncation_truth(tiny_result):
    """Diffuse HSH is exact from L = 1 (errata: b~_l = 0 for l >= 2): what is left is the
    disagreement of two ground-truth methods on a 16-row map (the SH method's documented
    truncation tail, ~5e-6 of the largest value at H = 32, larger at H = 16)."""
    t = next(x for x in tiny_result.truncation if x["brdf"] == "diffuse" and x["basis"] == "hsh")
    assert t["predicted_wce"][1] == 0.0 and t["measured_rmse"][1] < 1e-4 * t["measured_rmse"][0]
    sh = next(x for x in tiny_result.truncation if x["brdf"] == "glossy" and x["basis"] == "sh")
    assert all(a >= b for a, b in zip(sh["predicted_wce"], sh["predicted_wce"][1:]))


# ----------------------------------------------------------------------------- report, plots, CLI

def test_report_sections(tiny_result):
    from envfit.validate._report import render_report
    md = render_report(tiny_result.to_json(), {"validate_quadrature_glossy.png": "/x/validate_quadrature_glossy.png"})
    for head in ("## What was run", "## Agreement", "### Rank order", "### Truncation",
                 "## What disagrees and why"):
        assert head in md
    assert "](validate_quadrature_glossy.png)" in md
    # every measured/predicted ratio of the absolute table is the one in the result
    e = tiny_result.agreement["absolute"]["per_rule"][0]
    assert f"{e['predicted_over_measured'][0]:.2f} /" in md


def test_cli_bad_s_exits_2_with_one_line(capsys):
    from envfit.cli import main
    for bad in ("2.5", "abc"):
        rc = main(["validate", "--s", bad, "--quiet"])
        err = capsys.readouterr().err
        assert rc == 2
        assert err.count("\n") == 1 and err.startswith("envfit validate: error:") and "--s" in err


def test_cli_end_to_end(tmp_path, capsys):
    from envfit.cli import main
    data = gaussian_process_map(1.5, 16, seed=2, channels=3, offset=5.0)
    path = save_envmap(tmp_path / "tiny.exr", data.astype(np.float32))
    out = tmp_path / "out"
    rc = main(["validate", str(path), "--s", "1.4", "--brdf", "glossy", "--n", "16,32",
               "--axes", "40", "--pointsets", "sf,random", "--sh-L", "0,1,2", "--hsh-L", "0,1",
               "--hsh-axes", "6", "--hsh-max-height", "8", "--fit-n", "100", "--scale", "linear",
               "--out", str(out), "--json", "-", "--quiet"])
    assert rc == 0
    res = json.loads(capsys.readouterr().out)
    assert res["s"] == 1.4 and res["fit"]["source"] == "given"
    assert [e["brdf"] for e in res["results"]] == ["glossy"] * 4
    md = (out / "report.md").read_text()
    assert md.startswith("# Validation of predicted")
    assert json.loads((out / "validate.json").read_text())["s"] == 1.4
    # the verdicts of the JSON are the report's judgements: its bullets, sentence for sentence
    from envfit.validate._report_predicates import Verdict
    from envfit.validate._report_template import bullets
    verdicts = [Verdict(**v) for v in res["verdicts"]]
    assert {v.section for v in verdicts} == {"acceptance", "disagreements"}
    lines = bullets(verdicts, "disagreements")
    assert lines and all(f"- {x}\n" in md for x in lines)
    for name in ("validate_quadrature_glossy.png", "validate_absolute_glossy.png",
                 "validate_truncation.png", "validate_s_choice.png"):
        with open(out / name, "rb") as fh:
            assert fh.read(8) == b"\x89PNG\r\n\x1a\n"


def test_auto_s_path(gp_map):
    """--s auto: s and σ come from envfit.fit._smoothness (likelihood); σ matches the profiled σ̂ at that s."""
    cfg = V.ValidateConfig(**{**TINY, "s": "auto", "truncation": False, "n_values": (16,),
                              "pointsets": ("sf",), "weights": ("equal",), "fit_n": 150})
    r = V.run_validation(gp_map, cfg)
    assert r.fit["source"] == "fit"
    from envfit.fit._smoothness import fit_smoothness
    direct = fit_smoothness(gp_map, method=cfg.fit_method, n=cfg.fit_n, scale=cfg.scale,
                            seed=cfg.seed)
    assert r.s == pytest.approx(direct.s, abs=1e-9)     # the fit's own ŝ, not a copy of it
    # the fit's own interval (it contains ŝ by construction: lo <= ŝ <= hi could not fail)
    assert r.fit["s_interval"] == pytest.approx(direct.s_interval, abs=1e-9)
    sig = SG.profiled_sigma(gp_map, r.s, n=150, seed=0)
    assert np.allclose(r.sigma_channels, sig, rtol=1e-6)


def test_low_degree_power_ratio_on_known_spectrum():
    """A map with known real SH coefficients at l = 2 only: ρ_2 = P_2/(σ² a_2), ρ_l ≈ 0 elsewhere.

    Reference: the coefficients put in (envfit.data_gen._sht.synthesize); the bilinear interpolant of a
    64-row map changes a degree-2 coefficient by O((l π/H)²) ≈ 1e-3 relative.
    """
    from envfit.data_gen._sht import real_index, synthesize
    from envfit.theory._sobolev import sobolev_coefficients
    c = np.zeros(9)
    c[real_index(2, np.arange(-2, 3))] = [1.0, 2.0, 0.0, -1.0, 0.5]
    env = EnvMap(synthesize(c, 64)[:, :, None] + 3.0)           # an offset only changes l = 0
    rho = V.low_degree_power_ratio(env, [2.0], 1.5, lmax=4)
    expect = (1 + 4 + 1 + 0.25) / 5 / (4.0 * sobolev_coefficients(1.5, 2)[2])
    assert rho["2"] == pytest.approx(expect, rel=5e-3)
    assert rho["1"] < 1e-8 * expect and rho["3"] < 1e-6 * expect


def test_map_degree_power_of_known_coefficients():
    """P̂_l of a map built from known real SH coefficients (envfit.data_gen._sht.synthesize): the
    sum of squares / (2l+1) put in, to the O((lπ/H)²) bilinear change; l = 0 is 4π·mean²."""
    from envfit.data_gen._sht import real_index, synthesize
    c = np.zeros(16)
    c[real_index(1, np.arange(-1, 2))] = [0.3, -1.0, 0.0]
    c[real_index(3, np.arange(-3, 4))] = [0.0, 0.5, 0.0, 0.0, 2.0, 0.0, -0.25]
    env = EnvMap(synthesize(c, 128)[:, :, None] + 2.0)
    P = SP.map_degree_power(env, 5)
    assert P.shape == (1, 6)
    assert P[0, 0] == pytest.approx(4 * np.pi * 4.0, rel=1e-6)
    assert P[0, 1] == pytest.approx((0.09 + 1.0) / 3, rel=2e-3)
    assert P[0, 3] == pytest.approx((0.25 + 4.0 + 0.0625) / 7, rel=5e-3)
    assert P[0, 2] < 1e-8 and P[0, 4] < 1e-6 and P[0, 5] < 1e-6


def test_rule_error_power_sums_to_wce():
    """Σ_l a_l e_l = wce² of envfit.theory._quadrature.worst_case_error (closed form); the sum stops
    at l = 4000, whose tail (a_l e_l ~ l^(1-2s)) is ~3e-4 of the total at s = 1.7."""
    from envfit.theory._sobolev import sobolev_coefficients
    pts = generate("sf", 40, morph=Glossy(10.0).morph)
    w = np.full(40, 1 / 40)
    e = V.rule_error_power(pts, w, Glossy(10.0), 4000)
    a = sobolev_coefficients(1.7, 4000)
    assert math.fsum(a * e) == pytest.approx(worst_case_error(pts, w, Glossy(10.0), 1.7) ** 2, rel=1e-3)


def test_spectral_prediction_matches_measured_rmse():
    """Prediction (c), from the map's own spectrum, against the RMSE measured over many random
    rotations on a map whose bilinear interpolant is (nearly) band-limited: a low-degree map
    on a fine grid. Agreement within 3 standard errors of the measured RMSE (the Monte Carlo
    error of M axes, also an independent computation: ground truth by shading_integral,
    estimates by bilinear lookups)."""
    from envfit.data_gen._sht import synthesize
    rng = np.random.default_rng(5)
    c = rng.normal(size=100) / (1.0 + np.repeat(np.arange(10), 2 * np.arange(10) + 1))
    env = EnvMap(np.stack([synthesize(c, 96), synthesize(rng.permutation(c), 96)], axis=2) + 1.0)
    cfg = V.ValidateConfig(s=1.5, brdfs=("diffuse", "glossy"), pointsets=("sf", "random"),
                           weights=("equal", "osw"), n_values=(8, 24), axes=1500, scale="linear",
                           truncation=False, fit_n=100)
    res = V.run_validation(env, cfg).to_json()
    for e in res["results"]:
        for m, p, se in zip(e["measured_rmse"], e["predicted_rmse_spectral"], e["measured_rel_se"]):
            assert abs(p / m - 1.0) <= 3.0 * se + 0.01, (e["brdf"], e["pointset"], e["weights"], p / m, se)
    assert res["agreement"]["absolute"]["slope_range_spectral"] is None or \
        res["agreement"]["absolute"]["all_spectral"]["cells"] == 16


def test_model_scatter_against_sampled_spectra():
    """model_scatter (delta method) against the spread of sqrt(Σ P̂_l e_l) over sampled
    realisations P̂_l ~ σ² a_l χ²_{(2l+1)C}/((2l+1)C) (numpy's chi-square sampler)."""
    from envfit.theory._sobolev import sobolev_coefficients
    pts = generate("random", 64, seed=2, morph=Diffuse().morph)
    e = V.rule_error_power(pts, np.full(64, 1 / 64), Diffuse(), 60)
    sig = [1.0, 2.0, 0.5]
    a = sobolev_coefficients(1.5, 60)
    rng = np.random.default_rng(0)
    dof = 2 * np.arange(61) + 1
    draws = []
    for _ in range(4000):
        P = np.array([s ** 2 * a * rng.chisquare(dof) / dof for s in sig])
        P[:, 0] = 0.0
        draws.append(math.sqrt(np.mean(P @ e)))
    draws = np.asarray(draws)
    assert SP.model_scatter(e, 1.5, sig) == pytest.approx(draws.std() / draws.mean(), rel=0.1)
