"""Tests of envfit.data_gen._gp and envfit.data_gen._sht: Gaussian-process maps of known Sobolev smoothness.

Every statistic is checked against an independent computation: the SH projection below uses
its own normalised associated-Legendre recurrence (checked against scipy.special.sph_harm_y),
numpy's FFT in φ and Gauss–Legendre quadrature in cos θ after exact trigonometric
interpolation in θ, never ducc0's analysis; the variance uses Fejér's first-rule weights.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from scipy.special import sph_harm_y

from envfit.data_gen import _gp as gp, _sht as sht
from envfit.data_gen import SyntheticMapError
from envfit.theory._sobolev import (generalized_distance_kernel, kernel_constant,
                                    sobolev_coefficients)


# ----------------------------------------------------------------------------- references

def real_ylm_scipy(l, m, theta, phi):
    """Real orthonormal Y_lm (no Condon–Shortley phase) from scipy's complex sph_harm_y."""
    if m == 0:
        return sph_harm_y(l, 0, theta, phi).real
    y = sph_harm_y(l, abs(m), theta, phi)
    return np.sqrt(2.0) * (-1.0) ** abs(m) * (y.real if m > 0 else y.imag)


def legendre_rows(lmax, x):
    """Yield (l, P) with P[m, q] = orthonormal P_l^m(cos x_q) incl. CS phase (0 for m > l)."""
    z, s = np.cos(x), np.sin(x)
    M = lmax + 1
    m = np.arange(M, dtype=float)[:, None]
    diag = np.empty((M, x.size))
    diag[0] = 1.0 / np.sqrt(4 * np.pi)
    for k in range(1, M):
        diag[k] = -np.sqrt((2 * k + 1) / (2 * k)) * s * diag[k - 1]
    p2 = np.zeros((M, x.size))
    p1 = np.zeros((M, x.size))
    for l in range(M):
        p = np.zeros((M, x.size))
        if l >= 1:
            a = np.sqrt((4 * l * l - 1) / (l * l - m[:l] ** 2))
            p[:l] = a * z * p1[:l]
            if l >= 2:
                aprev = np.sqrt((4 * (l - 1) ** 2 - 1) / ((l - 1) ** 2 - m[:l - 1] ** 2))
                p[:l - 1] -= a[:l - 1] / aprev * p2[:l - 1]
        p[l] = diag[l]
        yield l, p
        p2, p1 = p1, p


def power_spectrum_f1(maps, lmax):
    """Angular power spectrum C_l (lmax+1, C) of H×2H×C maps band-limited to degree ≤ H−1.

    φ: numpy FFT gives G_m(θ_i). θ: G_m extends to a 2π-periodic trigonometric polynomial of
    degree ≤ H−1 (G_m(2π−θ) = (−1)^m G_m(θ)), known at 2H equispaced points, so it is
    interpolated exactly onto H Gauss–Legendre nodes in cos θ, where G_m P_l^m is a
    polynomial of degree ≤ 2H−2: the projection is exact.
    """
    f = np.asarray(maps, dtype=float)
    if f.ndim == 2:
        f = f[..., None]
    H, W, C = f.shape
    m = np.arange(lmax + 1)
    G = np.fft.fft(f, axis=1)[:, :lmax + 1, :] / W * np.exp(-1j * m * np.pi / W)[None, :, None]
    z, wq = np.polynomial.legendre.leggauss(H)
    x = np.arccos(z)
    j = np.arange(1, H)
    vt = np.pi * (np.arange(2 * H) + 0.5) / H
    T = (1 + 2 * (np.cos(np.outer(x, j)) @ np.cos(np.outer(vt, j)).T
                  + np.sin(np.outer(x, j)) @ np.sin(np.outer(vt, j)).T)) / (2 * H)
    Te = T[:, :H] + T[:, ::-1][:, :H]
    To = T[:, :H] - T[:, ::-1][:, :H]
    g = np.where((m % 2 == 0)[None, :, None],
                 np.einsum("qi,imc->qmc", Te, G), np.einsum("qi,imc->qmc", To, G))
    gw = g * wq[:, None, None]
    out = np.empty((lmax + 1, C))
    for l, P in legendre_rows(lmax, x):
        flm = 2 * np.pi * np.einsum("mq,qmc->mc", P[:l + 1], gw[:, :l + 1])   # (l+1, C)
        p = np.abs(flm) ** 2
        out[l] = (p[0] + 2 * p[1:].sum(axis=0)) / (2 * l + 1)
    return out


def fejer1_weights(n):
    """Fejér's first rule on [−1, 1] at z_k = cos((2k+1)π/(2n)) (closed form)."""
    th = (2 * np.arange(n) + 1) * np.pi / (2 * n)
    j = np.arange(1, n // 2 + 1)
    return 2.0 / n * (1 - 2 * np.sum(np.cos(2 * np.outer(th, j)) / (4 * j * j - 1), axis=1))


def chi2_pvalue(stat, dof):
    """Two-sided p-value of a χ² statistic."""
    return 2 * min(stats.chi2.cdf(stat, dof), stats.chi2.sf(stat, dof))


# ----------------------------------------------------------------------------- the references

def test_legendre_recurrence_matches_scipy():
    x = np.linspace(1e-3, np.pi - 1e-3, 29)
    for l, P in legendre_rows(120, x):
        if l in (0, 1, 2, 9, 64, 120):
            for m in {0, 1, l // 2, l}:
                np.testing.assert_allclose(P[m], sph_harm_y(l, m, x, 0.0).real, atol=1e-11)


def test_power_spectrum_reference_is_exact_on_a_direct_synthesis():
    H, L = 12, 11
    theta, phi = sht.grid_angles(H)
    T, P = np.meshgrid(theta, phi, indexing="ij")
    c = np.random.default_rng(7).standard_normal((L + 1) ** 2)
    f = sum(c[l * l + l + m] * real_ylm_scipy(l, m, T, P)
            for l in range(L + 1) for m in range(-l, l + 1))
    expected = np.array([np.sum(c[l * l:(l + 1) ** 2] ** 2) / (2 * l + 1) for l in range(L + 1)])
    np.testing.assert_allclose(power_spectrum_f1(f, L)[:, 0], expected, rtol=1e-10, atol=1e-13)


def test_fejer_weights_closed_form():
    n = 16
    w = fejer1_weights(n)
    z = np.cos((2 * np.arange(n) + 1) * np.pi / (2 * n))
    for d in range(n):     # exact for polynomials of degree ≤ n − 1
        assert abs(np.sum(w * z ** d) - (2.0 / (d + 1) if d % 2 == 0 else 0.0)) < 1e-13


# ----------------------------------------------------------------------------- sht convention

def test_grid_is_the_latlong_pixel_centres():
    theta, phi = sht.grid_angles(4)
    np.testing.assert_allclose(theta, np.pi * (np.arange(4) + 0.5) / 4)
    np.testing.assert_allclose(phi, 2 * np.pi * (np.arange(8) + 0.5) / 8)
    d = sht.grid_directions(4)
    np.testing.assert_allclose(d[1, 2], [np.sin(theta[1]) * np.cos(phi[2]),
                                         np.sin(theta[1]) * np.sin(phi[2]), np.cos(theta[1])])


@pytest.mark.parametrize("L,l,m", [(7, 0, 0), (7, 1, 1), (7, 1, -1), (7, 3, 2), (7, 3, -2),
                                   (7, 7, -7), (7, 7, 7), (12, 11, 9), (12, 12, -10)])
def test_single_real_coefficient_synthesises_the_real_harmonic(L, l, m):
    """(c) ducc0 + real_to_complex_alm reproduce c·Y_lm(θ_i, φ_j), incl. L above Nyquist (H=8)."""
    H = 8
    theta, phi = sht.grid_angles(H)
    T, P = np.meshgrid(theta, phi, indexing="ij")
    c = np.zeros((L + 1) ** 2)
    c[sht.real_index(l, m)] = 1.7
    np.testing.assert_allclose(sht.synthesize(c, H, lmax=L), 1.7 * real_ylm_scipy(l, m, T, P),
                               atol=1e-13)


def test_real_complex_round_trip_and_analysis():
    L = 9
    c = np.random.default_rng(3).standard_normal((2, (L + 1) ** 2))
    np.testing.assert_allclose(sht.complex_to_real_alm(sht.real_to_complex_alm(c, L), L), c,
                               atol=1e-15)
    maps = sht.synthesize(c, L + 1)                    # Nyquist grid: H = L + 1
    np.testing.assert_allclose(sht.analyze(maps), c, atol=1e-12)
    with pytest.raises(SyntheticMapError, match="exact only up to"):
        sht.analyze(maps, L + 1)


def test_complex_alm_variance_convention():
    """Real coefficients of variance a give Re, Im of a_lm (m > 0) variance a/2, a_l0 variance a."""
    L, n = 4, 4000
    c = np.random.default_rng(11).standard_normal((n, (L + 1) ** 2))
    alm = sht.real_to_complex_alm(c, L)
    m = np.concatenate([np.full(L + 1 - mm, mm) for mm in range(L + 1)])
    var_re, var_im = alm.real.var(axis=0), alm.imag.var(axis=0)
    tol = 5 * np.sqrt(2 / n)
    assert np.all(np.abs(var_re[m == 0] - 1) < tol) and np.all(var_im[m == 0] == 0)
    assert np.all(np.abs(var_re[m > 0] - 0.5) < tol * 0.5)
    assert np.all(np.abs(var_im[m > 0] - 0.5) < tol * 0.5)


# ----------------------------------------------------------------------------- GP spectrum

@pytest.mark.parametrize("s0,H,C", [(1.5, 256, 4), (1.15, 128, 4), (1.85, 128, 4)])
def test_gp_power_spectrum_matches_sobolev_coefficients(s0, H, C):
    """(a) (2l+1) Ĉ_l / a_l summed over channels and a band of l is χ² with Σ C(2l+1) dof."""
    f = gp.gaussian_process_map(s0, H, seed=2024, channels=C, offset=10.0, scale=1.0)
    L = H - 1
    Chat = power_spectrum_f1(f - 10.0, L)                         # (L+1, C)
    a = sobolev_coefficients(s0, L)
    np.testing.assert_allclose(gp.expected_power_spectrum(s0, L), a)
    l = np.arange(L + 1)
    ratio = ((2 * l + 1)[:, None] * Chat / a[:, None]).sum(axis=1)
    dof = C * (2 * l + 1)
    edges = [0, 1, 4, 16, 64, L + 1]
    for lo, hi in zip(edges[:-1], edges[1:]):
        p = chi2_pvalue(ratio[lo:hi].sum(), dof[lo:hi].sum())
        assert p > 1e-5, (lo, hi, ratio[lo:hi].sum(), dof[lo:hi].sum())
    # the statistic has power: the spectrum of a neighbouring smoothness is rejected
    a_wrong = sobolev_coefficients(s0 + 0.1, L)
    wrong = ((2 * l + 1)[:, None] * Chat / a_wrong[:, None]).sum(axis=1)
    assert chi2_pvalue(wrong[64:].sum(), dof[64:].sum()) < 1e-10


def test_gp_sample_variance_matches_band_sum():
    """(b) Fejér-weighted spatial variance about the mean vs Σ_{1≤l≤L} (2l+1) a_l / (4π)."""
    s0, H, C = 1.5, 64, 64
    f = gp.gaussian_process_map(s0, H, seed=99, channels=C)
    w = fejer1_weights(H)[:, None, None] * (2 * np.pi / (2 * H))  # per-pixel weights, Σ = 4π
    np.testing.assert_allclose(w.sum() * 2 * H, 4 * np.pi)
    mean = (w * f).sum(axis=(0, 1)) / (4 * np.pi)
    var = (w * f ** 2).sum(axis=(0, 1)) / (4 * np.pi) - mean ** 2              # (C,)
    a = sobolev_coefficients(s0, H - 1)
    l = np.arange(H)
    expected = np.sum((2 * l[1:] + 1) * a[1:]) / (4 * np.pi)
    np.testing.assert_allclose(expected, gp.expected_variance(s0, H - 1) - a[0] / (4 * np.pi))
    sigma = np.sqrt(np.sum(2 * (2 * l[1:] + 1) * a[1:] ** 2)) / (4 * np.pi) / np.sqrt(C)
    assert abs(var.mean() - expected) < 5 * sigma, (var.mean(), expected, sigma)
    assert abs(var.mean() - 2 * expected) > 5 * sigma      # a factor-2 convention error fails


def test_expected_variance_closed_forms():
    # s = 1.5: a_l = 2π/((l−½)(l+½)(l+3/2)) telescopes to 8/3 − ½(1/(L+½) + 1/(L+3/2))
    for L in (0, 1, 5, 200):
        closed = 8 / 3 - 0.5 * (1 / (L + 0.5) + 1 / (L + 1.5)) if L > 0 else 4 / 3
        assert abs(gp.expected_variance(1.5, L) - closed) < 1e-12
    assert gp.expected_variance(1.3) == pytest.approx(2 ** 1.6 / 1.3, rel=1e-15)
    assert gp.expected_variance(1.5, 100000) == pytest.approx(8 / 3, abs=2e-5)


def test_offset_scale_per_channel_and_above_nyquist():
    g = gp.gaussian_process_map(1.4, 16, seed=5, channels=2)
    f = gp.gaussian_process_map(1.4, 16, seed=5, channels=2, offset=[1.0, 2.0], scale=[3.0, 4.0])
    np.testing.assert_allclose(f, np.array([1.0, 2.0]) + np.array([3.0, 4.0]) * g, atol=1e-14)
    with pytest.raises(SyntheticMapError, match="one value per channel"):
        gp.gaussian_process_map(1.4, 16, seed=5, channels=2, offset=[1.0, 2.0, 3.0])
    wide = gp.gaussian_process_map(1.4, 16, seed=5, lmax=40)   # point values of a wider band
    assert wide.shape == (16, 32, 1) and np.all(np.isfinite(wide))


# ----------------------------------------------------------------------------- exact sampler

def test_cholesky_factor_reproduces_kernel():
    """(d) deterministic: L Lᵀ = K_gd at the pixel centres of an 8×16 map."""
    u = sht.grid_directions(8).reshape(-1, 3)
    for s0 in (1.1, 1.5, 1.9):
        L, eps = gp._kernel_cholesky(s0, u)
        K = generalized_distance_kernel(s0, u, u)
        assert eps == 0.0
        np.testing.assert_allclose(L @ L.T, K, atol=1e-12 * kernel_constant(s0))


def test_exact_values_empirical_covariance_matches_kernel():
    """(d) statistical: covariance over 20000 independent channels vs K_gd, entrywise z < 5."""
    s0, n = 1.3, 20000
    rng = np.random.default_rng(0)
    u = rng.standard_normal((30, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    x = gp.gaussian_process_values(s0, u, seed=1, channels=n)
    K = generalized_distance_kernel(s0, u, u)
    emp = x @ x.T / n                                   # zero-mean process
    sd = np.sqrt((np.outer(np.diag(K), np.diag(K)) + K ** 2) / n)
    assert np.max(np.abs(emp - K) / sd) < 5.0
    assert np.max(np.abs(emp - 0.5 * K) / sd) > 5.0


def test_exact_map_equals_exact_values_on_the_grid():
    H = 6
    f = gp.gaussian_process_map(1.6, H, seed=8, channels=2, method="exact", offset=1.0)
    v = gp.gaussian_process_values(1.6, sht.grid_directions(H).reshape(-1, 3), seed=8,
                                   channels=2, offset=1.0)
    np.testing.assert_array_equal(f, v.reshape(H, 2 * H, 2))
    pix_var = (f - 1.0).reshape(-1, 2).var()       # crude: K(u,u) = 2^{2s−1}/s ≈ 2.75
    assert 0.1 < pix_var < 20


def test_jitter_only_when_needed():
    q, _ = np.linalg.qr(np.random.default_rng(2).standard_normal((3, 3)))
    K = q @ np.diag([2.0, 1.0, -1e-13]) @ q.T            # indefinite at rounding level
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.cholesky(K)
    L, eps = gp._cholesky_with_jitter(K, 2.0)
    assert eps == pytest.approx(2e-12)
    np.testing.assert_allclose(L @ L.T, K + eps * np.eye(3), atol=1e-14)
    L, eps = gp._cholesky_with_jitter(np.diag([1.0, 2.0]), 2.0)
    assert eps == 0.0
    with pytest.raises(SyntheticMapError, match="positive definite"):
        gp._cholesky_with_jitter(np.diag([1.0, -1.0]), 1.0)


def test_exact_duplicate_directions_give_equal_values():
    u = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    x = gp.gaussian_process_values(1.5, u, seed=4, channels=3)
    assert np.all(np.isfinite(x))
    assert np.max(np.abs(x[0] - x[1])) < 1e-4 * np.max(np.abs(x))


def test_exact_size_guard_and_bad_inputs():
    with pytest.raises(SyntheticMapError, match="method='sht'"):
        gp.gaussian_process_map(1.5, 49, seed=0, method="exact")
    with pytest.raises(SyntheticMapError, match="lmax must be None"):
        gp.gaussian_process_map(1.5, 8, seed=0, method="exact", lmax=5)
    with pytest.raises(SyntheticMapError, match="method"):
        gp.gaussian_process_map(1.5, 8, seed=0, method="fft")
    with pytest.raises(SyntheticMapError, match="unit vectors"):
        gp.gaussian_process_values(1.5, [[0.0, 0.0, 2.0]], seed=0)
    with pytest.raises(SyntheticMapError, match="positive integer"):
        gp.gaussian_process_map(1.5, 0, seed=0)
    with pytest.raises(SyntheticMapError, match="channels"):
        gp.gaussian_process_map(1.5, 8, seed=0, channels=0)


# ----------------------------------------------------------------------------- seeds, params

@pytest.mark.parametrize("method", ["sht", "exact"])
def test_seed_reproducible_and_distinct(method):
    """(e)"""
    a = gp.gaussian_process_map(1.5, 8, seed=42, channels=2, method=method)
    b = gp.gaussian_process_map(1.5, 8, seed=42, channels=2, method=method)
    c = gp.gaussian_process_map(1.5, 8, seed=43, channels=2, method=method)
    np.testing.assert_array_equal(a, b)
    assert np.max(np.abs(a - c)) > 1e-3
    assert np.max(np.abs(a[..., 0] - a[..., 1])) > 1e-3


@pytest.mark.parametrize("s0", [1.0, 2.0, 0.5, 2.5, float("nan"), "abc"])
def test_smoothness_outside_range_raises(s0):
    """(f)"""
    for call in (lambda: gp.gaussian_process_map(s0, 8, seed=0),
                 lambda: gp.gaussian_process_map(s0, 4, seed=0, method="exact"),
                 lambda: gp.gaussian_process_values(s0, [[0.0, 0.0, 1.0]], seed=0)):
        with pytest.raises(ValueError, match="smoothness"):
            call()
