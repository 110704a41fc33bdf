"""Tests for envfit.theory._pointsets: square generators, SF, Lambert lift, morphs, rotations."""
from __future__ import annotations

import functools
from decimal import Decimal, getcontext

import numpy as np
import pytest
from scipy import integrate, stats

from envfit.theory._errors import TheoryParameterError
from envfit.theory._pointsets import (DETERMINISTIC_POINTSETS, POINTSETS, frame_from_axis,
                                      generate, hemisphere_points, jitter_strata,
                                      lambert_to_hemisphere, larcher_pillichshammer, morph_diffuse,
                                      morph_glossy, random_square, rotate_to_axes, sobol02,
                                      spherical_fibonacci, square_points, stratified_jitter)


# ----------------------------------------------------------------------------- helpers
def _is_02_net(p: np.ndarray, m: int) -> bool:
    """Every dyadic box of area 2^-m holds exactly one of the 2^m points."""
    n = 2 ** m
    assert p.shape == (n, 2)
    for d1 in range(m + 1):
        d2 = m - d1
        a = np.floor(p[:, 0] * 2 ** d1).astype(np.int64)
        b = np.floor(p[:, 1] * 2 ** d2).astype(np.int64)
        cells = a * 2 ** d2 + b
        if not np.array_equal(np.sort(cells), np.arange(n)):
            return False
    return True


def _lp_kollig_keller(i: int, bits: int = 32) -> float:
    """Kollig & Keller's bit loop: for each set bit k of i, XOR the top k+1 bits."""
    r, v = 0, 1 << (bits - 1)
    while i:
        if i & 1:
            r ^= v
        i >>= 1
        v |= v >> 1
    return r / 2.0 ** bits


# ----------------------------------------------------------------------------- SF
def test_spherical_fibonacci_matches_errata_formula_in_exact_arithmetic():
    getcontext().prec = 50
    n = 1000
    phi_golden = (1 + Decimal(5).sqrt()) / 2
    p = spherical_fibonacci(n)
    d = lambert_to_hemisphere(p)
    for j in (0, 1, 2, 3, 10, 377, 610, 999):
        frac = (Decimal(j) / phi_golden) % 1
        assert p[j, 1] == pytest.approx(float(frac), abs=1e-13)
        assert p[j, 0] == 1.0 - (2 * j + 1) / (2 * n)
        az = np.mod(np.arctan2(d[j, 1], d[j, 0]), 2 * np.pi)
        assert np.cos(az - 2 * np.pi * float(frac)) == pytest.approx(1.0, abs=1e-12)
        assert d[j, 2] == pytest.approx(1.0 - (2 * j + 1) / (2 * n), abs=1e-15)
    # z' is the midpoint rule on [0, 1]: mean z = 1/2, mean z^2 = 1/3 - 1/(12 n^2)
    assert d[:, 2].mean() == pytest.approx(0.5, abs=1e-14)
    assert np.mean(d[:, 2] ** 2) == pytest.approx(1 / 3 - 1 / (12 * n * n), abs=1e-14)


# ----------------------------------------------------------------------------- Lambert lift
def test_lambert_lift_has_constant_area_element_2pi():
    rng = np.random.default_rng(5)
    xy = 0.02 + 0.96 * rng.random((200, 2))
    h = 1e-6
    dx = (lambert_to_hemisphere(xy + [h, 0]) - lambert_to_hemisphere(xy - [h, 0])) / (2 * h)
    dy = (lambert_to_hemisphere(xy + [0, h]) - lambert_to_hemisphere(xy - [0, h])) / (2 * h)
    jac = np.linalg.norm(np.cross(dx, dy), axis=1)
    np.testing.assert_allclose(jac, 2 * np.pi, rtol=1e-6)


def test_lambert_lift_of_uniform_points_is_uniform_on_hemisphere():
    n = 400_000
    d = lambert_to_hemisphere(random_square(n, seed=11))
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-14)
    assert d[:, 2].min() >= 0
    se = 1.0 / np.sqrt(n)
    # hemisphere averages: <z> = 1/2, <z^2> = <x^2> = 1/3, <x> = <y> = <xy> = 0, <x^2 z> = 1/8
    assert abs(d[:, 2].mean() - 0.5) < 5 * se * 0.29
    assert abs(np.mean(d[:, 2] ** 2) - 1 / 3) < 5 * se * 0.3
    assert abs(np.mean(d[:, 0] ** 2) - 1 / 3) < 5 * se * 0.3
    assert abs(d[:, 0].mean()) < 5 * se * 0.6 and abs(d[:, 1].mean()) < 5 * se * 0.6
    assert abs(np.mean(d[:, 0] * d[:, 1])) < 5 * se * 0.3
    assert abs(np.mean(d[:, 0] ** 2 * d[:, 2]) - 1 / 8) < 5 * se * 0.2


def test_lambert_lift_rejects_bad_input():
    with pytest.raises(TheoryParameterError):
        lambert_to_hemisphere(np.zeros((3, 3)))
    with pytest.raises(TheoryParameterError):
        lambert_to_hemisphere([[1.5, 0.2]])


# ----------------------------------------------------------------------------- morphs
def _midpoints(k: int = 200_000) -> np.ndarray:
    return (np.arange(k) + 0.5) / k


def test_diffuse_morph_gives_cosine_density():
    z = morph_diffuse(_midpoints())
    # cosine-weighted hemisphere, p = z / pi: E[z] = 2/3, E[z^2] = 1/2, E[z^3] = 2/5
    assert z.mean() == pytest.approx(2 / 3, abs=1e-9)
    assert np.mean(z ** 2) == pytest.approx(1 / 2, abs=1e-9)
    assert np.mean(z ** 3) == pytest.approx(2 / 5, abs=1e-9)
    d = generate("sf", 4096, morph=morph_diffuse)
    assert d[:, 2].mean() == pytest.approx(2 / 3, abs=2e-5)


@pytest.mark.parametrize("shin", [1.0, 30.0, 300.0])
def test_glossy_morph_matches_lobe_moments(shin):
    # uniform z' -> density e^{n(z-1)} / norm on z: E[z^k] = ∫ m(z')^k dz'
    z = morph_glossy(_midpoints(), shin)
    lobe = lambda t: np.exp(shin * (t - 1))
    norm = integrate.quad(lobe, 0, 1, epsabs=0, epsrel=1e-13)[0]
    for k in (1, 2):
        ref = integrate.quad(lambda t: t ** k * lobe(t), 0, 1, epsabs=0, epsrel=1e-13)[0] / norm
        lhs = integrate.quad(lambda u: float(morph_glossy(u, shin)) ** k, 0, 1, limit=200,
                             epsabs=0, epsrel=1e-12)[0]
        assert lhs == pytest.approx(ref, rel=1e-10)
        assert np.mean(z ** k) == pytest.approx(ref, rel=1e-5)
    d = generate("sf", 4096, morph=functools.partial(morph_glossy, shininess=shin))
    assert d[:, 2].mean() == pytest.approx(
        integrate.quad(lambda t: t * lobe(t), 0, 1)[0] / norm, rel=1e-3)


def test_glossy_morph_inverts_cdf_and_is_stable():
    shin = 30.0
    t = np.linspace(0, 1, 101)
    cdf = np.expm1(shin * t) / np.expm1(shin)
    np.testing.assert_allclose(morph_glossy(cdf, shin), t, atol=1e-12)
    zp = np.linspace(0, 1, 1001)
    naive = np.log1p(zp * np.expm1(shin)) / shin      # Eq. 67 as printed
    np.testing.assert_allclose(morph_glossy(zp, shin), naive, atol=1e-13)
    big = morph_glossy(zp, 1e4)                         # e^n overflows in the printed form
    assert np.all(np.isfinite(big)) and np.all(np.diff(big) >= 0)
    assert big[0] == 0.0 and big[-1] == 1.0 and big.min() >= 0
    with pytest.raises(TheoryParameterError):
        morph_glossy(0.5, 0.0)


def test_generate_accepts_morph_callable_and_validates_it():
    m = functools.partial(morph_glossy, shininess=30.0)
    d = generate("lp", 1024, morph=m)
    np.testing.assert_allclose(d[:, 2], m(larcher_pillichshammer(1024)[:, 0]), atol=1e-15)
    with pytest.raises(TheoryParameterError):
        generate("sf", 16, morph=lambda z: 2 * z)
    with pytest.raises(TheoryParameterError):
        generate("sf", 16, morph="sqrt")


# ----------------------------------------------------------------------------- nets
@pytest.mark.parametrize("m", range(0, 11))
def test_sobol_and_lp_are_02_nets(m):
    assert _is_02_net(sobol02(2 ** m), m)
    assert _is_02_net(larcher_pillichshammer(2 ** m), m)
    assert _is_02_net(sobol02(2 ** m, scramble=True, seed=m), m)


def test_sobol_is_a_02_sequence_and_nets_can_fail():
    p = sobol02(2048)
    for m in (3, 6, 9):
        for start in (2 ** m, 3 * 2 ** m):
            assert _is_02_net(p[start:start + 2 ** m], m)
    # the check can fail: random points and a shifted LP block are not nets
    assert not _is_02_net(random_square(256, seed=0), 8)
    assert not _is_02_net(larcher_pillichshammer(512)[1:257], 8)


def test_lp_radical_inverse_matches_kollig_keller_bit_loop():
    n = 3000
    p = larcher_pillichshammer(n)
    ref = np.array([_lp_kollig_keller(i) for i in range(n)])
    np.testing.assert_array_equal(p[:, 1], ref)
    np.testing.assert_array_equal(p[:, 0], np.arange(n) / n)
    assert np.array_equal(larcher_pillichshammer(100)[:, 1], p[:100, 1])


def test_sobol_scramble_is_seeded_and_default_is_deterministic():
    np.testing.assert_array_equal(sobol02(64), sobol02(64, seed=5))
    a, b = sobol02(64, scramble=True, seed=1), sobol02(64, scramble=True, seed=1)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, sobol02(64, scramble=True, seed=2))


# ----------------------------------------------------------------------------- jitter
@pytest.mark.parametrize("n", [1, 2, 3, 7, 16, 50, 99, 100, 257])
def test_jitter_has_one_point_per_equal_area_stratum(n):
    lo, hi = jitter_strata(n)
    np.testing.assert_allclose(np.prod(hi - lo, axis=1), 1.0 / n, rtol=1e-12)
    p = stratified_jitter(n, seed=3)
    inside = np.all((p[:, None, :] >= lo[None]) & (p[:, None, :] < hi[None]), axis=2)
    # point i is in stratum i and in no other one
    np.testing.assert_array_equal(inside, np.eye(n, dtype=bool))
    # the strata tile the square: every test point is in exactly one stratum
    t = random_square(5000, seed=4)
    cover = np.all((t[:, None, :] >= lo[None]) & (t[:, None, :] < hi[None]), axis=2).sum(1)
    assert np.all(cover == 1)
    aspect = (hi - lo).max(1) / (hi - lo).min(1)
    assert aspect.max() <= 2.5 or n < 4


def test_jitter_square_n_is_regular_grid():
    lo, hi = jitter_strata(16)
    np.testing.assert_allclose(hi - lo, 0.25)
    assert sorted(set(lo[:, 0])) == [0, 0.25, 0.5, 0.75]


# ----------------------------------------------------------------------------- registry
def test_registry_generate_all_sets():
    assert set(POINTSETS) == {"sf", "sobol", "lp", "bnot", "random", "jitter"}
    for name in POINTSETS:
        n = 64
        d = generate(name, n, seed=1)
        assert d.shape == (n, 3)
        np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-14)
        assert d[:, 2].min() >= 0
        np.testing.assert_array_equal(d, hemisphere_points(name, n, seed=1))
        sq = square_points(name, n, seed=1)
        assert sq.min() >= 0 and sq.max() < 1
        if name in DETERMINISTIC_POINTSETS:
            np.testing.assert_array_equal(d, generate(name, n, seed=2))
        else:
            np.testing.assert_array_equal(d, generate(name, n, seed=1))
            assert not np.allclose(d, generate(name, n, seed=2))
    with pytest.raises(TheoryParameterError):
        generate("halton", 10)
    for bad in (0, -3, 2.5):
        with pytest.raises(TheoryParameterError):
            generate("sf", bad)


# ----------------------------------------------------------------------------- rotations
def _test_axes():
    rng = np.random.default_rng(8)
    a = rng.standard_normal((500, 3))
    special = [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, -1, 0], [1e-9, 0, -1], [0, 1e-12, 1],
               [1e-300, 0, -1], [3, 4, 0]]
    return np.vstack([a, special]).astype(float)


def test_frame_from_axis_is_orthonormal_right_handed_with_given_axis():
    axes = _test_axes()
    R = frame_from_axis(axes)
    eye = np.einsum("mki,mkj->mij", R, R)
    np.testing.assert_allclose(eye, np.broadcast_to(np.eye(3), eye.shape), atol=2e-15)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-14)
    unit = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    np.testing.assert_allclose(R[:, :, 2], unit, atol=1e-15)
    np.testing.assert_allclose(R @ np.array([0, 0, 1.0]), unit, atol=1e-15)
    np.testing.assert_array_equal(frame_from_axis(axes[3]), R[3])
    with pytest.raises(TheoryParameterError):
        frame_from_axis([0, 0, 0])


def test_rotate_to_axes_preserves_geometry_and_is_vectorised_einsum():
    axes = _test_axes()
    local = generate("sf", 50, morph=morph_diffuse)
    out = rotate_to_axes(local, axes)
    assert out.shape == (axes.shape[0], 50, 3)
    unit = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    # cosine to the axis = local z; pairwise dot products unchanged
    np.testing.assert_allclose(np.einsum("mnj,mj->mn", out, unit),
                               np.broadcast_to(local[:, 2], (axes.shape[0], 50)), atol=1e-14)
    np.testing.assert_allclose(np.einsum("mni,mki->mnk", out, out)[7], local @ local.T,
                               atol=1e-14)
    R = frame_from_axis(axes)
    np.testing.assert_allclose(out[5], local @ R[5].T, atol=1e-15)


def test_random_twist_is_seeded_and_uniform():
    m = 4000
    axis = np.array([0.3, -0.5, 0.8])
    axes = np.tile(axis, (m, 1))
    local = np.array([[1.0, 0.0, 0.0], [0.6, 0.0, 0.8], [0.0, -1.0, 0.0]])
    a = rotate_to_axes(local, axes, seed=42)
    np.testing.assert_array_equal(a, rotate_to_axes(local, axes, seed=42))
    assert not np.allclose(a, rotate_to_axes(local, axes, seed=43))
    # back in the untwisted frame every rotated point is R_z(alpha_m) p with one angle per m
    R0 = frame_from_axis(axis)
    back = a @ R0                       # local coordinates, (m, 3, 3)
    np.testing.assert_allclose(back[:, :, 2], np.broadcast_to(local[:, 2], (m, 3)), atol=1e-14)
    ang = np.arctan2(back[:, :, 1], back[:, :, 0]) - np.arctan2(local[:, 1], local[:, 0])
    ang = np.mod(ang, 2 * np.pi)
    spread = np.abs(np.angle(np.exp(1j * (ang - ang[:, :1]))))
    assert spread.max() < 1e-12
    assert stats.kstest(ang[:, 0] / (2 * np.pi), "uniform").pvalue > 1e-3
    # without seed: no twist
    np.testing.assert_allclose(rotate_to_axes(local, axes[:3]) @ R0,
                               np.broadcast_to(local, (3, 3, 3)), atol=1e-15)
