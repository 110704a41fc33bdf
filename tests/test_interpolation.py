"""Tests of envfit.sobolev._interpolation (kernel interpolation with K_gd, Eq. 14) and its numba kernels.

Every expected value comes from an independent computation: numpy's libm power, dense
numpy/scipy linear algebra on a kernel matrix built by ``envfit.theory._sobolev``, scipy's
RBFInterpolator, explicit leave-one-out refits, scipy.stats.multivariate_normal.
"""
from __future__ import annotations

import tracemalloc
import warnings

import numpy as np
import pytest
import scipy.linalg
import scipy.stats
from numpy.polynomial import legendre
from scipy.interpolate import RBFInterpolator

from envfit.sobolev import _interpolation_kernels as _kernels
from envfit.base._errors import DuplicatePointsError, MemoryBudgetError, ParameterError
from envfit.base._resources import interpolator_nbytes, largest_feasible_n
from envfit.base._checks import as_unit_vectors
from envfit.sobolev._interpolation import SobolevInterpolator
from envfit.sobolev._nearfar import far_field_expansion
from envfit.base._resources import MEMORY_FRACTION, available_memory_bytes
from envfit.theory._sobolev import kernel_constant, kernel_from_distance2


def unit(n, seed):
    p = np.random.default_rng(seed).normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def field(p):
    """A test function with a kink (not in any finite SH band) and three channels."""
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    return np.stack([0.5 + 0.3 * z + 0.2 * np.sin(3 * x) * np.cos(2 * y),
                     np.abs(x - 0.2) + 0.1 * y, np.exp(-((p @ [0.6, 0.0, 0.8]) - 1) ** 2 / 0.01)],
                    axis=-1)


def dense_kernel(s, p):
    """K_ij from envfit.theory._sobolev with |p_i - p_j|^2 from coordinate differences (the Gram form
    2 - 2 p.p loses the diagonal: (2e-16)^(s-1) is 0.027 at s = 1.1)."""
    return kernel_from_distance2(s, ((p[:, None, :] - p[None, :, :]) ** 2).sum(-1))


def naive_power_sums(q, p, alpha, s):
    """sum_j alpha_j |q - p_j|^(2s-2) with numpy's pow and coordinate differences."""
    d2 = ((q[:, None, :] - p[None, :, :]) ** 2).sum(-1)
    g = d2 ** (s - 1.0)
    return g @ alpha, g @ np.abs(alpha)


def naive_interpolant(q, p, alpha, s):
    """(f(q), B(q)) with B = sum_j |alpha_j K(q, p_j)| the scale of the rounding errors."""
    gs, gabs = naive_power_sums(q, p, alpha, s)
    c = kernel_constant(s)
    return c * alpha.sum(0) - gs, c * np.abs(alpha).sum(0) + gabs


# ----------------------------------------------------------------------------- the power

@pytest.mark.parametrize("a", [0.1, 0.37, 0.5, 0.9])
def test_fast_pow_matches_libm(a):
    rng = np.random.default_rng(0)
    x = np.concatenate([rng.uniform(0, 4, 20000), 10 ** rng.uniform(-10, np.log10(4), 20000)])
    tiny = 10 ** rng.uniform(-300, -10, 20000)
    ref = x ** a
    for kind in {_kernels.KIND_GENERIC, _kernels.power_kind(a)}:
        out = np.empty_like(x)
        _kernels.pow_array(x, a, kind, out)
        assert np.max(np.abs(out - ref) / ref) < 5e-15
        out_t = np.empty_like(tiny)
        _kernels.pow_array(tiny, a, kind, out_t)
        assert np.max(np.abs(out_t - tiny ** a) / tiny ** a) < 2e-13
    edge = np.array([0.0, 2.0 ** -1010, 4.0])
    out = np.empty(3)
    _kernels.pow_array(edge, a, _kernels.KIND_GENERIC, out)
    assert out[0] == 0.0 and out[1] == 0.0 and out[2] == pytest.approx(4.0 ** a, rel=1e-15)


# ----------------------------------------------------------------------------- basics

@pytest.mark.parametrize("s", [1.1, 1.5, 1.9])
def test_reproduces_data_at_nodes(s):
    p = unit(300, 1)
    f = field(p)
    it = SobolevInterpolator(p, f, s)
    assert it.coefficients.shape == (300, 3)
    for method in ("direct", "nearfar"):
        assert np.max(np.abs(it.evaluate(p, method=method) - f)) < 1e-8 * np.abs(f).max()
    # the coefficients solve K alpha = f with K from envfit.theory._sobolev (an independent build)
    K = dense_kernel(s, p)
    assert np.max(np.abs(K @ it.coefficients - f)) < 1e-9 * np.abs(f).max()


def test_cholesky_factor_is_in_place_and_correct():
    n = 1200
    p = unit(n, 2)
    tracemalloc.start()
    tracemalloc.reset_peak()
    it = SobolevInterpolator(p, field(p), 1.7)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    matrix = 8 * n * n
    # one N x N buffer (11.5 MB) plus O(N) arrays: no second copy of the matrix
    assert matrix <= peak < 1.25 * matrix
    L, lower = it.cholesky
    assert lower and L.flags.f_contiguous and L.shape == (n, n)
    Lt = np.tril(L)
    K = dense_kernel(1.7, p)
    assert np.max(np.abs(Lt @ Lt.T - K)) < 1e-12 * K.max()
    assert it.log_det == pytest.approx(np.linalg.slogdet(K)[1], rel=1e-10)
    # usable with scipy's cho_solve
    b = np.random.default_rng(0).normal(size=n)
    assert np.allclose(scipy.linalg.cho_solve(it.cholesky, b), it.solve(b), rtol=1e-10, atol=0)


def test_query_shapes_follow_values():
    p = unit(200, 3)
    f = field(p)
    q = unit(12, 4).reshape(3, 4, 3)
    it3 = SobolevInterpolator(p, f, 1.5)
    it1 = SobolevInterpolator(p, f[:, 0], 1.5)
    assert it3(q).shape == (3, 4, 3)
    assert it1(q).shape == (3, 4)
    assert it1([0.0, 0.0, 5.0]).shape == ()  # a single direction, any length
    assert it3([0.0, 0.0, 5.0]).shape == (3,)
    assert np.allclose(it1(q), it3(q)[..., 0], rtol=0, atol=1e-12)


# ----------------------------------------------------------------------------- scipy RBF

def test_agrees_with_scipy_rbf_linear_at_s_1_5():
    r"""At s = 1.5, K = 8/3 - r. RBFInterpolator(kernel="linear") is -r plus a constant with
    the side condition sum(lambda) = 0. Imposing that condition on K (the augmented system,
    solved here with this interpolator's factorisation) gives *the same* interpolant, because
    (8/3) sum(alpha) vanishes. Without it the interpolants differ by
    beta (u(x) - 1), u = the K-interpolant of the constant 1 and
    beta = 1^T K^-1 f / 1^T K^-1 1, i.e. beta times the error of interpolating a constant.
    """
    p = unit(400, 5)
    f = field(p)
    q = unit(3000, 6)
    rbf = RBFInterpolator(p, f, kernel="linear")(q)
    it = SobolevInterpolator(p, f, 1.5)
    ones = np.ones(400)
    k1 = it.solve(ones)
    beta = (ones @ it.coefficients) / (ones @ k1)            # per channel
    alpha_aug = it.coefficients - np.outer(k1, beta)
    assert np.max(np.abs(alpha_aug.sum(0))) < 1e-9
    aug = it.evaluate(q, coefficients=alpha_aug) + beta
    assert np.max(np.abs(aug - rbf)) < 1e-8 * np.abs(f).max()
    # the plain interpolant: the difference is exactly beta (u - 1) ...
    plain = it(q)
    u = it.evaluate(q, coefficients=k1)
    diff = plain - rbf
    assert np.max(np.abs(diff - np.outer(u - 1.0, beta))) < 1e-8
    # ... small (constants are nearly reproduced) but not zero
    rel = np.max(np.abs(diff)) / np.abs(f).max()
    assert 1e-7 < rel < 1e-2


# ----------------------------------------------------------------------------- errors

@pytest.mark.parametrize("s", [1.0, 2.0, 0.5, 2.5, float("nan"), "x"])
def test_rejects_smoothness_outside_1_2(s):
    p = unit(10, 7)
    with pytest.raises(ParameterError, match="1 < s < 2|number"):
        SobolevInterpolator(p, np.ones(10), s)


def test_rejects_duplicate_points_with_their_indices():
    p = unit(50, 8)
    p[31] = p[4]
    with pytest.raises(DuplicatePointsError, match=r"points 4 and 31"):
        SobolevInterpolator(p, np.ones(50), 1.5)
    p[31] = p[4] + 1e-14
    with pytest.raises(DuplicatePointsError, match=r"points 4 and 31 coincide"):
        SobolevInterpolator(p, np.ones(50), 1.5)
    # with the kd-tree check off, the factorisation itself reports the pair
    p[31] = p[4]
    for s in (1.2, 1.5, 1.9):
        with pytest.raises(DuplicatePointsError, match=r"points 4 and 31"):
            SobolevInterpolator(p, np.ones(50), s, check_duplicates=False)
    # distinct points 1e-7 apart are legitimate
    p[31] = p[4] + 1e-7
    SobolevInterpolator(p, np.ones(50), 1.5)


@pytest.mark.parametrize("bad", [
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
    [[np.nan, 0.0, 1.0], [1.0, 0.0, 0.0]],
    [[np.inf, 0.0, 1.0], [1.0, 0.0, 0.0]],
    [[1.0, 0.0], [0.0, 1.0]],
])
def test_rejects_bad_points_without_warnings(bad):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ParameterError):
            SobolevInterpolator(bad, np.ones(2), 1.5)


def test_normalises_points_without_overflow():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        u = as_unit_vectors([[1e300, 1e300, 0.0], [0.0, 3e-320, 0.0], [0.0, 0.0, -2.0]])
    assert np.allclose(u, [[2 ** -0.5, 2 ** -0.5, 0], [0, 1, 0], [0, 0, -1]], rtol=1e-15)


def test_rejects_bad_values():
    p = unit(10, 9)
    with pytest.raises(ParameterError, match="NaN"):
        SobolevInterpolator(p, np.r_[np.ones(9), np.nan], 1.5)
    with pytest.raises(ParameterError, match="shape"):
        SobolevInterpolator(p, np.ones(11), 1.5)


def test_memory_guard_names_the_largest_n(monkeypatch):
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", "200M")
    budget = available_memory_bytes() * MEMORY_FRACTION
    nmax = largest_feasible_n(budget, 1)
    # the root of the quadratic, checked against the byte count on both sides
    assert interpolator_nbytes(nmax, 1) <= budget < interpolator_nbytes(nmax + 1, 1)
    assert 2000 < nmax < 4000
    p = unit(nmax + 50, 10)
    tracemalloc.start()
    with pytest.raises(MemoryBudgetError, match=f"largest N that fits is {nmax}"):
        SobolevInterpolator(p, np.ones(nmax + 50), 1.5, solver="cholesky")
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak < 2**20  # refused before allocating the matrix
    SobolevInterpolator(p[:nmax], np.ones(nmax), 1.5)  # N = nmax fits


# ----------------------------------------------------------------------------- solves

def test_multi_rhs_solve_equals_separate_solves():
    p = unit(250, 11)
    rng = np.random.default_rng(1)
    F = rng.normal(size=(250, 5))
    it = SobolevInterpolator(p, F, 1.3)
    K = dense_kernel(1.3, p)
    ref = np.linalg.solve(K, F)
    assert np.allclose(it.coefficients, ref, rtol=1e-9, atol=1e-9 * np.abs(ref).max())
    for c in range(5):
        single = SobolevInterpolator(p, F[:, c], 1.3)
        assert np.allclose(single.coefficients[:, 0], it.coefficients[:, c], rtol=1e-12, atol=1e-12)
    G = rng.normal(size=(250, 7))
    X = it.solve(G)
    assert X.shape == (250, 7)
    sep = np.column_stack([it.solve(G[:, c]) for c in range(7)])
    assert np.max(np.abs(X - sep)) < 1e-11 * np.abs(sep).max()
    # evaluation with 5 channels (power block + BLAS) equals channel-by-channel (fused) sums
    q = unit(500, 12)
    all5 = it(q)
    assert np.allclose(all5, np.column_stack([single_channel(it, q, c) for c in range(5)]),
                       rtol=0, atol=1e-11 * np.abs(all5).max())


def single_channel(it, q, c):
    return it.evaluate(q, coefficients=it.coefficients[:, c], method="direct")


# ----------------------------------------------------------------------------- evaluation

@pytest.mark.parametrize("s", [1.1, 1.5, 1.9])
@pytest.mark.parametrize("nc", [1, 3, 4])
def test_direct_evaluation_equals_naive_numpy(s, nc):
    p = unit(700, 13)
    rng = np.random.default_rng(2)
    alpha = rng.normal(size=(700, nc))
    it = SobolevInterpolator(p, np.zeros((700, nc)), s)
    q = unit(900, 14)
    q[:5] = it.points[:5]              # queries on nodes (d = 0) and next to them
    q[5] = it.points[5] + 1e-9
    q = as_unit_vectors(q)             # the reference sees exactly the evaluated directions
    ref, scale = naive_interpolant(q, it.points, alpha, s)
    got = it.evaluate(q, coefficients=alpha, method="direct")
    assert np.max(np.abs(got - ref) / np.abs(ref).max()) < 1e-10
    assert np.max(np.abs(got - ref) / scale) < 1e-14


@pytest.mark.parametrize("s", [1.1, 1.5, 1.9])
def test_nearfar_evaluation_equals_naive_numpy(s):
    """The near/far split: error below 1e-12 of sum_j |alpha_j K(q, p_j)| (the SH transforms
    run at 3e-13), and, for this well-conditioned problem, 1e-10 of the values."""
    p = unit(1500, 15)
    it = SobolevInterpolator(p, field(p), s)
    q = unit(4000, 16)
    q[:10] = it.points[:10]
    ref, scale = naive_interpolant(q, it.points, it.coefficients, s)
    got = it.evaluate(q, method="nearfar")
    assert np.max(np.abs(got - ref) / scale) < 1e-12
    if s < 1.8:
        assert np.max(np.abs(got - ref)) < 1e-10 * np.abs(ref).max()
    assert np.max(np.abs(got - ref)) < 1e-8 * np.abs(ref).max()


def test_auto_uses_nearfar_for_large_problems(monkeypatch):
    p = unit(1000, 17)
    it = SobolevInterpolator(p, field(p)[:, 0], 1.9)
    calls = []
    for name in ("_power_sums_direct", "_power_sums_nearfar"):
        orig = getattr(it, name)
        monkeypatch.setattr(it, name, lambda q, a, _o=orig, _n=name: calls.append(_n) or _o(q, a))
    q = unit(50000, 18)
    auto = it(q)
    small = unit(100, 19)
    it(small)
    assert calls == ["_power_sums_nearfar", "_power_sums_direct"]
    ref, _ = naive_interpolant(q[:2000], it.points, it.coefficients, 1.9)
    assert np.max(np.abs(auto[:2000] - ref[:, 0])) < 1e-8 * np.abs(ref).max()
    with pytest.raises(ParameterError, match="method"):
        it.evaluate(small, method="fmm")


@pytest.mark.parametrize("s", [1.2, 1.5, 1.9])
def test_far_field_expansion(s):
    """P_L approximates (2-2t)^(s-1) off the cap; its Legendre weights w_l reproduce it."""
    ff = far_field_expansion(s, 0.15)
    assert ff.far_error < 1e-13
    t0 = 1 - 0.15 ** 2 / 2
    t = np.concatenate([np.linspace(-1, t0, 3001), t0 - np.geomspace(1e-8, 0.5, 200)])
    l = np.arange(ff.lmax + 1)
    g = ff.sh_weights * (2 * l + 1) / (4 * np.pi)     # Legendre coefficients of P_L
    series = legendre.legval(t, g)
    assert np.max(np.abs(series - (2 - 2 * t) ** (s - 1))) < 1e-13
    # the near-zone Chebyshev series is the same polynomial, continued into the cap
    d2 = np.linspace(0, 0.15 ** 2, 101)
    near = np.polynomial.chebyshev.chebval(2 * d2 / 0.15 ** 2 - 1, ff.near_cheb)
    assert np.max(np.abs(near - legendre.legval(1 - d2 / 2, g))) < 1e-13


# ----------------------------------------------------------------------------- LOO, likelihood

@pytest.mark.parametrize("s", [1.3, 1.8])
def test_loo_closed_form_equals_explicit_refits(s):
    n = 60
    p = unit(n, 20)
    f = field(p)[:, :2]
    it = SobolevInterpolator(p, f, s)
    e = it.loo_residuals()
    assert e.shape == (n, 2)
    refit = np.empty((n, 2))
    for i in range(n):
        keep = np.arange(n) != i
        sub = SobolevInterpolator(p[keep], f[keep], s)
        refit[i] = f[i] - sub(p[i])
    assert np.allclose(e, refit, rtol=1e-8, atol=1e-10)
    # 1-D values give 1-D residuals; other values reuse the factorisation
    assert np.allclose(it.loo_residuals(f[:, 0]), refit[:, 0], rtol=1e-8, atol=1e-10)


def test_inverse_diagonal_in_blocks_matches_dense_inverse():
    from envfit.theory._cholesky import inverse_diagonal
    p = unit(700, 21)
    it = SobolevInterpolator(p, np.ones(700), 1.6)
    K = dense_kernel(1.6, p)
    ref = np.diag(np.linalg.inv(K))
    for block in (1, 64, 333, 700, 5000):
        got = inverse_diagonal(it.cholesky[0], block=block)
        assert np.allclose(got, ref, rtol=1e-8, atol=0)
    assert np.allclose(it.inverse_diagonal(), ref, rtol=1e-8, atol=0)


@pytest.mark.parametrize("s", [1.25, 1.75])
def test_profiled_log_likelihood_equals_multivariate_normal(s):
    n = 80
    p = unit(n, 22)
    f = field(p)
    it = SobolevInterpolator(p, f, s)
    ll, sigma = it.log_likelihood_profiled()
    K = dense_kernel(s, p)
    for c in range(3):
        sig2 = f[:, c] @ np.linalg.solve(K, f[:, c]) / n
        assert sigma[c] == pytest.approx(np.sqrt(sig2), rel=1e-10)
        mvn = scipy.stats.multivariate_normal(mean=np.zeros(n), cov=sigma[c] ** 2 * K)
        assert ll[c] == pytest.approx(mvn.logpdf(f[:, c]), rel=1e-10, abs=1e-8)
        # sigma-hat maximises the likelihood over the scale
        for fac in (0.98, 1.02):
            other = scipy.stats.multivariate_normal(mean=np.zeros(n), cov=(fac * sigma[c]) ** 2 * K)
            assert other.logpdf(f[:, c]) < ll[c]
    one = SobolevInterpolator(p, f[:, 1], s).log_likelihood_profiled()
    assert isinstance(one.loglik, float) and one.loglik == pytest.approx(ll[1], rel=1e-12)


def test_normalisation_is_idempotent_and_row_independent():
    rng = np.random.default_rng(23)
    p = rng.normal(size=(5000, 3)) * rng.uniform(0.1, 10, size=(5000, 1))
    u = as_unit_vectors(p)
    assert np.array_equal(as_unit_vectors(u), u)
    assert np.array_equal(as_unit_vectors(p[17:21]), u[17:21])
    assert np.max(np.abs(np.linalg.norm(u, axis=1) - 1)) < 4e-16


def test_profiled_log_likelihood_is_one_formula_for_all_three_paths():
    """envfit.sobolev._likelihood.profiled_log_likelihood against scipy's multivariate normal,
    and the interpolator, the band-limited likelihood and fit.sigma.profiled_sigma all
    giving its numbers."""
    from envfit.data_gen._gp import gaussian_process_map
    from envfit.fit._sigma import profiled_sigma
    from envfit.sobolev._bandlimited import BandlimitedKernel, bandlimited_log_likelihood
    from envfit.sobolev._likelihood import profiled_log_likelihood
    from envfit.maps._envmap import EnvMap
    from envfit.maps._latlong import local_to_world
    from envfit.theory._sphere_points import sphere_points
    rng = np.random.default_rng(5)
    n = 40
    A = rng.normal(size=(n, n))
    K = A @ A.T + n * np.eye(n)
    f = rng.normal(size=(n, 3)) * [1.0, 2.0, 0.0]        # the last channel is zero
    log_det = float(np.linalg.slogdet(K)[1])
    ll, sigma = profiled_log_likelihood(f, np.linalg.solve(K, f), log_det)
    for c in range(2):
        mvn = scipy.stats.multivariate_normal(mean=np.zeros(n), cov=sigma[c] ** 2 * K)
        assert ll[c] == pytest.approx(mvn.logpdf(f[:, c]), rel=1e-12)
    assert sigma[2] == 0.0 and ll[2] == np.inf
    one = profiled_log_likelihood(f[:, 0], np.linalg.solve(K, f[:, 0]), log_det)
    assert isinstance(one.sigma, float) and one.loglik == pytest.approx(ll[0], rel=1e-14)
    # the three callers
    p = unit(60, 8)
    g = field(p)
    it = SobolevInterpolator(p, g, 1.4)
    ref = profiled_log_likelihood(g, np.linalg.solve(dense_kernel(1.4, p), g), it.log_det)
    np.testing.assert_allclose(it.log_likelihood_profiled().loglik, ref.loglik, rtol=1e-10)
    Kb = BandlimitedKernel(1.4, 20).matrix(p)
    refb = profiled_log_likelihood(g, np.linalg.solve(Kb, g), float(np.linalg.slogdet(Kb)[1]))
    np.testing.assert_allclose(bandlimited_log_likelihood(p, g, 1.4, 20).loglik, refb.loglik,
                               rtol=1e-9)
    env = EnvMap(gaussian_process_map(1.5, 16, seed=1, channels=2))
    dirs = sphere_points("sf", 120, seed=0) @ local_to_world(env.up).T
    v = env.lookup(dirs).reshape(120, 2)
    v = v - v.mean(axis=0)
    np.testing.assert_allclose(profiled_sigma(env, 1.6, n=120),
                               SobolevInterpolator(dirs, v, 1.6).log_likelihood_profiled().sigma,
                               rtol=1e-9)
