"""oracles.is_variance: the exact variances of random-point importance sampling,
checked against Monte Carlo simulations of the estimators written here in plain numpy
(inverse-CDF sampling of the pixels, uniform in (cos θ, φ) inside a pixel; the lobe by its
inverse CDF about the axis), against a finer quadrature and against the ground truth."""
from __future__ import annotations

import numpy as np
import pytest

from envfit.maps._envmap import EnvMap
from envfit.maps._latlong import local_to_world, pixel_solid_angles
from envfit.shading._estimators import rmse_over_axes
from envfit.shading._ground_truth import shading_integral, weight_function
from oracles.is_variance import (LobePdf, MapPdf, is_variance, mis_variance, mixture_pdf,
                                 predicted_rmse_random)
from oracles.sphere_quadrature import sphere_integrals
from envfit.theory._brdf import gauss_legendre_01
from envfit.theory._pointsets import frame_from_axis

NSIGMA = 4.5


def _test_map(h=16, up="y", seed=3) -> EnvMap:
    """Smooth sky-like content, a bright sun, some pixel noise, 3 channels."""
    rng = np.random.default_rng(seed)
    th = np.pi * (np.arange(h) + 0.5) / h
    ph = 2 * np.pi * (np.arange(2 * h) + 0.5) / (2 * h)
    T, P = np.meshgrid(th, ph, indexing="ij")
    base = 0.4 + 0.3 * np.cos(T)[..., None] * np.array([0.8, 1.0, 1.3]) \
        + 0.1 * np.sin(2 * P)[..., None]
    sun = 15.0 * np.exp(-((T - 0.9) ** 2 + (P - 2.0) ** 2) / 0.08)[..., None] * np.array([1.0, 0.9, 0.7])
    data = base + sun + 0.05 * rng.random((h, 2 * h, 3))
    return EnvMap(data, up=up)


AXES = np.array([[0.3, 0.8, 0.5], [-0.6, 0.2, 0.77], [0.1, -0.3, 0.95]])


# ----------------------------------------------------------------------------- samplers

def _world(envmap, local):
    return local @ local_to_world(envmap.up).T


def sample_map(q: np.ndarray, envmap: EnvMap, k: int, rng):
    """k directions with density q_ij/Ω_ij: pixel by the inverse CDF of q, then uniform in
    (cos θ, φ) inside it. Returns (dirs (k, 3), pixel rows, pixel cols)."""
    h, w = q.shape
    cdf = np.cumsum(q.ravel())
    flat = np.minimum(np.searchsorted(cdf, rng.random(k) * cdf[-1], side="right"), h * w - 1)
    i, j = np.divmod(flat, w)
    c0, c1 = np.cos(np.pi * i / h), np.cos(np.pi * (i + 1) / h)
    ct = c0 + (c1 - c0) * rng.random(k)
    ph = 2 * np.pi * (j + rng.random(k)) / w
    st = np.sqrt(np.maximum(0.0, 1 - ct * ct))
    local = np.stack([st * np.cos(ph), st * np.sin(ph), ct], -1)
    return _world(envmap, local), i, j


def map_density(q: np.ndarray, envmap: EnvMap, dirs):
    """q_ij/Ω_ij at world directions (plain numpy: the pixel containing each direction)."""
    h, w = q.shape
    d = dirs @ local_to_world(envmap.up)
    th = np.arccos(np.clip(d[:, 2], -1, 1))
    ph = np.mod(np.arctan2(d[:, 1], d[:, 0]), 2 * np.pi)
    i = np.clip((th * h / np.pi).astype(int), 0, h - 1)
    j = (ph * w / (2 * np.pi)).astype(int) % w
    return (q / pixel_solid_angles(h, w))[i, j]


def sample_lobe(weight, axis, k: int, rng):
    """k directions with density ρ_a (z by the lobe's inverse CDF, uniform azimuth)."""
    z = weight.morph(rng.random(k))
    psi = 2 * np.pi * rng.random(k)
    s = np.sqrt(np.maximum(0.0, 1 - z * z))
    local = np.stack([s * np.cos(psi), s * np.sin(psi), z], -1)
    return local @ frame_from_axis(axis).T


def lobe_density(weight, axis, dirs):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    return weight.p(dirs @ a) / (2 * np.pi * weight.r_s)


def f_values(envmap, weight, axis, dirs):
    return envmap.lookup(dirs) * lobe_density(weight, axis, dirs)[:, None]


def _check(measured_sq_dev, predicted, label):
    """measured_sq_dev (K, C): squared deviations from the exact mean; their mean estimates
    the variance, with standard error std/√K. Returns the worst |z|."""
    est = measured_sq_dev.mean(axis=0)
    se = measured_sq_dev.std(axis=0) / np.sqrt(measured_sq_dev.shape[0])
    z = (est - predicted) / se
    assert np.all(np.abs(z) < NSIGMA), f"{label}: MC {est} vs exact {predicted} (z = {z})"
    return float(np.abs(z).max())


# ----------------------------------------------------------------------------- one-sample IS

@pytest.mark.parametrize("brdf,n,up", [("diffuse", 1, "y"), ("glossy", 30, "y"),
                                       ("glossy", 300, "z")])
def test_map_is_variance_matches_simulation(brdf, n, up):
    m = _test_map(up=up)
    weight = weight_function(brdf, n)
    pdf = MapPdf(m, floor=1e-2)
    var, I, _ = is_variance(m, AXES, pdf, brdf, n, moments=True)
    rng = np.random.default_rng(7)
    for a in range(len(AXES)):
        d, i, j = sample_map(pdf.q, m, 200_000, rng)
        F = f_values(m, weight, AXES[a], d) / map_density(pdf.q, m, d)[:, None]
        _check((F - I[a]) ** 2, var[a], f"map IS {brdf} {n} axis {a}")


@pytest.mark.parametrize("brdf,n", [("diffuse", 1), ("glossy", 30), ("glossy", 1000)])
def test_brdf_sampling_variance_matches_simulation(brdf, n):
    m = _test_map()
    weight = weight_function(brdf, n)
    var, I, _ = is_variance(m, AXES, LobePdf(brdf, n), brdf, n, moments=True)
    rng = np.random.default_rng(11)
    for a in range(len(AXES)):
        d = sample_lobe(weight, AXES[a], 200_000, rng)
        F = f_values(m, weight, AXES[a], d) / lobe_density(weight, AXES[a], d)[:, None]
        _check((F - I[a]) ** 2, var[a], f"BRDF IS {brdf} {n} axis {a}")


def test_mean_of_n_samples_has_mse_var_over_n_and_rmse_convention():
    """N i.i.d. samples: MSE = Var/N; the measured rmse_over_axes² over realisations
    averages to predicted_rmse_random²."""
    m = _test_map()
    weight = weight_function("glossy", 30)
    rng = np.random.default_rng(5)
    axes = rng.normal(size=(12, 3))
    pdf = MapPdf(m)
    var, I, _ = is_variance(m, axes, pdf, "glossy", 30, moments=True)
    N, R = 16, 3000
    est = np.empty((R, len(axes), 3))
    for a in range(len(axes)):
        d, _, _ = sample_map(pdf.q, m, N * R, rng)
        F = f_values(m, weight, axes[a], d) / map_density(pdf.q, m, d)[:, None]
        est[:, a] = F.reshape(R, N, 3).mean(axis=1)
    measured = rmse_over_axes(est, I).total ** 2                     # (R,)
    pred = predicted_rmse_random(var, N)
    z = (measured.mean() - pred.total ** 2) / (measured.std() / np.sqrt(R))
    assert abs(z) < NSIGMA, (measured.mean(), pred.total ** 2, z)
    per = (rmse_over_axes(est, I).per_channel ** 2).mean(axis=0)
    assert np.allclose(per, pred.per_channel ** 2, rtol=0.1)


def test_constant_map_brdf_sampling_has_zero_variance():
    m = EnvMap(np.full((16, 32, 3), 1.7))
    for brdf, n in (("diffuse", 1), ("glossy", 30), ("glossy", 1000)):
        v, I, _ = is_variance(m, AXES, LobePdf(brdf, n), brdf, n, moments=True)
        assert np.abs(v).max() <= 1e-24, (brdf, v)
        assert np.allclose(I, 1.7, atol=1e-12)


def _quarter_pixel_integrals(envmap, g, nq=12):
    """Per pixel ∫_pixel g(ω) dω (H, W, C) by an independent rule: each pixel split at its
    centre lines (where the bilinear interpolant kinks) into 2×2, nq×nq Gauss–Legendre in
    (θ, φ) with the weight sin θ on each quarter (not in cos θ: the interpolant, linear in
    θ, has a square-root singularity in cos θ at the poles)."""
    h, w = envmap.height, envmap.width
    x, wq = gauss_legendre_01(nq)
    out = np.zeros((h, w, envmap.channels))
    for half_t in (0, 1):
        t_lo = np.pi * (np.arange(h) + 0.5 * half_t) / h
        th = t_lo[:, None] + (0.5 * np.pi / h) * x                     # (H, nq)
        wth = (0.5 * np.pi / h) * wq * np.sin(th)
        for half_p in (0, 1):
            p_lo = 2 * np.pi * (np.arange(w) + 0.5 * half_p) / w
            ph = p_lo[:, None] + (np.pi / w) * x                     # (W, nq)
            wph = (np.pi / w) * wq
            st, ct = np.sin(th), np.cos(th)
            loc = np.stack(np.broadcast_arrays(
                st[:, :, None, None] * np.cos(ph)[None, None], st[:, :, None, None] * np.sin(ph)[None, None],
                ct[:, :, None, None] + 0 * ph[None, None]), -1)       # (H, nq, W, nq, 3)
            vals = g(_world(envmap, loc))                              # (H, nq, W, nq, C)
            out += np.einsum("aibjc,ai,j->abc", vals, wth, wph)
    return out


def test_map_is_variance_vanishes_when_pixel_pdf_follows_f():
    """q_ij ∝ ∫_pixel f: Var = I Σ Ω_ij ∫f²/∫f − I² ≥ 0 is only the within-pixel variation of
    f; the fast path reproduces Σ (Ω/q) ∫_pixel f² − I² of the independent rule, and the
    residual falls ~ h² when the same content is sampled on a twice finer map."""
    rel = []
    for h in (16, 32):
        m = _test_map(h=h)
        mono = m.with_data(m.luminance()[..., None])
        weight = weight_function("glossy", 30)
        axis = AXES[0]
        fpix = _quarter_pixel_integrals(mono, lambda d: mono.lookup(d) * lobe_density(
            weight, axis, d.reshape(-1, 3)).reshape(d.shape[:-1])[..., None])[..., 0]
        f2pix = _quarter_pixel_integrals(mono, lambda d: (mono.lookup(d) * lobe_density(
            weight, axis, d.reshape(-1, 3)).reshape(d.shape[:-1])[..., None]) ** 2)[..., 0]
        q = np.maximum(fpix, 0.0)
        pdf = MapPdf(mono, probabilities=q)
        var, I, S = is_variance(mono, axis, pdf, weight, moments=True)
        om = pixel_solid_angles(h)
        ok = pdf.q > 0
        S_ref = np.sum(om[ok] / pdf.q[ok] * f2pix[ok])
        assert abs(S[0, 0] / S_ref - 1) < 1e-9
        assert abs(I[0, 0] - fpix.sum()) < 1e-10 * I[0, 0]
        assert var[0, 0] >= 0
        rel.append(var[0, 0] / I[0, 0] ** 2)
        # luminance × Ω sampling is far worse than the f-proportional pixel pdf
        assert is_variance(mono, axis, MapPdf(mono), weight)[0, 0] > 50 * var[0, 0]
    # relative variance 0.17 (H = 16), 0.044 (H = 32): the O(h²) within-pixel term
    assert rel[0] < 0.25 and rel[1] < rel[0] / 3.5, rel


# ----------------------------------------------------------------------------- MIS

def _mis_case():
    m = _test_map()
    return m, MapPdf(m, floor=1e-2), LobePdf("glossy", 30), weight_function("glossy", 30)


@pytest.mark.parametrize("heuristic", ["balance", "power"])
def test_multi_sample_mis_matches_simulation(heuristic):
    m, pm, pb, weight = _mis_case()
    n1, n2 = 2, 3
    var = mis_variance(m, AXES, pm, pb, weight, mode="multi", heuristic=heuristic,
                       counts=(n1, n2))
    I = shading_integral(m, AXES, weight, method="pixels")
    rng = np.random.default_rng(17)
    R = 100_000
    for a in range(len(AXES)):
        total = np.zeros((R, 3))
        for tech, n in ((0, n1), (1, n2)):
            if tech == 0:
                d, _, _ = sample_map(pm.q, m, R * n, rng)
            else:
                d = sample_lobe(weight, AXES[a], R * n, rng)
            p1, p2 = map_density(pm.q, m, d), lobe_density(weight, AXES[a], d)
            x1, x2 = n1 * p1, n2 * p2
            e = 1.0 if heuristic == "balance" else 2.0
            wts = (x1 ** e if tech == 0 else x2 ** e) / (x1 ** e + x2 ** e)
            own = p1 if tech == 0 else p2
            F = (wts / own)[:, None] * f_values(m, weight, AXES[a], d)
            total += F.reshape(R, n, 3).sum(axis=1) / n
        _check((total - I[a]) ** 2, var[a], f"multi-sample MIS {heuristic} axis {a}")


@pytest.mark.parametrize("heuristic", ["balance", "power"])
def test_one_sample_mis_matches_simulation(heuristic):
    m, pm, pb, weight = _mis_case()
    c = np.array([0.3, 0.7])
    var = mis_variance(m, AXES, pm, pb, weight, mode="one", heuristic=heuristic, fractions=c)
    I = shading_integral(m, AXES, weight, method="pixels")
    rng = np.random.default_rng(23)
    K = 200_000
    for a in range(len(AXES)):
        pick = rng.random(K) < c[0]
        d = np.empty((K, 3))
        d[pick] = sample_map(pm.q, m, int(pick.sum()), rng)[0]
        d[~pick] = sample_lobe(weight, AXES[a], int((~pick).sum()), rng)
        x1 = c[0] * map_density(pm.q, m, d)
        x2 = c[1] * lobe_density(weight, AXES[a], d)
        e = 1.0 if heuristic == "balance" else 2.0
        own = np.where(pick, x1, x2)
        wts = np.where(pick, x1 ** e, x2 ** e) / (x1 ** e + x2 ** e)
        F = (wts / own)[:, None] * f_values(m, weight, AXES[a], d)
        _check((F - I[a]) ** 2, var[a], f"one-sample MIS {heuristic} axis {a}")


def test_one_sample_balance_is_the_mixture_pdf():
    m, pm, pb, weight = _mis_case()
    c = (0.4, 0.6)
    v1 = mis_variance(m, AXES, pm, pb, weight, mode="one", heuristic="balance", fractions=c)
    v2 = is_variance(m, AXES, mixture_pdf([pm, pb], c), weight)
    assert np.allclose(v1, v2, rtol=1e-11, atol=0)


# ----------------------------------------------------------------------------- quadrature

def test_generic_callables_agree_with_the_fast_paths():
    m = _test_map()
    pm = MapPdf(m)
    fast = is_variance(m, AXES, pm, "glossy", 100)
    generic = is_variance(m, AXES, lambda d: pm(d), "glossy", 100)          # one-argument callable
    assert np.allclose(fast, generic, rtol=1e-12, atol=0)
    pb = LobePdf("glossy", 100)
    analytic, I, S = is_variance(m, AXES, pb, "glossy", 100, moments=True)
    generic = is_variance(m, AXES, lambda d, a: pb(d, a), "glossy", 100)    # S − I² form
    assert np.allclose(analytic, generic, rtol=0, atol=1e-10 * S.max())


@pytest.mark.parametrize("brdf,n", [("diffuse", 1), ("glossy", 5), ("glossy", 30),
                                    ("glossy", 1000)])
def test_quadrature_against_a_finer_one_and_the_ground_truth(brdf, n):
    m = _test_map()
    axes = np.vstack([AXES[:2], [[0.0, 1.0, 0.0]]])                      # one at the pole
    pm, pb = MapPdf(m), LobePdf(brdf, n)
    cases = [
        lambda **kw: is_variance(m, axes, pm, brdf, n, moments=True, **kw)[2],
        lambda **kw: is_variance(m, axes, pb, brdf, n, moments=True, **kw)[0],
        lambda **kw: mis_variance(m, axes, pm, pb, brdf, n, heuristic="power", counts=(1, 2),
                                  moments=True, **kw)[2],
        lambda **kw: mis_variance(m, axes, pm, pb, brdf, n, mode="one", moments=True, **kw)[2],
    ]
    from envfit.shading._ground_truth import polynomial_degree
    from envfit.shading._patches import gauss_legendre_order
    D = polynomial_degree(weight_function(brdf, n))
    q = max(4, gauss_legendre_order((2 * D + 3) * (np.pi / 32) / 2))
    for case in cases:
        coarse, fine = case(), case(refine=2, order=2 * q + 4)
        assert np.allclose(coarse, fine, rtol=1e-9, atol=1e-12 * np.abs(fine).max())
    I = is_variance(m, axes, pm, brdf, n, moments=True)[1]
    assert np.allclose(I, shading_integral(m, axes, brdf, n, method="pixels"), rtol=1e-10,
                       atol=1e-12)


def test_cell_interpolant_is_the_lookup():
    m = _test_map()
    worst = []

    def integrands(nd):
        worst.append(float(np.abs(nd.L - m.lookup(nd.dirs)).max()))
        return [nd.rho]

    sphere_integrals(m, AXES, integrands, 1, "diffuse", refine=2)
    assert max(worst) < 1e-12


def test_parameter_errors():
    from envfit.base._errors import ParameterError
    m = _test_map()
    with pytest.raises(ParameterError):
        mis_variance(m, AXES, MapPdf(m), LobePdf(), mode="both")
    with pytest.raises(ParameterError):
        mis_variance(m, AXES, MapPdf(m), LobePdf(), counts=(0, 1))
    with pytest.raises(ParameterError):
        MapPdf(m, probabilities=np.zeros((16, 32)))
    with pytest.raises(ParameterError):
        predicted_rmse_random(np.ones((2, 3)), 0)
