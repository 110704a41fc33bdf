"""Tests of envfit.data_gen._analytic: closed-form shading integrals (Eq. 17) vs brute-force quadrature.

References computed here, independently of the module's formulas:
* smooth maps: a product rule in the *axis* frame (Gauss–Legendre in t = u·axis on [0, 1],
  trapezoid in the azimuth — exact for the polynomial integrands, spectrally accurate for
  the glossy exponential), f evaluated through the map's own ``values_at``;
* cap indicators (sun disk, bright region of the step): a nested adaptive 2-D
  ``scipy.integrate.quad`` over the cap in the *cap's* frame, restricted to u·axis > 0;
* r_s by 1-D quadrature of Eq. 18.
"""
from __future__ import annotations

import functools

import numpy as np
import pytest
from scipy import integrate

from envfit.data_gen import _analytic as A
from envfit.data_gen import SyntheticMapError

RTOL = 1e-6


def unit(theta, phi=0.3):
    return np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])


def frame(axis):
    """Orthonormal e1, e2 completing axis."""
    h = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = h - (h @ axis) * axis
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(axis, e1)


def weight(kind, n):
    if kind == "diffuse":
        return (lambda t: t), 0.5
    rs = integrate.quad(lambda t: np.exp(n * (t - 1.0)), 0.0, 1.0, epsabs=0, epsrel=1e-13)[0]
    return (lambda t: np.exp(n * (t - 1.0))), rs


@functools.lru_cache(maxsize=None)
def gauss_legendre(nt):
    return np.polynomial.legendre.leggauss(nt)


def brute_smooth(m, axis, kind, n=None, nt=300, nphi=128):
    """(1/(2π r_s)) ∫_{u·axis>0} f p dS with a product rule in the axis frame."""
    p, rs = weight(kind, n)
    x, w = gauss_legendre(nt)
    t, wt = 0.5 * (x + 1), 0.5 * w
    ph = 2 * np.pi * np.arange(nphi) / nphi
    e1, e2 = frame(axis)
    st = np.sqrt(1 - t * t)
    u = (t[:, None, None] * axis + st[:, None, None]
         * (np.cos(ph)[None, :, None] * e1 + np.sin(ph)[None, :, None] * e2))
    f = m.values_at(u)                                                  # (nt, nphi, C)
    total = np.einsum("t,tpc->c", wt * p(t), f) * (2 * np.pi / nphi)
    return total / (2 * np.pi * rs)


def brute_cap(axis, centre, rho, kind, n=None):
    """(1/(2π r_s)) ∫_{cap(centre, ρ) ∩ {u·axis > 0}} p(u·axis) dS, nested adaptive quad."""
    p, rs = weight(kind, n)
    cg = float(np.clip(axis @ centre, -1, 1))
    sg = np.sqrt(1 - cg * cg)

    def ring(th):   # ∫ over φ' of p(u·axis) on the circle of polar angle th about centre
        a, b = np.cos(th) * cg, np.sin(th) * sg          # u·axis = a + b cos φ'
        if b < 1e-15:
            return 2 * np.pi * p(a) if a > 0 else 0.0
        phim = np.arccos(np.clip(-a / b, -1, 1))
        if phim <= 0:
            return 0.0
        return 2 * integrate.quad(lambda ph: p(a + b * np.cos(ph)), 0, phim,
                                  epsabs=1e-15, epsrel=1e-12, limit=200)[0]

    g = np.arccos(cg)
    pts = [q for q in (abs(np.pi / 2 - g), np.pi / 2 + g, 1.5 * np.pi - g) if 0 < q < rho]
    val = integrate.quad(lambda th: ring(th) * np.sin(th), 0, rho, points=pts or None,
                         epsabs=1e-14, epsrel=1e-11, limit=200)[0]
    return val / (2 * np.pi * rs)


def close(got, ref, atol=1e-10):
    np.testing.assert_allclose(got, ref, rtol=RTOL, atol=atol)


AXES = [unit(t, ph) for t, ph in [(0.0, 0.0), (0.4, 0.3), (1.2, 2.0), (np.pi / 2, 1.0),
                                  (1.9, -0.7), (2.6, 4.0), (np.pi, 0.0)]]


# ----------------------------------------------------------------------------- normalisation

@pytest.mark.parametrize("n", [1e-4, 0.5, 7.0, 300.0])
def test_glossy_normalisation_and_mean_cosine(n):
    p, rs = weight("glossy", n)
    assert A.glossy_normalisation(n) == pytest.approx(rs, rel=1e-12)
    mu = integrate.quad(lambda t: t * p(t), 0, 1, epsabs=0, epsrel=1e-12)[0] / rs
    assert A.glossy_mean_cosine(n) == pytest.approx(mu, rel=1e-10)


# ----------------------------------------------------------------------------- smooth maps

def test_constant_map_every_axis_and_brdf():
    m = A.ConstantMap((0.5, 2.0, 3.0))
    axes = np.array(AXES)
    np.testing.assert_array_equal(m.diffuse_integral(axes), np.tile([0.5, 2.0, 3.0], (7, 1)))
    np.testing.assert_array_equal(m.glossy_integral(axes[1], 40.0), [0.5, 2.0, 3.0])
    close(brute_smooth(m, AXES[2], "glossy", 12.0), [0.5, 2.0, 3.0])
    np.testing.assert_array_equal(m.render(4), np.full((4, 8, 3), [0.5, 2.0, 3.0]))


@pytest.mark.parametrize("axis", AXES)
def test_sky_gradient_diffuse_and_glossy_vs_quadrature(axis):
    m = A.SkyGradientMap(horizon=(1.0, 0.8, 0.6), zenith=(0.4, 0.9, 1.7))
    close(m.diffuse_integral(axis), brute_smooth(m, axis, "diffuse"))
    # the formula itself: a + (2/3) b (n·z)
    close(m.diffuse_integral(axis), m.a + 2 / 3 * m.b * axis[2])
    for n in (0.7, 10.0, 150.0):
        close(m.glossy_integral(axis, n), brute_smooth(m, axis, "glossy", n))


def test_sky_gradient_values_and_render():
    m = A.SkyGradientMap(horizon=2.0, zenith=3.0)
    np.testing.assert_allclose(m.values([0.0, np.pi / 2, np.pi], 0.0)[:, 0], [3.0, 2.0, 1.0],
                               atol=1e-15)
    np.testing.assert_allclose(m.nadir, [1.0])
    H = 16
    avg, pt = m.render(H), m.render(H, mode="point")
    # cell average of a + b z over an equal-area cell = mean over a fine z-rule in the cell
    zt, zb = np.cos(np.pi * np.arange(H) / H), np.cos(np.pi * (np.arange(H) + 1) / H)
    x, w = np.polynomial.legendre.leggauss(8)
    zs = zb[:, None] + (zt - zb)[:, None] * 0.5 * (x + 1)[None, :]
    ref = (m.values(np.arccos(zs), 0.0)[..., 0] * 0.5 * w).sum(axis=1)
    np.testing.assert_allclose(avg[:, 5, 0], ref, rtol=1e-13)
    np.testing.assert_allclose(pt[:, 3, 0], 2.0 + np.cos(np.pi * (np.arange(H) + 0.5) / H))


# ----------------------------------------------------------------------------- caps

CAP_CASES = [(0.3, 0.0), (0.3, 1.2), (0.3, np.pi / 2), (0.3, 1.75), (0.3, 1.9),
             (1.0, 0.2), (1.0, 1.0), (1.0, 2.4), (np.pi / 2, 0.7), (np.pi / 2, np.pi / 2),
             (2.0, 0.0), (2.0, 1.0), (2.0, 2.5), (2.0, np.pi)]


@pytest.mark.parametrize("rho,gamma", CAP_CASES)
def test_diffuse_cap_closed_form_vs_quadrature(rho, gamma):
    centre = np.array([0.0, 0.0, 1.0])
    axis = unit(gamma, 0.9)
    close(A.diffuse_cap_integral(axis @ centre, rho), brute_cap(axis, centre, rho, "diffuse"))


@pytest.mark.parametrize("rho,gamma", CAP_CASES[::2] + [(0.05, 1.55), (0.05, 1.6)])
@pytest.mark.parametrize("n", [2.0, 60.0])
def test_glossy_cap_vs_quadrature(rho, gamma, n):
    centre = unit(0.8, 2.0)
    e1, _ = frame(centre)
    axis = np.cos(gamma) * centre + np.sin(gamma) * e1
    close(A.glossy_cap_integral(axis, centre, rho, n), brute_cap(axis, centre, rho, "glossy", n))


def test_cap_fully_visible_closed_form():
    # ∫_cap u dS = π sin²ρ c  ⇒  D = sin²ρ cos γ when γ + ρ ≤ π/2
    assert A.diffuse_cap_integral(np.cos(0.4), 0.2) == pytest.approx(np.sin(0.2) ** 2 * np.cos(0.4),
                                                                    rel=1e-14)
    assert A.diffuse_cap_integral(np.cos(2.0), 0.2) == 0.0
    assert A.diffuse_cap_integral(1.0, np.pi / 2) == pytest.approx(1.0, rel=1e-14)


# ----------------------------------------------------------------------------- step map

@pytest.mark.parametrize("theta_edge", [0.3, np.pi / 2 - 0.05, 1.0, np.pi / 2, 2.0])
def test_step_map_integrals_vs_quadrature(theta_edge):
    m = A.StepMap(low=(0.2, 0.1), high=(5.0, 3.0), theta_edge=theta_edge)
    z = np.array([0.0, 0.0, 1.0])
    axes = np.array([AXES[0], AXES[2], AXES[4], AXES[6]])
    got_d = m.diffuse_integral(axes)
    got_g = m.glossy_integral(axes, 25.0)
    for k, ax in enumerate(axes):
        ref_d = m.lo + (m.hi - m.lo) * brute_cap(ax, z, theta_edge, "diffuse")
        ref_g = m.lo + (m.hi - m.lo) * brute_cap(ax, z, theta_edge, "glossy", 25.0)
        close(got_d[k], ref_d)
        close(got_g[k], ref_g)


def test_step_map_values_and_exact_cell_average():
    m = A.StepMap(low=1.0, high=4.0, theta_edge=1.0)
    np.testing.assert_array_equal(m.values([0.5, 0.999, 1.001, 3.0], 2.0)[:, 0], [4, 4, 1, 1])
    H = 32
    f = m.render(H)
    i = np.arange(H)
    omega = 2 * np.pi / (2 * H) * (np.cos(np.pi * i / H) - np.cos(np.pi * (i + 1) / H))
    total = (f[..., 0] * omega[:, None]).sum()
    exact = 4 * np.pi * 1.0 + 3.0 * 2 * np.pi * (1 - np.cos(1.0))
    assert total == pytest.approx(exact, rel=1e-13)
    assert set(np.unique(f[i != int(1.0 / np.pi * H), 0, 0])) <= {1.0, 4.0}


# ----------------------------------------------------------------------------- sun + sky

SUNS = [(0.5, 0.3, 0.05), (1.5, 2.0, 0.3), (np.pi / 2, -1.0, 0.1), (0.0, 0.0, 0.2)]


@pytest.mark.parametrize("sun", SUNS)
def test_sun_sky_integrals_vs_quadrature(sun):
    th, ph, rho = sun
    sky = A.SkyGradientMap(horizon=(1.0, 1.2, 1.4), zenith=(0.3, 0.5, 1.0))
    m = A.SunSkyMap(th, ph, rho, (1000.0, 900.0, 800.0), sky)
    c = m.sun_direction
    e1, _ = frame(c)
    # axes: towards the sun, grazing (disk straddling the horizon), and away
    axes = [c, np.cos(np.pi / 2 - 0.5 * rho) * c + np.sin(np.pi / 2 - 0.5 * rho) * e1,
            np.cos(np.pi / 2 + 0.3 * rho) * c + np.sin(np.pi / 2 + 0.3 * rho) * e1,
            AXES[1], AXES[5]]
    for ax in axes:
        ref_d = brute_smooth(sky, ax, "diffuse") + m.radiance * brute_cap(ax, c, rho, "diffuse")
        ref_g = (brute_smooth(sky, ax, "glossy", 40.0)
                 + m.radiance * brute_cap(ax, c, rho, "glossy", 40.0))
        close(m.diffuse_integral(ax), ref_d, atol=1e-8)
        close(m.glossy_integral(ax, 40.0), ref_g, atol=1e-8)


def test_sun_disk_entirely_above_horizon_formula():
    m = A.SunSkyMap(0.6, 1.0, 0.1, 10.0, sky=0.0)
    n = unit(0.9, 0.2)
    cosg = n @ m.sun_direction
    assert m.diffuse_integral(n)[0] == pytest.approx(10.0 * np.sin(0.1) ** 2 * cosg, rel=1e-13)


def test_sun_render_cell_averages():
    sky = A.ConstantMap((1.0, 2.0))
    m = A.SunSkyMap(1.0, 0.5, 0.15, (100.0, 50.0), sky, subsamples=8)
    H = 64
    i = np.arange(H)
    omega = 2 * np.pi / (2 * H) * (np.cos(np.pi * i / H) - np.cos(np.pi * (i + 1) / H))
    cov = m.disk_coverage(H)
    disk_area = 2 * np.pi * (1 - np.cos(0.15))
    assert (cov * omega[:, None]).sum() == pytest.approx(disk_area, rel=5e-3)
    fine = A.SunSkyMap(1.0, 0.5, 0.15, (100.0, 50.0), sky, subsamples=64).disk_coverage(H)
    assert abs((fine * omega[:, None]).sum() - disk_area) < abs((cov * omega[:, None]).sum()
                                                                - disk_area) + 1e-6
    f = m.render(H)
    np.testing.assert_allclose(f, np.array([1.0, 2.0]) + np.array([100.0, 50.0]) * cov[..., None])
    # the pixel holding the disk centre is fully inside, a far pixel fully outside
    assert cov[int(1.0 / np.pi * H), int(0.5 / (2 * np.pi) * 2 * H)] == 1.0
    assert cov[H - 1, 0] == 0.0
    assert np.any((cov > 0) & (cov < 1))
    # point mode = values at pixel centres
    pt = m.render(8, mode="point")
    th = np.pi * (np.arange(8) + 0.5) / 8
    phs = 2 * np.pi * (np.arange(16) + 0.5) / 16
    np.testing.assert_array_equal(pt, m.values(th[:, None], phs[None, :]))


def test_sun_coverage_is_conservative_near_the_pole():
    """A disk around the pole: coverage from supersampling agrees with the exact area."""
    m = A.SunSkyMap(0.0, 0.0, 0.3, 1.0, sky=0.0, subsamples=32)
    H = 32
    i = np.arange(H)
    omega = 2 * np.pi / (2 * H) * (np.cos(np.pi * i / H) - np.cos(np.pi * (i + 1) / H))
    # the disk is a polar cap: its exact per-row coverage is known in closed form
    zt, zb = np.cos(np.pi * i / H), np.cos(np.pi * (i + 1) / H)
    exact_row = (zt - np.clip(np.cos(0.3), zb, zt)) / (zt - zb)
    np.testing.assert_allclose(m.disk_coverage(H).mean(axis=1), exact_row, atol=1.0 / 32)


# ----------------------------------------------------------------------------- errors

def test_bad_parameters_raise_clear_errors():
    with pytest.raises(SyntheticMapError, match="theta_edge"):
        A.StepMap(0.0, 1.0, theta_edge=4.0)
    with pytest.raises(SyntheticMapError, match="sun_radius"):
        A.SunSkyMap(0.5, 0.0, 2.0, 1.0)
    with pytest.raises(SyntheticMapError, match="channels"):
        A.SkyGradientMap((1.0, 2.0), (1.0, 2.0, 3.0))
    with pytest.raises(SyntheticMapError, match="unit vectors"):
        A.ConstantMap(1.0).diffuse_integral([0.0, 0.0, 2.0])
    with pytest.raises(SyntheticMapError, match="shininess"):
        A.SkyGradientMap(1.0, 2.0).glossy_integral([0.0, 0.0, 1.0], 0.0)
    with pytest.raises(SyntheticMapError, match="mode"):
        A.ConstantMap(1.0).render(4, mode="bilinear")
    with pytest.raises(ValueError):
        A.ConstantMap(float("nan"))
