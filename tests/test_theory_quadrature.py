"""Quadrature worst-case error: closed form (Eq. 41) vs spectrum (Eq. 42), SH tools, OSW."""
import math

import numpy as np
import pytest
from scipy import integrate
from scipy.special import eval_legendre, sph_harm_y

from envfit.theory._brdf import Diffuse, Glossy
from envfit.theory._errors import TheoryParameterError
from envfit.theory._quadrature import (error_spectrum, initial_error, kernel_mean_embedding,
                                       weighted_energy_sum, worst_case_error,
                                       worst_case_error_squared, embedding_coefficients)
from envfit.theory._sh import (_power_spectrum_legendre_pairs, legendre_p, legendre_series,
                               point_set_power_spectrum, point_set_sh_coefficients,
                               points_to_angles, zonal_sums)
from envfit.theory._sobolev import kernel_constant, kernel_series, sobolev_coefficients
from envfit.theory._weights import equal_weights, kernel_matrix, optimal_weights


pytestmark = pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")

def hemisphere_points(n, seed, brdf=None):
    """Random points on the upper hemisphere (uniform, or importance-sampled for brdf)."""
    rng = np.random.default_rng(seed)
    zp = rng.uniform(size=n)
    z = zp if brdf is None else brdf.morph(zp)
    phi = rng.uniform(0, 2 * np.pi, n)
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def gd_kernel(s, u, v):
    """K_gd (Eq. 14) with |u - v| from coordinate differences: exactly 0 for u = v.

    (envfit.theory._sobolev.generalized_distance_kernel uses 2 - 2 u.v, whose rounding gives
    |u - u|^{2s-2} ~ 1e-8 on the diagonal.)
    """
    d2 = np.sum((u[:, None, :] - v[None, :, :]) ** 2, axis=-1)
    return kernel_constant(s) - d2 ** (s - 1)


def fibonacci_points(n, brdf):
    """Spherical Fibonacci on the hemisphere (errata 'Point sets'), morphed for brdf."""
    j = np.arange(n)
    zp = 1 - (2 * j + 1) / (2 * n)
    phi = 2 * np.pi * np.mod(j / ((1 + 5 ** 0.5) / 2), 1.0)
    z = brdf.morph(zp)
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


# ---------------------------------------------------------------------------- SH tools

def test_legendre_tools():
    t = np.linspace(-1, 1, 37)
    P = legendre_p(30, t)
    for l in (0, 1, 7, 30):
        np.testing.assert_allclose(P[l], eval_legendre(l, t), atol=1e-14)
    c = np.random.default_rng(0).normal(size=41)
    np.testing.assert_allclose(legendre_series(c, t), np.polynomial.legendre.legval(t, c), atol=1e-13)


def test_zonal_sums_eq45():
    u = hemisphere_points(50, 1)
    w = np.random.default_rng(2).uniform(size=50)
    c0 = zonal_sums(u, w, 20)
    for l in (0, 3, 20):
        assert c0[l] == pytest.approx(math.sqrt((2 * l + 1) / (4 * math.pi)) * np.sum(w * eval_legendre(l, u[:, 2])),
                                      abs=1e-14)


def test_ducc_coefficients_match_direct_sum_with_sph_harm_y():
    rng = np.random.default_rng(3)
    u = rng.normal(size=(30, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)       # whole sphere, both hemispheres
    w = rng.uniform(-1, 1, 30)
    c = point_set_sh_coefficients(u, w, 12)
    theta, phi = points_to_angles(u)
    for l in range(13):
        for m in range(l + 1):
            direct = np.sum(w * sph_harm_y(l, m, theta, phi))     # Eq. 54
            assert abs(c[l, m] - direct) < 1e-12
    assert np.all(c[np.triu_indices(13, 1)] == 0)


def test_fast_power_spectrum_equals_legendre_pair_sum():
    u = hemisphere_points(300, 4, Diffuse())
    w = np.random.default_rng(5).uniform(0.5, 1.5, 300) / 300
    c0, S = point_set_power_spectrum(u, w, 80)
    c0_ref, S_ref = _power_spectrum_legendre_pairs(u, w, 80)
    np.testing.assert_allclose(c0, c0_ref, atol=1e-15)
    np.testing.assert_allclose(S, S_ref, rtol=1e-11, atol=1e-16)
    assert S[0] == pytest.approx(w.sum() ** 2 / (4 * math.pi), rel=1e-13)


# ---------------------------------------------------------------------------- embedding

def _embedding_by_2d_quadrature(t, brdf, s):
    r"""(1/(2 pi r_s)) int_H K(u_t, u) p(u) dS by adaptive 2-D quadrature of the definition."""
    C = kernel_constant(s)
    st = math.sqrt(1 - t * t)

    def f(phi, z):
        d2 = max(2 - 2 * (z * t + math.sqrt(1 - z * z) * st * math.cos(phi)), 0.0)
        return (C - d2 ** (s - 1)) * float(brdf.p(z))

    opts_phi = {"points": [0.0], "epsabs": 1e-13, "epsrel": 1e-12, "limit": 200}
    opts_z = {"epsabs": 1e-12, "epsrel": 1e-12, "limit": 200}
    if 0 < t < 1:
        opts_z["points"] = [t]
    val, _ = integrate.nquad(f, [[-math.pi, math.pi], [0.0, 1.0]], opts=[opts_phi, opts_z])
    return val / (2 * math.pi * brdf.r_s)


@pytest.mark.parametrize("brdf,s", [(Diffuse(), 1.5), (Glossy(30.0), 1.5), (Diffuse(), 1.3)])
def test_kernel_mean_embedding_matches_2d_quadrature(brdf, s):
    ts = np.array([0.93, -0.4])
    u = np.stack([np.sqrt(1 - ts ** 2), np.zeros(2), ts], axis=1)
    z = kernel_mean_embedding(u, brdf, s)
    for tj, zj in zip(ts, z):
        assert zj == pytest.approx(_embedding_by_2d_quadrature(tj, brdf, s), abs=2e-10)


def test_embedding_chebyshev_path_equals_series():
    t = np.concatenate([np.linspace(-1, 1, 2001), [0.0, 1e-12, -1e-12, 1 - 1e-13]])
    u = np.stack([np.sqrt(1 - t ** 2), np.zeros_like(t), t], axis=1)
    for brdf in (Diffuse(), Glossy(30.0)):
        a = kernel_mean_embedding(u, brdf, 1.5, method="series")
        b = kernel_mean_embedding(u, brdf, 1.5, method="chebyshev")
        assert np.abs(a - b).max() < 5e-15


def test_initial_error_eq57_matches_double_integral():
    # E_0^2 = (1/(4 pi^2 r_s^2)) iint K p p = int_0^1 int_0^1 p^(z1) p^(z2) kbar(z1, z2)
    from envfit.theory._truncation import azimuthal_mean_kernel
    for brdf in (Diffuse(), Glossy(30.0)):
        r = brdf.r_s

        def inner(z1):
            val, _ = integrate.quad(lambda z2: float(brdf.p(z2)) / r * float(azimuthal_mean_kernel(1.5, z1, z2)),
                                    0, 1, points=[z1], epsabs=1e-13, epsrel=1e-12, limit=200)
            return val

        ref, _ = integrate.quad(lambda z1: float(brdf.p(z1)) / r * inner(z1), 0, 1,
                                epsabs=1e-12, epsrel=1e-11, limit=100)
        assert initial_error(brdf, 1.5) == pytest.approx(ref, rel=1e-10)
        # and it is the squared error of the empty rule
        assert worst_case_error_squared(np.zeros((0, 3)), np.zeros(0), brdf, 1.5) == \
            pytest.approx(ref, rel=1e-10)


def test_worst_case_error_embedding_choices_agree():
    """Eq. 41 with z_j by the Legendre series, its Chebyshev interpolant and "auto": E² to
    1e-14 absolute (the rounding level of E²), for a short (glossy n = 100) and a long
    (diffuse, glossy n = 30 at s = 1.1) embedding series; "auto" picks Chebyshev for the
    long ones and is then as fast as it."""
    import time
    rng = np.random.default_rng(5)
    for brdf in (Diffuse(), Glossy(30.0), Glossy(100.0)):
        for n in (3, 40, 257):
            u = hemisphere_points(n, n, brdf)
            for w in (np.full(n, 1.0 / n), rng.uniform(0.0, 2.0 / n, n)):
                for s in (1.1, 1.5, 1.9):
                    e2 = {m: worst_case_error(u, w, brdf, s, embedding=m) ** 2
                          for m in ("series", "chebyshev", "auto")}
                    assert abs(e2["series"] - e2["chebyshev"]) <= 1e-14
                    assert abs(e2["auto"] - e2["series"]) <= 1e-14
                    assert worst_case_error_squared(u, w, brdf, s, embedding="chebyshev") == \
                        pytest.approx(e2["chebyshev"], abs=1e-15)
    u = hemisphere_points(64, 1, Diffuse())
    w = np.full(64, 1 / 64)
    worst_case_error(u, w, Diffuse(), 1.5)                      # warm the caches
    t0 = time.perf_counter()
    worst_case_error(u, w, Diffuse(), 1.5)
    t1 = time.perf_counter()
    worst_case_error(u, w, Diffuse(), 1.5, embedding="series")
    t2 = time.perf_counter()
    assert t1 - t0 < 0.5 * (t2 - t1)                            # auto = Chebyshev here
    with pytest.raises(TheoryParameterError):
        worst_case_error(u, w, Diffuse(), 1.5, embedding="clenshaw")


# ---------------------------------------------------------------------------- Eq. 41 vs 42

def test_pair_sum_tiling_matches_dense_kernel_matrix():
    u = hemisphere_points(333, 6)
    w = np.random.default_rng(7).uniform(size=333)
    for s in (1.5, 1.25, 1.8):
        d = np.sqrt(np.maximum(np.sum((u[:, None] - u[None]) ** 2, axis=-1), 0))
        ref = w @ d ** (2 * s - 2) @ w
        for tile in (64, 100, 1000):
            assert weighted_energy_sum(u, w, s, tile=tile) == pytest.approx(ref, rel=1e-13)
    assert weighted_energy_sum(u, w, 1.5, workers=2) == pytest.approx(
        weighted_energy_sum(u, w, 1.5), rel=1e-14)


@pytest.mark.parametrize("brdf", [Diffuse(), Glossy(30.0)])
def test_closed_form_eq41_equals_spectral_eq42_plus_explicit_tail(brdf):
    s, lmax, N = 1.5, 300, 64
    u = hemisphere_points(N, 8, brdf)
    w = np.random.default_rng(9).uniform(0.5, 1.5, N) / N
    sp = error_spectrum(u, w, brdf, s, lmax)
    # independent closed form with the library kernel and the embedding
    K = gd_kernel(s, u, u)
    z = kernel_mean_embedding(u, brdf, s)
    e2_closed = w @ K @ w - 2 * w @ z + initial_error(brdf, s)
    assert sp.wce ** 2 == pytest.approx(e2_closed, rel=1e-10)
    # band-limited identity: Eq. 42 to lmax == Eq. 41 with the kernel truncated at lmax
    t = np.clip(u @ u.T, -1, 1)
    KL = kernel_series(s, t, lmax)
    a = sobolev_coefficients(s, lmax)
    b = brdf.sh_coefficients(lmax)
    g = a * b * np.sqrt((2 * np.arange(lmax + 1) + 1) / (4 * np.pi))
    zL = legendre_series(g, u[:, 2])
    e2_band = w @ KL @ w - 2 * w @ zL + np.sum(a * b * b)
    assert sp.partial == pytest.approx(e2_band, rel=1e-11)
    # explicit tail of Eq. 42 (degrees > lmax), computed from the kernel and embedding tails
    aa = sobolev_coefficients(s, 4096)       # a_l b_l^2 ~ l^-7 (diffuse): rest < 1e-22
    bb = brdf.sh_coefficients(4096)
    tail = w @ (K - KL) @ w - 2 * w @ (z - zL) + math.fsum(aa[lmax + 1:] * bb[lmax + 1:] ** 2)
    assert sp.partial + tail == pytest.approx(sp.wce ** 2, rel=1e-8)
    assert sp.tail == pytest.approx(tail, rel=1e-6)
    # decomposition bookkeeping (Eqs. 42, 46, 47)
    assert sp.wce_zonal ** 2 + sp.wce_anisotropic ** 2 == pytest.approx(sp.partial, rel=1e-12)
    np.testing.assert_allclose(sp.e2, sp.a * (sp.d2 + sp.C2))
    np.testing.assert_allclose(sp.S, sp.c0 ** 2 + sp.C2)
    assert sp.C2[0] == 0.0 and np.all(sp.C2 >= 0)


def test_high_degree_anisotropic_power_tends_to_diagonal_term():
    # errata: C_l^2 -> (2l+1)/(4 pi) sum w_j^2, so the tail is ~ sum w^2 (C - K_lmax(1))
    brdf = Diffuse()
    u = fibonacci_points(400, brdf)
    w = equal_weights(400)
    sp = error_spectrum(u, w, brdf, 1.5, 800)
    assert sp.tail == pytest.approx(sp.tail_diagonal, rel=2e-3)
    hi = slice(600, 801)
    ratio = sp.C2[hi] / ((2 * sp.l[hi] + 1) / (4 * np.pi) * np.sum(w * w))
    assert abs(np.mean(ratio) - 1) < 0.05
    # the zonal part is much smaller than the anisotropic one (Sec. 7.2, Fig. 1)
    assert sp.wce_zonal < 0.2 * sp.wce_anisotropic


def test_worst_case_error_bounds_an_actual_quadrature_error():
    # f = K(., v) has ||f||_Hs = sqrt(K(v, v)) = sqrt(C); |I_f - Q_f| <= E ||f||  (Eq. 37)
    brdf, s = Glossy(30.0), 1.5
    u = fibonacci_points(200, brdf)
    w = equal_weights(200)
    E = worst_case_error(u, w, brdf, s)
    C = kernel_constant(s)
    rng = np.random.default_rng(10)
    for v in rng.normal(size=(5, 3)):
        v /= np.linalg.norm(v)
        I = kernel_mean_embedding(v[None], brdf, s)[0]        # I_f of f = K(., v)
        Q = w @ gd_kernel(s, u, v[None])[:, 0]
        assert abs(I - Q) <= E * math.sqrt(C)
    # the representer h (Eq. 40) attains the bound: I_h - Q_h = ||h||^2 = E^2
    # h = z - sum_j w_j K(., u_j); I_h = E0^2 - w.z ; Q_h = w.z - w.K.w
    K = gd_kernel(s, u, u)
    z = kernel_mean_embedding(u, brdf, s)
    I_h = initial_error(brdf, s) - w @ z
    Q_h = w @ z - w @ K @ w
    assert I_h - Q_h == pytest.approx(E ** 2, rel=1e-9)


def test_worst_case_error_decreases_with_n_for_fibonacci():
    brdf = Diffuse()
    E = [worst_case_error(fibonacci_points(n, brdf), equal_weights(n), brdf, 1.5)
         for n in (64, 256, 1024)]
    assert E[0] > E[1] > E[2]
    # about N^{-3/4} for s = 1.5 (Sec. 7.2)
    rate = -math.log(E[2] / E[0]) / math.log(16)
    assert 0.6 < rate < 0.9


# ---------------------------------------------------------------------------- OSW

@pytest.mark.parametrize("brdf", [Diffuse(), Glossy(30.0)])
def test_optimal_weights_are_optimal(brdf):
    s, N = 1.5, 300
    u = hemisphere_points(N, 11, brdf)
    w_eq = equal_weights(N)
    w = optimal_weights(u, brdf, s)
    e_eq = worst_case_error(u, w_eq, brdf, s)
    e_osw = worst_case_error(u, w, brdf, s)
    assert e_osw < e_eq
    # gradient of E^2 = w K w - 2 w z + E0^2 vanishes: K w = z (K built independently)
    K = gd_kernel(s, u, u)
    z = kernel_mean_embedding(u, brdf, s)
    assert np.linalg.norm(K @ w - z) <= 1e-9 * np.linalg.norm(z)
    # E^2(w*) = E0^2 - z.w*
    assert e_osw ** 2 == pytest.approx(initial_error(brdf, s) - z @ w, rel=1e-8, abs=1e-14)
    # any perturbation increases the error by exactly eps^2 v K v
    v = np.random.default_rng(12).normal(size=N) / N
    for eps in (1e-2, 1e-1):
        e2 = worst_case_error_squared(u, w + eps * v, brdf, s)
        assert e2 - e_osw ** 2 == pytest.approx(eps ** 2 * v @ K @ v, rel=1e-6)
    np.testing.assert_allclose(kernel_matrix(u, s), K, atol=1e-14)


def test_optimal_weights_reject_duplicate_points():
    u = hemisphere_points(20, 13)
    with pytest.raises(TheoryParameterError):
        optimal_weights(np.vstack([u, u[:1]]), Diffuse(), 1.5)


def test_input_validation():
    with pytest.raises(TheoryParameterError):
        worst_case_error(np.ones((4, 2)), np.ones(4), Diffuse(), 1.5)
    with pytest.raises(TheoryParameterError):
        worst_case_error(np.ones((4, 3)), np.ones(4), Diffuse(), 1.5)        # not unit vectors
    with pytest.raises(TheoryParameterError):
        worst_case_error(hemisphere_points(4, 0), np.ones(3), Diffuse(), 1.5)
    with pytest.raises(TheoryParameterError):
        worst_case_error(hemisphere_points(4, 0), np.ones(4), Diffuse(), 2.5)
    with pytest.raises(TheoryParameterError):
        error_spectrum(hemisphere_points(4, 0), np.ones(4), "diffuse", 1.5, 10)
    assert embedding_coefficients(Glossy(30.0), 1.5)[0] == pytest.approx(kernel_constant(1.5) / 2)


@pytest.mark.parametrize("s", [1.5, 1.9])
def test_kernel_matrix_condition_grows_like_n_to_the_s(s):
    """docs/ERRATA.md (Table 2): cond(K) of the OSW system grows like N^s, so at N = 20000 and
    s = 1.9 it is far beyond what a float32 factorisation resolves (1/eps32 ≈ 8.4e6)."""
    from envfit.theory._pointsets import generate
    ns = np.array([128, 256, 512])
    cond = []
    for n in ns:
        ev = np.linalg.eigvalsh(kernel_matrix(generate("sf", int(n)), s))
        assert ev[0] > 0
        cond.append(ev[-1] / ev[0])
    k, b = np.polyfit(np.log(ns), np.log(cond), 1)
    assert k == pytest.approx(s, abs=0.15)
    if s == 1.9:
        assert math.exp(b + k * math.log(20000)) > 10 / np.finfo(np.float32).eps
    assert 8 * 20000 ** 2 == 3.2e9            # the float64 matrix of 20000 samples: 3.2 GB
