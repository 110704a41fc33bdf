"""Weight functions: every coefficient family against quadrature of its definition (Sec. 4)."""
import math

import numpy as np
import pytest
from scipy import integrate
from scipy.special import eval_legendre

from envfit.theory._brdf import (Diffuse, Glossy, Phong, WeightFunction, ZonalWeight,
                                 gauss_legendre_01, hsh_to_sh_matrix)
from envfit.theory._errors import TheoryParameterError


pytestmark = pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")

def quad_sh(p, r_s, l):
    """b_l = (1/r_s) sqrt((2l+1)/4pi) int_0^1 p P_l dz  (Eq. 20) by adaptive quadrature."""
    val, _ = integrate.quad(lambda z: p(z) * eval_legendre(l, z), 0.0, 1.0,
                            limit=400, epsabs=1e-15, epsrel=1e-13)
    return math.sqrt((2 * l + 1) / (4 * math.pi)) * val / r_s


def quad_hsh(p, r_s, l):
    """b~_l = (1/r_s) sqrt((2l+1)/2pi) int_0^1 p P_l(2z-1) dz  (Eq. 28, errata)."""
    val, _ = integrate.quad(lambda z: p(z) * eval_legendre(l, 2 * z - 1), 0.0, 1.0,
                            limit=400, epsabs=1e-15, epsrel=1e-13)
    return math.sqrt((2 * l + 1) / (2 * math.pi)) * val / r_s


def test_gauss_legendre_01_exact_for_polynomials():
    z, w = gauss_legendre_01(300)
    for k in (0, 1, 7, 200, 599):
        assert abs(w @ z ** k - 1.0 / (k + 1)) < 1e-15 * 50


def test_diffuse_sh_closed_form_matches_definition_and_errata_values():
    d = Diffuse()
    b = d.sh_coefficients(14)
    ref = [quad_sh(lambda z: z, 0.5, l) for l in range(15)]
    np.testing.assert_allclose(b, ref, rtol=0, atol=2e-14)
    np.testing.assert_allclose(b[:7], [0.282095, 0.325735, 0.157696, 0.0, -0.035262, 0.0, 0.015892],
                               atol=5e-7)
    assert b[3] == 0.0 and b[5] == 0.0
    # Ramamoorthi-Hanrahan: b_l = (A_l/pi) sqrt((2l+1)/4pi), A_0 = pi, A_1 = 2pi/3, A_2 = pi/4
    for l, A in ((0, math.pi), (1, 2 * math.pi / 3), (2, math.pi / 4)):
        assert b[l] == pytest.approx(A / math.pi * math.sqrt((2 * l + 1) / (4 * math.pi)), rel=1e-14)
    # the closed form equals the generic quadrature path (stable at high degree)
    generic = WeightFunction.sh_coefficients(d, 400)
    np.testing.assert_allclose(d.sh_coefficients(400), generic, rtol=0, atol=1e-14)


def test_diffuse_hsh_and_morph():
    d = Diffuse()
    bt = d.hsh_coefficients(6)
    ref = [quad_hsh(lambda z: z, 0.5, l) for l in range(7)]
    np.testing.assert_allclose(bt, ref, atol=1e-15)
    assert bt[0] == pytest.approx(1 / math.sqrt(2 * math.pi), rel=1e-15)
    assert bt[1] == pytest.approx(1 / math.sqrt(6 * math.pi), rel=1e-15)
    zp = np.linspace(0, 1, 101)
    np.testing.assert_allclose(d.morph(zp), np.sqrt(zp))
    # generic inverse-CDF path gives the same map
    np.testing.assert_allclose(WeightFunction.morph(d, zp), np.sqrt(zp), atol=1e-13)


@pytest.mark.parametrize("n", [1.0, 30.0, 300.0])
def test_glossy_sh_exact_matches_eq26_quadrature(n):
    g = Glossy(n)
    assert g.r_s == pytest.approx(-math.expm1(-n) / n, rel=1e-15)
    b = g.sh_coefficients(40)
    p = lambda z: math.exp(n * (z - 1))
    ref = [quad_sh(p, g.r_s, l) for l in range(0, 41, 4)]
    np.testing.assert_allclose(b[::4], ref, rtol=1e-11, atol=1e-14)
    assert b[0] == pytest.approx(0.5 / math.sqrt(math.pi), rel=1e-14)


def test_glossy_bessel_eq27_is_close_for_large_n():
    # the error of Eq. 27 is the lower-hemisphere part of the integral,
    # |diff_l| <= sqrt((2l+1)/4pi) e^{-n}   (|P_l| <= 1 on [-1, 0])
    for n in (5.0, 30.0, 100.0, 1000.0):
        g = Glossy(n)
        l = np.arange(61)
        diff = np.abs(g.sh_coefficients(60) - g.sh_coefficients_bessel(60))
        exact = g.sh_coefficients(60)
        bound = np.sqrt((2 * l + 1) / (4 * np.pi)) * math.exp(-n) + 1e-13 * np.abs(exact).max()
        assert np.all(diff <= bound)
    # for small n the approximation is visibly wrong, so the test above is not vacuous
    g = Glossy(2.0)
    assert abs(g.sh_coefficients(3)[1] - g.sh_coefficients_bessel(3)[1]) > 1e-3
    # overflow-free at large n (I_nu(n) alone would overflow)
    assert np.all(np.isfinite(Glossy(5000.0).sh_coefficients_bessel(100)))


@pytest.mark.parametrize("n", [3.0, 30.0, 500.0])
def test_glossy_hsh_eq30_equals_eq28_and_eq29(n):
    g = Glossy(n)
    bt = g.hsh_coefficients(30)                           # Eq. 30 (Bessel, exact)
    p = lambda z: math.exp(n * (z - 1))
    ref28 = [quad_hsh(p, g.r_s, l) for l in range(0, 31, 3)]
    np.testing.assert_allclose(bt[::3], ref28, rtol=1e-11, atol=5e-15)   # quad: ~2e-15 abs
    # Eq. 29: (1/(2 r_s)) sqrt((2l+1)/2pi) int_{-1}^{1} e^{(n/2)(z'-1)} P_l(z') dz'
    for l in (0, 5, 17):
        val, _ = integrate.quad(lambda x: math.exp(0.5 * n * (x - 1)) * eval_legendre(l, x), -1, 1,
                                epsabs=1e-15, epsrel=1e-13, limit=200)
        assert bt[l] == pytest.approx(math.sqrt((2 * l + 1) / (2 * math.pi)) * val / (2 * g.r_s),
                                      rel=1e-11, abs=5e-15)
    # and the generic Gauss-Legendre path (Eq. 28) agrees to rounding
    np.testing.assert_allclose(bt, WeightFunction.hsh_coefficients(g, 30), rtol=1e-12, atol=5e-14)
    assert bt[0] == pytest.approx(1 / math.sqrt(2 * math.pi), rel=1e-14)


def test_glossy_morph_eq67_stable_form():
    for n in (0.5, 30.0, 2000.0):
        g = Glossy(n)
        zp = np.linspace(0.0, 1.0, 1001)
        z = g.morph(zp)
        assert np.all(np.isfinite(z)) and z[0] == pytest.approx(0.0, abs=1e-12) and z[-1] == 1.0
        # z is the inverse of the CDF of p on [0, 1]
        np.testing.assert_allclose(g.cdf(z), zp, atol=1e-12)
        if n < 500:   # Eq. 67 as printed agrees where it does not overflow
            np.testing.assert_allclose(z, np.log1p(zp * np.expm1(n)) / n, atol=1e-13)
        # generic inverse-CDF path
        np.testing.assert_allclose(WeightFunction.morph(g, zp), z, atol=1e-12)


def test_phong_through_generic_path():
    for n in (1.0, 10.0, 64.0):
        ph = Phong(n)
        assert ph.r_s == pytest.approx(1 / (n + 1), rel=1e-14)
        b = ph.sh_coefficients(30)
        ref = [quad_sh(lambda z: z ** n, 1 / (n + 1), l) for l in range(0, 31, 5)]
        np.testing.assert_allclose(b[::5], ref, rtol=1e-11, atol=1e-14)
        bt = ph.hsh_coefficients(10)
        np.testing.assert_allclose(bt, [quad_hsh(lambda z: z ** n, 1 / (n + 1), l) for l in range(11)],
                                   rtol=1e-11, atol=1e-14)
        zp = np.linspace(0, 1, 257)
        np.testing.assert_allclose(ph.morph(zp), zp ** (1 / (n + 1)), atol=1e-12)
    # p = z (Phong n = 1) is the diffuse lobe
    np.testing.assert_allclose(Phong(1).sh_coefficients(50), Diffuse().sh_coefficients(50),
                               atol=3e-15)


def test_user_zonal_weight():
    wf = ZonalWeight(lambda z: 1.0 + z * z, name="1+z^2")
    assert wf.r_s == pytest.approx(4 / 3, rel=1e-15)
    b = wf.sh_coefficients(12)
    np.testing.assert_allclose(b, [quad_sh(lambda z: 1 + z * z, 4 / 3, l) for l in range(13)],
                               atol=1e-14)
    assert wf.p(-0.5) == 0.0                    # zero on the lower hemisphere
    # HSH series of a quadratic stops at degree 2
    assert np.all(np.abs(wf.hsh_coefficients(8)[3:]) < 1e-15)


def test_hsh_to_sh_matrix_matches_definition():
    M = hsh_to_sh_matrix(12, 6)
    for l, lp in ((0, 0), (1, 0), (3, 2), (12, 6), (7, 1)):
        # Eq. 32: int_{S^2} Y~_{l',0} Y_{l,0} dS = 2pi int_0^1 (...) dz
        val, _ = integrate.quad(lambda z: math.sqrt((2 * lp + 1) / (2 * math.pi)) * eval_legendre(lp, 2 * z - 1)
                                * math.sqrt((2 * l + 1) / (4 * math.pi)) * eval_legendre(l, z), 0, 1,
                                epsabs=1e-15, epsrel=1e-13)
        assert M[l, lp] == pytest.approx(2 * math.pi * val, abs=1e-14)
    # converting the complete HSH series of the diffuse lobe gives its SH coefficients
    d = Diffuse()
    np.testing.assert_allclose(d.truncated_hsh_as_sh(1, 40), d.sh_coefficients(40), atol=3e-15)
    g = Glossy(30.0)
    np.testing.assert_allclose(g.truncated_hsh_as_sh(60, 80), g.sh_coefficients(80), atol=1e-13)


def test_normalisation_for_every_family():
    for wf in (Diffuse(), Glossy(7.0), Phong(3), ZonalWeight(lambda z: np.exp(z))):
        assert wf.sh_coefficients(0)[0] == pytest.approx(1 / (2 * math.sqrt(math.pi)), rel=1e-13)
        assert wf.hsh_coefficients(0)[0] == pytest.approx(1 / math.sqrt(2 * math.pi), rel=1e-13)


def test_bad_parameters():
    with pytest.raises(TheoryParameterError):
        Glossy(-1.0)
    with pytest.raises(TheoryParameterError):
        Phong(-2)
    with pytest.raises(TheoryParameterError):
        Diffuse().sh_coefficients(-1)
    with pytest.raises(TheoryParameterError):
        Glossy(3.0).morph([1.5])
    with pytest.raises(TheoryParameterError):
        ZonalWeight(lambda z: -np.ones_like(z)).r_s


# --- sharp glossy lobes (issue 22, item 2): closed forms, no underflow, no warnings ----------

def _glossy_sh_by_quadrature(n: float, ls, t_max: float = 60.0, panels: int = 120,
                             k: int = 24) -> np.ndarray:
    r"""b_l of e^{n(z-1)} by composite Gauss–Legendre in t = n(1 - z), an algorithm independent
    of the Bessel form: :math:`b_l = \frac{1}{n r_s}\sqrt{\frac{2l+1}{4\pi}}\int_0^{n}
    e^{-t}P_l(1 - t/n)dt` (cut at t = 60: e^{-60} < 1e-26). P_l near z = 1 by the recurrence
    of the differences d_l = P_l − P_{l−1} in u = t/n, d_{l+1} = (−(2l+1)u P_l + l d_l)/(l+1),
    so that 1 − u is never formed (it would lose u's digits: 1e-11 at n = 1e6)."""
    x, w = np.polynomial.legendre.leggauss(k)
    e = np.linspace(0.0, min(t_max, n), panels + 1)
    half = 0.5 * (e[1:] - e[:-1])[:, None]
    t = (0.5 * (e[1:] + e[:-1])[:, None] + half * x).ravel()
    wt = (half * w).ravel() * np.exp(-t)
    u = t / n
    p, d = np.ones_like(u), np.zeros_like(u)
    top = max(ls)
    out = {}
    for l in range(top + 1):
        if l in ls:
            out[l] = math.fsum(wt * p)
        d = (-(2 * l + 1) * u * p + l * d) / (l + 1)
        p = p + d
    r_s = -math.expm1(-n) / n
    return np.array([math.sqrt((2 * l + 1) / (4 * math.pi)) * out[l] / (n * r_s) for l in ls])


@pytest.mark.parametrize("n", [2e3, 1e5, 1e6])
def test_sharp_glossy_sh_coefficients_against_quadrature(n):
    ls = sorted({0, 1, 7, 60, int(math.sqrt(n)), int(3 * math.sqrt(n))})
    b = Glossy(n).sh_coefficients(max(ls))[ls]
    ref = _glossy_sh_by_quadrature(n, ls)
    np.testing.assert_allclose(b, ref, rtol=0, atol=2e-12)
    assert b[-1] > 1e-3                      # 3√n: the lobe still passes it (no underflow)


def test_glossy_closed_form_meets_generic_path():
    """At the switch n = GLOSSY_CLOSED_FORM_N the generic quadrature (below) and the Bessel
    form (above) agree, coefficients and resolution degree."""
    from envfit.theory._brdf import GLOSSY_CLOSED_FORM_N
    n = GLOSSY_CLOSED_FORM_N
    g = Glossy(n)
    np.testing.assert_allclose(g.sh_coefficients(400), g.sh_coefficients_bessel(400),
                               rtol=0, atol=1e-12)
    assert abs(Glossy(n * 1.0001).resolution_degree() - g.resolution_degree()) <= 16


@pytest.mark.parametrize("n", [1.0, 1e4, 1e6, 1e8])
def test_glossy_lobe_no_runtime_warning(n):
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        g = Glossy(n)
        D = g.resolution_degree()
        b = g.sh_coefficients(2 * D)
        h = g.hsh_coefficients(D)
        z = g.morph(np.linspace(0.0, 1.0, 9))
    assert b[0] == pytest.approx(1 / (2 * math.sqrt(math.pi)), rel=1e-13)
    assert h[0] == pytest.approx(1 / math.sqrt(2 * math.pi), rel=1e-13)
    assert np.all(np.isfinite(b)) and np.all(np.isfinite(z))
    if n >= 1e4:                             # D ≈ 6√n (the lobe's bandwidth), not 0 or the cap
        assert 4 * math.sqrt(n) < D < 8 * math.sqrt(n)
        lam = np.sqrt(4 * np.pi / (2 * np.arange(2 * D + 1) + 1)) * b
        assert abs(lam[2 * D]) < 1e-12 < abs(lam[D // 2])


def test_glossy_shininess_range():
    from envfit.theory._brdf import GLOSSY_MAX_SHININESS
    Glossy(GLOSSY_MAX_SHININESS)
    with pytest.raises(TheoryParameterError, match="must be <= 1e\\+09"):
        Glossy(2 * GLOSSY_MAX_SHININESS)


@pytest.mark.parametrize("n", [0.05, 1.0, 16.0])
def test_glossy_with_a_horizon_jump_fast_and_exact(n):
    """n ≤ GLOSSY_SPLIT_N (half-range Legendre products): against the t-substitution
    quadrature to 1e-14, and to the embedding's 65536 degrees in well under the generic
    quadrature's 140 s (O(lmax²)) at n = 1."""
    import time
    from envfit.theory._brdf import GLOSSY_SPLIT_N
    assert n <= GLOSSY_SPLIT_N
    ls = [0, 1, 2, 3, 10, 50, 200, 1000]
    g = Glossy(n)
    np.testing.assert_allclose(g.sh_coefficients(1000)[ls], _glossy_sh_by_quadrature(n, ls, panels=400, k=40),
                               rtol=0, atol=2e-14)
    t0 = time.perf_counter()
    b = Glossy(n * (1 - 1e-9)).sh_coefficients(65536)      # a fresh lobe (no cache)
    assert time.perf_counter() - t0 < 10.0 and np.all(np.isfinite(b))
