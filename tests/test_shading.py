"""Tests of envfit.shading._ground_truth: the ground truth of the normalised shading integral (Eq. 17).

Every expected value is obtained independently: closed forms (constant and sky-gradient
maps, envfit.data_gen._analytic), 1-D scipy quadrature of an exactly known bilinear interpolant,
a brute-force product rule in the axis frame through envmap.lookup, the closed-form
coefficients of envfit.theory._brdf, and the other of the two methods.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate, special

from envfit.data_gen._analytic import ConstantMap, SkyGradientMap, SunSkyMap
from envfit.data_gen._gp import gaussian_process_map
from envfit.shading import _ground_truth as S
from envfit.shading._patches import gauss_legendre_order
from envfit.shading._bilinear_sh import alm_l_index
from envfit.shading._patches import bilinear_in_patch, patch_rows
from envfit.maps._envmap import EnvMap
from envfit.base._errors import ParameterError
from envfit.maps._latlong import local_to_world
from envfit.theory._brdf import Diffuse, Glossy, Phong
from envfit.theory._pointsets import frame_from_axis


def _axes(n, seed):
    a = np.random.default_rng(seed).standard_normal((n, 3))
    return a / np.linalg.norm(a, axis=1, keepdims=True)


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


# -- weight-function coefficients ----------------------------------------------------------
@pytest.mark.parametrize("weight", [Diffuse(), Glossy(30.0), Glossy(3.0), Phong(7)],
                         ids=["diffuse", "glossy30", "glossy3", "phong7"])
def test_lobe_coefficients_match_direct_quadrature(weight):
    # λ_l = ∫_0^1 p P_l dz / r_s and b̃_l = sqrt((2l+1)/2π) ∫_0^1 p P_l(2z-1) dz / r_s,
    # by scipy quad on p itself (independent of envfit.theory._brdf's Gauss-Legendre path)
    r_s = integrate.quad(lambda z: float(weight.p(z)), 0, 1, epsabs=1e-14, epsrel=1e-13)[0]
    assert r_s == pytest.approx(float(weight.r_s), rel=1e-12)
    lam = S.funk_hecke_factors(weight, 12)
    bt = S.hsh_weight_coefficients(weight, 12)
    for l in range(13):
        sh = integrate.quad(lambda z: float(weight.p(z)) * special.eval_legendre(l, z), 0, 1,
                            epsabs=1e-14, epsrel=1e-12, limit=200)[0] / r_s
        hsh = integrate.quad(lambda z: float(weight.p(z)) * special.eval_legendre(l, 2 * z - 1),
                             0, 1, epsabs=1e-14, epsrel=1e-12, limit=200)[0] / r_s
        assert abs(lam[l] - sh) < 1e-11
        assert abs(bt[l] - np.sqrt((2 * l + 1) / (2 * np.pi)) * hsh) < 1e-11
    assert lam[0] == pytest.approx(1.0, abs=1e-14)
    if isinstance(weight, Diffuse):                       # Ramamoorthi-Hanrahan A_l / π
        np.testing.assert_allclose(lam[:5], [1.0, 2 / 3, 1 / 4, 0.0, -1 / 24], atol=1e-14)
        np.testing.assert_allclose(bt[2:], 0.0, atol=1e-15)


def test_polynomial_degree_and_default_lmax():
    assert S.polynomial_degree(Diffuse()) == 1
    assert S.polynomial_degree(Phong(10)) == 10
    d30, d300 = S.polynomial_degree(Glossy(30)), S.polynomial_degree(Glossy(300))
    assert 20 < d30 < 60 and d30 < d300 < 160
    assert S.default_sh_lmax(Diffuse(), 32) == 63            # kinked: 2H - 1
    assert S.default_sh_lmax(Diffuse(), 1024) == 1023       # H - 1 beyond H = 256
    L = S.default_sh_lmax(Glossy(30), 32)                   # band-limited lobe
    lam = S.funk_hecke_factors(Glossy(30), 4 * L)
    assert np.all(np.abs(lam[L:]) <= 1e-11) and abs(lam[L - 1]) > 1e-11


def test_gauss_legendre_order_bound():
    # the chosen rule really integrates e^{iκx} on [-1, 1] to the tolerance
    for kappa in (0.1, 1.0, np.pi / 2, 5.0):
        q = gauss_legendre_order(kappa, 1e-11)
        x, w = np.polynomial.legendre.leggauss(q)
        assert abs(w @ np.cos(kappa * x) - 2 * np.sin(kappa) / kappa) < 1e-11
        if q > 2:
            x, w = np.polynomial.legendre.leggauss(q - 2)
            assert abs(w @ np.cos(kappa * x) - 2 * np.sin(kappa) / kappa) > 1e-13


# -- the bilinear interpolant -------------------------------------------------------------
def test_patch_interpolant_matches_lookup():
    rng = np.random.default_rng(0)
    h, w = 6, 12
    m = EnvMap(rng.random((h, w, 2)), up="z")
    s = rng.integers(0, h + 1, 4000)
    j = rng.integers(0, w, 4000)
    s[:200], s[200:400], j[400:600] = 0, h, w - 1            # both caps and the seam
    lo, hi = patch_rows(h)
    theta = lo[s] + (hi[s] - lo[s]) * rng.random(s.size)
    phi = 2 * np.pi * (j + 0.5 + rng.random(s.size)) / w
    mine = bilinear_in_patch(m.data, s, j, theta[:, None], phi[:, None])[:, 0, :]
    d = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], 1)
    np.testing.assert_allclose(mine, m.lookup(d), rtol=0, atol=1e-12)


def _row_linear_map(h, alpha=2.0, beta=0.7):
    """Rows linear in θ: the bilinear interpolant is α + β clip(θ, θ_0, θ_{H-1}) exactly."""
    theta = np.pi * (np.arange(h) + 0.5) / h
    row = alpha + beta * theta
    return np.repeat(row[:, None], 2 * h, axis=1), theta


def test_bilinear_sh_coefficients_of_a_zonal_interpolant():
    h = 8
    data, theta_c = _row_linear_map(h)
    alm = S.bilinear_sh_coefficients(EnvMap(data, up="z"), 12)
    l_of = alm_l_index(12)
    m_of = np.repeat(np.arange(13), 13 - np.arange(13))
    # zonal: only m = 0; f_l0 = 2π ∫ f(θ) Y_l0(θ) sinθ dθ by scipy quad on each smooth piece
    f = lambda t: 2.0 + 0.7 * np.clip(t, theta_c[0], theta_c[-1])
    for l in range(13):
        y = lambda t: np.sqrt((2 * l + 1) / (4 * np.pi)) * special.eval_legendre(l, np.cos(t))
        ref = sum(integrate.quad(lambda t: f(t) * y(t) * np.sin(t), a, b, epsabs=1e-13,
                                 epsrel=1e-12)[0]
                  for a, b in [(0, theta_c[0]), (theta_c[0], theta_c[-1]), (theta_c[-1], np.pi)])
        got = alm[0][(l_of == l) & (m_of == 0)][0]
        assert abs(got - 2 * np.pi * ref) < 1e-11
    assert np.abs(alm[0][m_of > 0]).max() < 1e-12


# -- the shading integral -----------------------------------------------------------------
@pytest.mark.parametrize("up", ["y", "x"])
def test_constant_map_gives_the_constant(up):
    value = (0.5, 3.0)
    m = EnvMap(ConstantMap(value).render(16), up=up)
    axes = _axes(25, 1)
    for brdf in ("diffuse", "glossy", Phong(5)):
        for method in ("sh", "pixels"):
            got = S.shading_integral(m, axes, brdf, 30, method=method)
            np.testing.assert_allclose(got, np.broadcast_to(value, got.shape), rtol=0, atol=1e-9)


def _zonal_reference(f_theta, gamma, kind, n=30.0, breaks=()):
    r"""I about an axis at polar angle γ for f depending on θ only, by 1-D scipy quad.

    The φ-integral of the lobe over a ring has a closed form: diffuse
    ∫ max(c + s cosφ, 0) dφ = 2(c arccos(-c/s) + sqrt(s²-c²)) for s > |c|; glossy
    ∫ e^{n(c + s cosφ - 1)} dφ = 2π e^{n(c+s-1)} ive(0, n s) (the lower-hemisphere part is
    below e^{-n}, 1e-13 at n = 30).
    """
    cg, sg = np.cos(gamma), np.sin(gamma)

    def ring(t):
        c, s = np.cos(t) * cg, np.sin(t) * sg
        if kind == "diffuse":
            if s <= abs(c):
                return 2 * np.pi * max(c, 0.0)
            return 2 * (c * np.arccos(-c / s) + np.sqrt(s * s - c * c))
        return 2 * np.pi * np.exp(n * (c + s - 1)) * special.ive(0, n * s)

    norm = np.pi if kind == "diffuse" else 2 * np.pi * (-np.expm1(-n) / n)
    pts = sorted({0.0, np.pi, *breaks, *(p for p in (np.pi / 2 - gamma, np.pi / 2 + gamma,
                                                   gamma) if 0 < p < np.pi)})
    total = sum(integrate.quad(lambda t: f_theta(t) * ring(t) * np.sin(t), a, b,
                               epsabs=1e-13, epsrel=1e-12, limit=200)[0]
                for a, b in zip(pts[:-1], pts[1:]))
    return total / norm


def test_exactly_known_interpolant_against_1d_quadrature():
    h = 12
    data, theta_c = _row_linear_map(h)
    gammas = np.array([0.0, 0.4, 1.3, np.pi / 2, 2.5])
    axes_local = np.stack([np.sin(gammas), 0 * gammas, np.cos(gammas)], 1)
    for up in ("z", "y"):
        m = EnvMap(data, up=up)
        axes = axes_local @ local_to_world(up).T
        f = lambda t: 2.0 + 0.7 * np.clip(t, theta_c[0], theta_c[-1])
        for kind in ("diffuse", "glossy"):
            ref = np.array([_zonal_reference(f, g, kind, breaks=(theta_c[0], theta_c[-1]))
                            for g in gammas])
            pix = S.shading_integral(m, axes, kind, 30, method="pixels")[:, 0]
            sh = S.shading_integral(m, axes, kind, 30, method="sh")[:, 0]
            assert _rel(pix, ref) < 1e-9
            assert _rel(sh, ref) < (1e-6 if kind == "diffuse" else 1e-9)


@pytest.mark.parametrize("up", ["y", "x"])
def test_sky_gradient_matches_closed_form_to_the_interpolation_error(up):
    # point-rendered a + b z: the bilinear interpolant differs from it by <= |b| h²/8,
    # and the difference is O(h²) (ratio 4 per halving of h)
    sky = SkyGradientMap(horizon=(1.0, 0.5), zenith=(3.0, 0.25))
    b = np.abs(sky.b).max()
    axes = _axes(20, 2)
    loc = S.axes_to_local(axes, up)
    for kind in ("diffuse", "glossy"):
        ref = sky.diffuse_integral(loc) if kind == "diffuse" else sky.glossy_integral(loc, 30)
        errs = []
        for h in (16, 32):
            m = EnvMap(sky.render(h, mode="point"), up=up)
            got = {meth: S.shading_integral(m, axes, kind, 30, method=meth)
                   for meth in ("sh", "pixels")}
            assert np.abs(got["sh"] - got["pixels"]).max() < 1e-9
            err = np.abs(got["pixels"] - ref).max()
            assert err <= b * (np.pi / h) ** 2 / 8
            errs.append(err)
        assert 3.5 < errs[0] / errs[1] < 4.5


def test_methods_agree_on_a_gp_map():
    m = EnvMap(gaussian_process_map(1.5, 32, seed=7, channels=2, offset=4.0))
    axes = _axes(40, 3)
    for kind, tol in (("diffuse", 1e-5), ("glossy", 1e-8)):
        sh = S.shading_integral(m, axes, kind, 30, method="sh")
        pix = S.shading_integral(m, axes, kind, 30, method="pixels")
        assert _rel(sh, pix) < tol


def test_methods_agree_on_a_sun_sky_map():
    sun = SunSkyMap(sun_theta=1.2, sun_phi=2.0, sun_radius=0.15, sun_radiance=(40.0, 30.0),
                    sky=SkyGradientMap(horizon=(1.0, 0.8), zenith=(2.0, 2.5)))
    m = EnvMap(sun.render(32))
    axes = _axes(40, 4)
    for kind, tol in (("diffuse", 2e-5), ("glossy", 1e-8)):
        sh = S.shading_integral(m, axes, kind, 30, method="sh")
        pix = S.shading_integral(m, axes, kind, 30, method="pixels")
        assert _rel(sh, pix) < tol


def test_diffuse_sh_truncation_tail_decreases():
    # b_l ~ l^-2 (kink): the SH result converges to the pixel reference as lmax grows
    sun = SunSkyMap(sun_theta=1.0, sun_phi=0.5, sun_radius=0.1, sun_radiance=50.0,
                    sky=SkyGradientMap(1.0, 2.0))
    m = EnvMap(sun.render(32))
    axes = _axes(40, 5)
    pix = S.shading_integral(m, axes, "diffuse", method="pixels")
    errs = [_rel(S.shading_integral(m, axes, "diffuse", lmax=L), pix) for L in (31, 63, 127)]
    assert errs[0] > errs[1] > errs[2]
    assert errs[0] < 2e-4 and errs[2] < 2e-6


def _bruteforce_axis_frame(m, axis, g, nz=400, nphi=800):
    """∫_{u·a>0} f g(u·a) dS by Gauss-Legendre in z × trapezoid in φ about the axis (lookup)."""
    x, w = np.polynomial.legendre.leggauss(nz)
    z, wz = 0.5 * (x + 1), 0.5 * w
    phi = 2 * np.pi * (np.arange(nphi) + 0.5) / nphi
    r = np.sqrt(1 - z * z)
    loc = np.stack(np.broadcast_arrays(r[:, None] * np.cos(phi), r[:, None] * np.sin(phi),
                                       z[:, None]), -1)
    f = m.lookup(loc @ frame_from_axis(axis).T)                          # (nz, nphi, C)
    return np.einsum("zpc,z->c", f, wz * g(z)) * 2 * np.pi / nphi


def test_pixels_against_bruteforce_in_the_axis_frame():
    m = EnvMap(gaussian_process_map(1.5, 16, seed=5, channels=1, offset=3.0))
    axes = np.array([[0.3, 0.5, -0.8], [0.0, 1.0, 0.0]])
    pix = S.shading_integral(m, axes, "diffuse", method="pixels")
    ref = np.array([_bruteforce_axis_frame(m, a, lambda z: z / np.pi) for a in axes])
    assert _rel(pix, ref) < 2e-6


def test_horizon_dipping_between_patch_corners_is_clipped():
    # A horizon whose apex lies just beyond a ring of patch corners (by 5e-4 rad, less than
    # the bilinear deviation h²/8) crosses that ring twice inside one patch while all four
    # corners have the same sign: only the h²/4 margin flags that patch. With the jump
    # kernel 1[u·a > 0] a missed sliver is an error ~1e-6; reference: 1-D quad of the
    # exactly known interpolant (f depends on θ only) times the ring's arc above the horizon.
    h = 16
    data, theta_c = _row_linear_map(h)
    m = EnvMap(data, up="z")
    f = lambda t: 2.0 + 0.7 * np.clip(t, theta_c[0], theta_c[-1])
    ring = theta_c[3]
    axes, refs = [], []
    for j in (0, 5, 31):
        apex_phi = 2 * np.pi * (j + 1) / (2 * h)         # the middle of column j's patch
        for sign in (1.0, -1.0):
            gamma = np.pi / 2 - (ring - sign * 5e-4)
            pa = apex_phi - np.pi
            axes.append([np.sin(gamma) * np.cos(pa), np.sin(gamma) * np.sin(pa), np.cos(gamma)])

            def arc(t, cg=np.cos(gamma), sg=np.sin(gamma)):
                c, s_ = np.cos(t) * cg, np.sin(t) * sg
                if s_ <= abs(c):
                    return 2 * np.pi * (c > 0)
                return 2 * np.arccos(-c / s_)

            pts = sorted({0.0, theta_c[0], theta_c[-1], np.pi / 2 - gamma, np.pi / 2 + gamma,
                          np.pi})
            refs.append(sum(integrate.quad(lambda t: f(t) * arc(t) * np.sin(t), lo_, hi_,
                                           epsabs=1e-13, epsrel=1e-13, limit=200)[0]
                            for lo_, hi_ in zip(pts[:-1], pts[1:]) if hi_ > lo_))
    got = S.hemisphere_integrals(m, np.array(axes), lambda z: (np.ones_like(z),), 1, degree=0)
    np.testing.assert_allclose(got[:, 0, 0], refs, rtol=1e-10)


def test_frames_are_consistent():
    # the same pixels read with another `up`, and the axes mapped accordingly, give the same I
    data = gaussian_process_map(1.5, 16, seed=11, channels=1, offset=3.0)
    axes = _axes(10, 6)
    ref = S.shading_integral(EnvMap(data, up="z"), axes, "glossy", 10, method="sh")
    for up in ("y", "x"):
        mw = local_to_world(up)
        moved = axes @ mw.T                                  # local (= world for "z") → world
        for method in ("sh", "pixels"):
            got = S.shading_integral(EnvMap(data, up=up), moved, "glossy", 10, method=method)
            np.testing.assert_allclose(got, ref, rtol=1e-8, atol=1e-10)


def test_parameter_errors():
    m = EnvMap(np.ones((4, 8, 1)))
    with pytest.raises(ParameterError):
        S.shading_integral(m, [0, 0, 1.0], "phong")
    with pytest.raises(ParameterError):
        S.shading_integral(m, [0, 0, 1.0], method="mc")
    with pytest.raises(ParameterError):
        S.shading_integral(m, [0, 0, 1.0], method="pixels", lmax=3)
    with pytest.raises(ParameterError):
        S.shading_integral(m, [0, 0, 0.0])
    with pytest.raises(ParameterError):
        S.shading_integral(m, [[0, 0, 1.0, 2.0]])
    with pytest.raises(ParameterError):
        S.shading_integral(m, [0, 0, 1.0], "glossy", shininess=-1)
    with pytest.raises(ParameterError):
        S.shading_integral(m, [0, 0, 1.0], lmax=-1)
    assert S.shading_integral(m, np.zeros((0, 3)), method="pixels").shape == (0, 1)
