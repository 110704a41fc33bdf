"""The band-limited kernel K_L (envfit.sobolev._bandlimited), its likelihood, the pixel-centre samples,
the band-limited fit of s, and the lookup transfer τ_l (envfit.shading._spectra)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from envfit.data_gen._gp import expected_variance, gaussian_process_map
from envfit.data_gen._sht import real_index, synthesize
from envfit.sobolev._bandlimited import (BandlimitedKernel, bandlimited_log_likelihood,
                                         pixel_centre_samples)
from envfit.maps._envmap import EnvMap
from envfit.base._errors import ParameterError
from envfit.fit._smoothness import fit_smoothness
from envfit.shading._spectra import (bandlimited_worst_case_errors, lookup_transfer,
                                     map_degree_power, pixel_degree_power, rule_error_power,
                                     spectral_rmse)
from envfit.theory._brdf import Glossy
from envfit.theory._pointsets import generate
from envfit.theory._sobolev import kernel_series, sobolev_coefficients


def _unit(rng, n):
    p = rng.normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1, keepdims=True)


@pytest.mark.parametrize("s", [1.1, 1.5, 1.9])
@pytest.mark.parametrize("lmax", [3, 64, 300])
def test_kernel_table_against_the_legendre_sum(s, lmax):
    """The tabulated kernel (DCT-I table + cubic interpolation in θ) against the direct
    Legendre sum (three-term recurrence) at random and nearly coincident directions."""
    rng = np.random.default_rng(0)
    t = np.concatenate([np.cos(rng.uniform(0, np.pi, 3000)), np.cos(np.linspace(0, 2e-3, 50)),
                        [1.0, -1.0]])
    k = BandlimitedKernel(s, lmax)
    ref = kernel_series(s, t, lmax)
    assert np.max(np.abs(k.at_cosine(t) - ref)) <= 1e-9 * k.variance


def test_variance_is_the_closed_form_and_the_matrix_is_symmetric():
    """K_L(u, u) = Σ_{l≤L}(2l+1)a_l/4π, for s = 1.5 the telescoped closed form
    8/3 − ½(1/(L+½) + 1/(L+3/2)); the matrix equals the Legendre sum entry by entry."""
    L = 40
    k = BandlimitedKernel(1.5, L)
    assert k.variance == pytest.approx(8 / 3 - 0.5 * (1 / (L + 0.5) + 1 / (L + 1.5)), rel=1e-12)
    assert k.variance == pytest.approx(expected_variance(1.5, L), rel=1e-12)
    p = _unit(np.random.default_rng(1), 60)
    K = k.matrix(p)
    assert np.array_equal(K, K.T)
    assert np.allclose(K, kernel_series(1.5, np.clip(p @ p.T, -1, 1), L), rtol=0, atol=1e-10)


def test_likelihood_matches_scipy_multivariate_normal():
    """ℓ at the profiled σ̂ equals scipy.stats.multivariate_normal(0, σ̂² K_L).logpdf, per
    channel; σ̂² = fᵀK⁻¹f/N."""
    rng = np.random.default_rng(2)
    p = _unit(rng, 80)
    f = rng.normal(size=(80, 2)) * [1.0, 3.0]
    ll, sig = bandlimited_log_likelihood(p, f, 1.4, 30)
    K = BandlimitedKernel(1.4, 30).matrix(p)
    for c in range(2):
        assert sig[c] ** 2 == pytest.approx(f[:, c] @ np.linalg.solve(K, f[:, c]) / 80, rel=1e-10)
        ref = stats.multivariate_normal(mean=np.zeros(80), cov=sig[c] ** 2 * K).logpdf(f[:, c])
        assert ll[c] == pytest.approx(ref, rel=1e-9)
    ll1, sig1 = bandlimited_log_likelihood(p, f[:, 1], 1.4, 30)
    assert isinstance(ll1, float) and ll1 == pytest.approx(ll[1], rel=1e-12)


def test_bad_inputs_are_reported():
    p = _unit(np.random.default_rng(3), 30)
    with pytest.raises(ParameterError, match="positive definite"):
        bandlimited_log_likelihood(p, np.ones(30), 1.5, 2)   # 30 samples, (L+1)² = 9 modes
    with pytest.raises(ParameterError, match="band limit"):
        BandlimitedKernel(1.5, 0)
    with pytest.raises(ParameterError):
        BandlimitedKernel(2.5, 10)
    with pytest.raises(ParameterError, match="NaN"):
        bandlimited_log_likelihood(p, np.full(30, np.nan), 1.5, 20)
    env = EnvMap(gaussian_process_map(1.5, 16, seed=0))
    with pytest.raises(ParameterError, match="likelihood"):
        fit_smoothness(env, method="loo", n=50, scale="linear", kernel="bandlimited")
    with pytest.raises(ParameterError, match="kernel"):
        fit_smoothness(env, n=50, scale="linear", kernel="wide")


def test_pixel_centre_samples_are_the_pixel_values():
    data = np.random.default_rng(4).uniform(size=(16, 32, 2))
    env = EnvMap(data)
    d = env.directions().reshape(-1, 3)
    jitter = d + 1e-3 * np.random.default_rng(5).normal(size=d.shape)   # well inside a pixel
    c, v = pixel_centre_samples(env, np.concatenate([jitter[[7, 100, 7]], d[[300]]]))
    assert np.array_equal(v, data.reshape(-1, 2)[[7, 100, 300]])
    assert np.allclose(c, d[[7, 100, 300]], atol=1e-15)


def test_bandlimited_fit_recovers_s0_on_gp_maps_where_the_full_kernel_does_not():
    """On 64-row GP maps (band-limited at 63) the band-limited fit recovers s0; the full
    kernel with bilinear samples reads the map as smoother. Calibration (6 seeds, 4
    channels, N = 800): band-limited mean 1.275 (s0 = 1.3) and 1.674 (s0 = 1.7), sd 0.025,
    14 more seeds at s0 = 1.5: mean 1.492; full kernel 1.464 and 1.791. Bounds: 3.5 sd per
    map, and the full kernel's bias is more than 4 sd."""
    for s0 in (1.3, 1.7):
        env = EnvMap(gaussian_process_map(s0, 64, seed=3, channels=4))
        bl = fit_smoothness(env, n=800, scale="linear", kernel="bandlimited")
        full = fit_smoothness(env, n=800, scale="linear")
        assert abs(bl.s - s0) < 0.09, bl.s
        assert bl.s_interval[0] - 0.02 <= s0 <= bl.s_interval[1] + 0.02
        assert full.s - s0 > 0.1, full.s
        assert bl.kernel == "bandlimited" and bl.band_lmax == 63 and bl.n <= 800
        assert np.all(np.asarray(bl.sigma) > 0.7) and np.all(np.asarray(bl.sigma) < 1.4)


def test_pixel_degree_power_of_known_coefficients():
    """The pixel analysis returns the power put in by envfit.data_gen._sht.synthesize, exactly."""
    c = np.zeros(25)
    c[real_index(2, np.arange(-2, 3))] = [1.0, 0.0, 2.0, 0.0, -1.0]
    c[real_index(4, 1)] = 3.0
    env = EnvMap(synthesize(c, 32)[:, :, None])
    P = pixel_degree_power(env)
    assert P.shape == (1, 32)
    assert P[0, 2] == pytest.approx(6.0 / 5, rel=1e-10)
    assert P[0, 4] == pytest.approx(9.0 / 9, rel=1e-10)
    assert np.delete(P[0], [2, 4]).max() < 1e-20
    with pytest.raises(ParameterError):
        pixel_degree_power(env, 32)                            # beyond the Nyquist degree


def test_lookup_transfer_and_the_refined_prediction_against_the_spectral_one():
    """τ_l is 1 at low degrees and falls towards the Nyquist degree (the bilinear
    interpolant is smoother); with it, σ²Σ a_l τ_l e_l (the model, true s and σ = 1) agrees
    with Σ P̂_l e_l (the map's own spectrum: a second computation) to within the expected
    scatter of one map (model_scatter ≈ 1 % here for SF at N = 256) plus 2 %, and without τ
    it does not (8 % high)."""
    H = 64
    env = EnvMap(gaussian_process_map(1.5, H, seed=7, channels=6))
    Pb = map_degree_power(env, H - 1)
    tau = lookup_transfer(Pb, pixel_degree_power(env))
    assert np.all(np.abs(tau[1:8] - 1.0) < 0.03)
    assert 0.15 < tau[H - 1] < 0.4 and tau[H // 2] < 0.85
    wf = Glossy(30.0)
    pts = generate("sf", 256, morph=wf.morph)
    e = rule_error_power(pts, np.full(256, 1 / 256), wf, H - 1)
    spectral = spectral_rmse(e, Pb)
    with_tau = bandlimited_worst_case_errors(None, None, None, [1.5], H - 1, power=e, transfer=tau)[0]
    without = bandlimited_worst_case_errors(None, None, None, [1.5], H - 1, power=e)[0]
    assert with_tau / spectral == pytest.approx(1.0, abs=0.05)
    assert without / spectral > 1.06
    a = sobolev_coefficients(1.5, H - 1)
    assert with_tau == pytest.approx(math.sqrt(np.sum((a * tau * e)[1:])), rel=1e-12)


def test_small_maps_cap_the_samples_at_half_the_degrees_of_freedom():
    """More than (L+1)² samples make K_L singular (rank (L+1)²): the fit takes at most half
    of an H-row map's H² degrees of freedom, says so, and refuses maps under 5 rows."""
    env = EnvMap(gaussian_process_map(1.5, 16, seed=1, channels=2))
    f = fit_smoothness(env, n=3000, scale="linear", kernel="bandlimited")
    assert f.n <= 128 and any("capped at 128" in note for note in f.notes)
    # the cap is exactly 128 samples: asking for 128 gives the same fit, to the last digit
    # (the search clamps s into (1, 2), so a range check on f.s could not fail)
    g = fit_smoothness(env, n=128, scale="linear", kernel="bandlimited")
    assert g.n == 128 and g.s == f.s and np.array_equal(g.sigma, f.sigma)
    with pytest.raises(ParameterError, match="too small"):
        fit_smoothness(EnvMap(gaussian_process_map(1.5, 4, seed=1)), n=50, scale="linear",
                       kernel="bandlimited")
    from envfit.fit._sigma import bandlimited_profiled_sigma
    sig, used = bandlimited_profiled_sigma(env, 1.5, n=3000)
    assert used <= 128 and np.all(sig > 0)
