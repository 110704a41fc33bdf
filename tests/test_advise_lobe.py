"""The advisor's lobe range and zero predictions (issue 22, item 2).

A glossy lobe sharper than the degrees the predictions hold (2H − 1 on an H-row map) is
refused in one line before any work, with the largest shininess for the map; a lobe inside
the range is accepted (both ways, at the computed limit). The limit is checked against the
lobe's Funk–Hecke factors computed by the generic quadrature (an independent algorithm) and
against the large-n asymptote. A reached row predicted exactly 0 is never recommended.
"""
from __future__ import annotations

import math
import re
import time
import warnings

import numpy as np
import pytest

from envfit.advisor._advise import advise
from envfit.advisor._prediction import (LOBE_TAIL_TRANSFER, check_lobe_resolved, glossy_transfer,
                                        lobe_tail_transfer, max_resolved_shininess, rows_resolving)
from envfit.advisor._result import Advice, AdviceRow
from envfit.base._errors import ParameterError
from envfit.data_gen._gp import gaussian_process_map
from envfit.maps._envmap import EnvMap
from envfit.theory._brdf import Diffuse, Glossy, WeightFunction


def test_glossy_transfer_against_generic_quadrature_and_asymptote():
    # n = 200, 700: Glossy's generic Gauss–Legendre path (not the Bessel form)
    for n, l in ((200.0, 31), (700.0, 60)):
        b = WeightFunction.sh_coefficients(Glossy(n), l)[l]
        assert glossy_transfer(n, l) == pytest.approx(math.sqrt(4 * math.pi / (2 * l + 1)) * b,
                                                      rel=1e-10)
    # large n: λ_l → exp(−l(l+1)/2n) (Gaussian lobe of width 1/√n)
    for n, l in ((1e6, 1000), (1e7, 4000)):
        assert glossy_transfer(n, l) == pytest.approx(math.exp(-l * (l + 1) / (2 * n)), rel=2e-3)


@pytest.mark.parametrize("height", [16, 128])
def test_limit_both_ways(height):
    top = 2 * height - 1
    n_max = max_resolved_shininess(top)
    # the limit is where the lobe passes LOBE_TAIL_TRANSFER just above 2H − 1
    assert lobe_tail_transfer(Glossy(0.99 * n_max), top) <= LOBE_TAIL_TRANSFER
    assert lobe_tail_transfer(Glossy(1.01 * n_max), top) > LOBE_TAIL_TRANSFER
    check_lobe_resolved(Glossy(0.99 * n_max), height)
    with pytest.raises(ParameterError, match=re.escape(f"shininess <= {n_max:.3g} for this map")):
        check_lobe_resolved(Glossy(1.01 * n_max), height)
    # large-n asymptote: n_max ≈ (top+1)(top+2) / (2 ln 10)
    if height >= 128:
        assert n_max == pytest.approx((top + 1) * (top + 2) / (2 * math.log(10.0)), rel=0.02)
    check_lobe_resolved(Diffuse(), height)            # the diffuse lobe: any map


def test_rows_resolving_is_the_first_h_that_passes():
    for n in (1e4, 1e5):
        h = rows_resolving(n)
        check_lobe_resolved(Glossy(n), h)
        with pytest.raises(ParameterError):
            check_lobe_resolved(Glossy(n), h - 1)


def test_advise_refuses_a_sharp_lobe_before_any_work(tmp_path):
    env = EnvMap(gaussian_process_map(1.5, 16, seed=0), name="gp16")
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        with pytest.raises(ParameterError, match="the lobe passes 100 % of the map's content "
                                                 "at degree 32"):
            advise(env, "glossy", 0.01, shininess=1e6, cache_dir=str(tmp_path))
    assert time.perf_counter() - t0 < 5.0             # no fit, no search


def test_cli_sharp_lobe_one_line_exit_2(tmp_path, monkeypatch, capsys):
    from envfit.cli import main
    monkeypatch.setenv("ENVFIT_CACHE_DIR", str(tmp_path))
    rc = main(["advise", "--max-height", "16", "--brdf", "glossy", "--shininess", "1e6",
               "--target-rmse", "0.01", "--check", "--no-renderer", "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1
    assert err[0].startswith("envfit advise: error: shininess 1e+06") and "<= " in err[0]


def test_glossy_advice_inside_the_range_has_no_runtime_warning(tmp_path):
    """A soft lobe (n = 20) and a sharp one at 0.9x the limit of a 16-row map: no
    RuntimeWarning reaches the caller, every prediction is positive."""
    env = EnvMap(gaussian_process_map(1.5, 16, seed=0, channels=1), name="gp16")
    n_edge = 0.9 * max_resolved_shininess(31)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        for n in (20.0, n_edge):
            a = advise(env, "glossy", 0.05, shininess=n, scale="linear", s=1.5, fit_n=100,
                       pointsets=("sf",), weights=("equal",), bases=("sh",), nmax=256,
                       cache=False)
            for r in a.rows:
                assert r.predicted is not None and r.predicted > 0


def test_embedding_tail_warning_is_not_the_users(monkeypatch):
    """Shininess 1 (a jump at the horizon) warns from the embedding series' cap
    (≈ 140 s to reproduce, so the warning is injected): rule_plain_wce2 silences exactly that
    one and lets any other RuntimeWarning through."""
    import envfit.advisor._prediction as pm
    wf = Glossy(20.0)

    def fake(msg):
        def wce(*a, **k):
            warnings.warn(msg, RuntimeWarning)
            return 0.5
        return wce
    monkeypatch.setattr(pm, "worst_case_error", fake("kernel mean embedding of Glossy(1): tail"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        assert pm.rule_plain_wce2("sf", 8, wf, 1.5, "equal", []) == 0.25
    monkeypatch.setattr(pm, "worst_case_error", fake("something else"))
    with pytest.warns(RuntimeWarning, match="something else"):
        pm.rule_plain_wce2("sf", 8, wf, 1.5, "equal", [])


def _advice(rows):
    return Advice(map="m", map_size=[32, 16], channels=1, brdf="glossy", shininess=30.0,
                  scale="linear", scale_description="", target_rmse=0.01,
                  target_relative=None, mean_shading=1.0, s=1.5, s_interval=None, sigma=1.0,
                  sigma_channels=[1.0], fit_source="", fit_cached=False,
                  fit_kernel="bandlimited", fit_band_lmax=15, fit_samples=100, band_lmax=15,
                  mean_rms=1.0, rows=rows, recommendation="")


def test_zero_prediction_is_never_recommended():
    sh0 = AdviceRow("sh", L=15, cost=256, predicted_rmse=0.0, predictor="bandlimited")
    q = AdviceRow("quadrature", "sf", "equal", n=400, cost=400, predicted_rmse=0.009,
                  predictor="bandlimited")
    adv = _advice([sh0, q])
    assert adv.best() is q and not sh0.recommendable
    assert "predicted 0.0 by (b')" in sh0.note
    assert any(w.startswith("rule SH: predicted 0.0") for w in adv.warnings)
    # the other way: a positive prediction stays recommendable, and is chosen (cheaper)
    sh1 = AdviceRow("sh", L=15, cost=256, predicted_rmse=0.008, predictor="bandlimited")
    adv = _advice([sh1, AdviceRow("quadrature", "sf", "equal", n=400, cost=400,
                                  predicted_rmse=0.009, predictor="bandlimited")])
    assert adv.best() is sh1 and sh1.recommendable and not adv.warnings
    # not finite: the same
    bad = AdviceRow("sh", L=3, cost=16, predicted_rmse_spectral=float("nan"),
                    predictor="spectral")
    assert _advice([bad]).best() is None and np.isnan(bad.predicted)
