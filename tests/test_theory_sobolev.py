"""envfit.theory._sobolev: a_l (Eqs. 15-16) against the definition Eq. 9 by quadrature, and Eq. 8."""
import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import eval_legendre

from envfit.theory._errors import TheoryParameterError
from envfit.theory._sobolev import (generalized_distance_kernel, kernel_constant,
                                    kernel_from_distance2, kernel_series, sobolev_coefficients)


@pytest.mark.parametrize("s", [1.1, 1.3, 1.5, 1.75, 1.9])
def test_coefficients_equal_projection_of_kernel(s):
    # Eq. 9: a_l = ∫_S2 K(u, v) P_l(u.v) dS(u) = 2π ∫_{-1}^{1} K(t) P_l(t) dt
    a = sobolev_coefficients(s, 8)
    for l in range(9):
        val = 2 * np.pi * quad(lambda t: kernel_from_distance2(s, 2 - 2 * t) * eval_legendre(l, t),
                               -1, 1, points=[1.0], limit=400, epsabs=1e-13)[0]
        assert val == pytest.approx(a[l], rel=1e-7, abs=1e-10)


def test_closed_form_at_s_three_halves():
    # ERRATA: a_0 = 16π/3, a_l = 2π/((l-1/2)(l+1/2)(l+3/2))
    a = sobolev_coefficients(1.5, 200)
    l = np.arange(1, 201.0)
    assert a[0] == pytest.approx(16 * np.pi / 3, rel=1e-15)
    np.testing.assert_allclose(a[1:], 2 * np.pi / ((l - 0.5) * (l + 0.5) * (l + 1.5)), rtol=1e-13)


@pytest.mark.parametrize("s", [1.1, 1.5, 1.9])
def test_recurrence_and_decay(s):
    # a_{l+1}/a_l = (l+1-s)/(l+1+s) for l >= 1, and a_l ~ l^{-2s}; stable far beyond Γ's overflow
    a = sobolev_coefficients(s, 100_000)
    assert np.all(np.isfinite(a)) and np.all(a > 0)
    l = np.arange(1, 100_000)
    np.testing.assert_allclose(a[2:] / a[1:-1], (l + 1 - s) / (l + 1 + s), rtol=1e-10)
    slope = np.log(a[100_000] / a[50_000]) / np.log(2.0)
    assert slope == pytest.approx(-2 * s, abs=1e-3)


@pytest.mark.parametrize("s", [1.2, 1.5, 1.8])
def test_series_reproduces_closed_form(s):
    # Eq. 8 partial sums converge to Eq. 14 away from t = 1; with |P_l(t)| = O(l^{-1/2}) there,
    # the tail is O(lmax^{3/2 - 2s}): quadrupling lmax must shrink the error by ~4^{2s-3/2}.
    t = np.linspace(-1, 0.8, 37)
    exact = kernel_from_distance2(s, 2 - 2 * t)
    err = [np.max(np.abs(kernel_series(s, t, lmax) - exact)) for lmax in (1000, 4000)]
    assert err[1] < 1e-4
    assert err[0] / err[1] > 0.5 * 4 ** (2 * s - 1.5)


def test_kernel_matrix_and_constant():
    rng = np.random.default_rng(1)
    u = rng.normal(size=(5, 3)); u /= np.linalg.norm(u, axis=1, keepdims=True)
    K = generalized_distance_kernel(1.5, u, u)
    direct = np.array([[8 / 3 - np.linalg.norm(a - b) for b in u] for a in u])
    np.testing.assert_allclose(K, direct, atol=1e-12)
    assert kernel_constant(1.5) == pytest.approx(8 / 3)
    assert generalized_distance_kernel(1.5, u[0], u[1]) == pytest.approx(direct[0, 1])


@pytest.mark.parametrize("bad", [1.0, 2.0, 0.5, 2.5, float("nan"), "x"])
def test_rejects_s_outside_range(bad):
    with pytest.raises(TheoryParameterError, match="1 < s < 2"if not isinstance(bad, str) else "number"):
        sobolev_coefficients(bad, 3)


def test_kernel_diagonal_is_exact():
    # K(u, u) = 2^{2s-1}/s exactly: no rounding residue from 2 - 2 u.u
    rng = np.random.default_rng(7)
    u = rng.normal(size=(200, 3)); u /= np.linalg.norm(u, axis=1, keepdims=True)
    for s in (1.1, 1.5, 1.9):
        K = generalized_distance_kernel(s, u, u)
        assert np.all(np.diag(K) == kernel_constant(s))


@pytest.mark.parametrize("s", [1.1, 1.5, 1.9])
def test_a1_closed_form_and_no_gamma_overflow(s):
    """docs/ERRATA.md (Sobolev kernel): a_1 = 4π 2^(2s-2) (s-1)/(s(s+1)), and the a_l stay finite
    far beyond where Γ(l + 1 + s) overflows (l ≈ 170)."""
    a = sobolev_coefficients(s, 2000)
    assert a[1] == pytest.approx(4 * np.pi * 2 ** (2 * s - 2) * (s - 1) / (s * (s + 1)), rel=1e-13)
    assert np.all(np.isfinite(a)) and np.all(a[1:] > 0) and a[2000] < a[171] < a[170]
