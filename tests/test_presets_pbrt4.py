"""The pbrt-v4 preset (pbrt-v4 is on no package registry and is not built here): its
equal-area map against values worked out by hand from ``EqualAreaSquareToSphere``, the
round trip, the constant Jacobian (finite differences), the compensated distribution on a
tiny hand-computed image, nearest-pixel radiance, ``makeequiarea`` on maps whose result is
known, pdf ↔ sampling histogram and the pdf's integral (a quadrature independent of the
equal-area map)."""
from __future__ import annotations

import numpy as np
import pytest

from envfit.base import ParameterError
from envfit.maps import EnvMap
from envfit.renderers import (Pbrt4ImageInfiniteLight, PiecewiseConstant2D,
                                     equal_area_sphere_to_square, equal_area_square_to_sphere,
                                     make_equal_area, pbrt_sphere_frame, get_renderer)
from envfit.renderers.pbrt4._equal_area import gaussian_filter_offsets
from oracles.pbrt_equiarea import make_equal_area_numpy

S = np.sqrt(0.5)


def test_square_to_sphere_hand_values():
    """Centre → +z, corners → −z, edge midpoints → ±x, ±y, (¾, ½): r = ½, z = 1 − r² = ¾,
    x = r√(2 − r²); (¼, ¼): r = 1 on the diagonal, φ = π/4 in the (−, −) quadrant."""
    p = [[0.5, 0.5], [0, 0], [1, 0], [0, 1], [1, 1], [1, 0.5], [0, 0.5], [0.5, 1], [0.5, 0],
         [0.75, 0.5], [0.25, 0.25]]
    want = [[0, 0, 1], [0, 0, -1], [0, 0, -1], [0, 0, -1], [0, 0, -1], [1, 0, 0], [-1, 0, 0],
            [0, 1, 0], [0, -1, 0], [0.5 * np.sqrt(1.75), 0, 0.75], [-S, -S, 0]]
    np.testing.assert_allclose(equal_area_square_to_sphere(p), want, atol=1e-12)


def test_round_trip_and_unit_length():
    p = np.random.default_rng(0).random((20000, 2))
    d = equal_area_square_to_sphere(p)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
    # pbrt's inverse uses a minimax polynomial for (2/π) atan: exact to a few 1e-6
    assert np.abs(equal_area_sphere_to_square(d) - p).max() < 5e-6


def test_jacobian_is_constant():
    """|∂d/∂x × ∂d/∂y| = 4π (equal area) by central differences, away from the fold lines
    (the axes u = 0, v = 0 and the diamond |u| + |v| = 1 of the octahedral map)."""
    rng = np.random.default_rng(1)
    p = rng.random((4000, 2)) * 0.98 + 0.01
    u, v = 2 * p[:, 0] - 1, 2 * p[:, 1] - 1
    keep = (np.abs(u) > 0.01) & (np.abs(v) > 0.01) & (np.abs(np.abs(u) + np.abs(v) - 1) > 0.01)
    p = p[keep]
    h = 1e-6
    dx = (equal_area_square_to_sphere(p + [h, 0]) - equal_area_square_to_sphere(p - [h, 0])) / (2 * h)
    dy = (equal_area_square_to_sphere(p + [0, h]) - equal_area_square_to_sphere(p - [0, h])) / (2 * h)
    jac = np.linalg.norm(np.cross(dx, dy), axis=1)
    np.testing.assert_allclose(jac, 4 * np.pi, rtol=1e-4)


def test_compensated_distribution_by_hand():
    """2 × 2 image with channel means [[1, 2], [3, 6]] (rows y, columns x): mean 3, so the
    compensated function is [[0, 0], [0, 3]] — every sample in pixel (x=1, y=1), mapPDF =
    3/(3/4) = 4, pdf 4/(4π); the plain one has mapPDF = v/(Σv/4) = (1, 2, 3, 6)/3."""
    img = np.repeat(np.array([[1.0, 2.0], [3.0, 6.0]])[:, :, None], 3, axis=2)
    comp = Pbrt4ImageInfiniteLight(equal_area=img)
    plain = Pbrt4ImageInfiniteLight(equal_area=img, compensated=False)
    U = np.random.default_rng(2).random((500, 2))
    uv, map_pdf = comp.distribution.sample(U)
    assert np.all(uv >= 0.5) and np.allclose(map_pdf, 4.0)
    np.testing.assert_allclose(comp.sample(U).pdf, 1 / np.pi)
    centres = equal_area_square_to_sphere([[0.25, 0.25], [0.75, 0.25], [0.25, 0.75],
                                           [0.75, 0.75]])
    np.testing.assert_allclose(plain.pdf(centres), np.array([1, 2, 3, 6]) / 3 / (4 * np.pi))
    np.testing.assert_allclose(comp.pdf(centres), [0, 0, 0, 1 / np.pi])
    const = Pbrt4ImageInfiniteLight(equal_area=np.ones((3, 3, 3)))    # all vanish → ones
    np.testing.assert_allclose(const.sample(U).pdf, 1 / (4 * np.pi))


def test_piecewise_constant_rows_by_u1_columns_by_u0():
    """A uniform function is sampled by the identity; a single nonzero cell at column 2,
    row 0 of a 2 × 4 array receives every sample: x ∈ [½, ¾) follows u[0], y ∈ [0, ½)
    follows u[1]."""
    U = np.random.default_rng(3).random((100, 2))
    pts, pdf = PiecewiseConstant2D(np.ones((3, 5))).sample(U)
    np.testing.assert_allclose(pts, U, atol=1e-12)
    f = np.zeros((2, 4))
    f[0, 2] = 5.0
    pts, pdf = PiecewiseConstant2D(f).sample(U)
    np.testing.assert_allclose(pts[:, 0], 0.5 + U[:, 0] / 4, atol=1e-12)
    np.testing.assert_allclose(pts[:, 1], U[:, 1] / 2, atol=1e-12)
    np.testing.assert_allclose(pdf, 8.0)


def test_nearest_pixel_radiance_and_refusal():
    n = 6
    img = np.random.default_rng(4).random((n, n, 3))
    t = Pbrt4ImageInfiniteLight(equal_area=img, scale=2.0)
    y, x = np.mgrid[0:n, 0:n]
    d = equal_area_square_to_sphere(np.column_stack([(x.ravel() + 0.5) / n, (y.ravel() + 0.5) / n]))
    np.testing.assert_allclose(t.eval(d), 2.0 * img.reshape(-1, 3))
    with pytest.raises(ParameterError):
        Pbrt4ImageInfiniteLight(equal_area=np.ones((4, 8, 3)))
    with pytest.raises(ParameterError):
        Pbrt4ImageInfiniteLight()


def test_makeequiarea_constant_and_linear_maps():
    """A constant map converts to the same constant; L = 1 + ½ cos θ (pbrt's light frame:
    z = cos θ of the lat-long file) converts to ≈ 1 + ½ z at each pixel centre (the filter
    blurs a linear function only through the sphere's curvature and the map's folds)."""
    off, w = gaussian_filter_offsets()
    np.testing.assert_allclose(off.mean(axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose(w, w[0])
    np.testing.assert_allclose(np.sort(off[:, 0])[::6], np.sort(-off[:, 0])[::6], atol=1e-12)
    h, n = 64, 64
    theta = np.pi * (np.arange(h) + 0.5) / h
    lat = np.repeat((1 + 0.5 * np.cos(theta))[:, None, None], 2 * h, axis=1).repeat(3, axis=2)
    np.testing.assert_allclose(make_equal_area(EnvMap(np.full((h, 2 * h, 3), 0.7)), 16), 0.7)
    eq = make_equal_area(EnvMap(lat), n)
    y, x = np.mgrid[0:n, 0:n]
    d = equal_area_square_to_sphere(np.column_stack([(x.ravel() + 0.5) / n, (y.ravel() + 0.5) / n]))
    np.testing.assert_allclose(eq[:, :, 0].ravel(), 1 + 0.5 * d[:, 2], atol=6e-3)


def test_makeequiarea_kernel_matches_numpy_form():
    """The compiled loop against the vectorised numpy form of the same arithmetic, on a map
    with a sun next to the pole (so the wrap and the clamp of θ are exercised)."""
    a = 0.1 + np.random.default_rng(12).random((16, 32, 3))
    a[0, 5] = 200.0
    m = EnvMap(a)
    np.testing.assert_allclose(make_equal_area(m, 40), make_equal_area_numpy(m, 40),
                               rtol=1e-12, atol=1e-12)


def _sphere_grid(n_z=1000, n_phi=2000):
    z = -1 + (np.arange(n_z) + 0.5) * 2 / n_z
    phi = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    Z, P = np.meshgrid(z, phi, indexing="ij")
    r = np.sqrt(1 - Z ** 2)
    return np.stack([r * np.cos(P), r * np.sin(P), Z], axis=-1).reshape(-1, 3), 4 * np.pi / Z.size


def _sun_latlong(h=16, seed=5):
    rng = np.random.default_rng(seed)
    a = 0.1 + rng.random((h, 2 * h, 3))
    a[4, 9] *= 300.0
    return EnvMap(a, up="z")


@pytest.mark.parametrize("comp", [True, False])
def test_pdf_integrates_to_one_and_matches_samples(comp):
    t = Pbrt4ImageInfiniteLight(_sun_latlong(), compensated=comp)
    g, dw = _sphere_grid()
    assert abs(t.pdf(g).sum() * dw - 1) < 3e-3
    n = 200_000
    d, p = t.sample(np.random.default_rng(6).random((n, 2)))
    # PDF_Li re-derives the pixel with pbrt's polynomial inverse: within ~2e-6 of a pixel
    # edge it reads the neighbour (pbrt does the same), so agreement is not total
    assert np.mean(np.isclose(t.pdf(d), p, rtol=1e-12)) > 0.999
    k = 8                                               # 8 × 8 equal-area cells, 4π/64 each

    def cell(v):
        sq = np.clip(equal_area_sphere_to_square(v), 0, 1 - 1e-12)
        return (sq[:, 1] * k).astype(int) * k + (sq[:, 0] * k).astype(int)

    counts = np.bincount(cell(d), minlength=k * k)
    expected = np.bincount(cell(g), weights=t.pdf(g) * dw, minlength=k * k) * n
    assert np.all(np.abs(counts - expected) < 5 * np.sqrt(expected) + 0.01 * expected + 3)


def test_orientation_is_envfit_local_frame():
    """makeequiarea reads the lat-long file with z up (pbrt-v3's convention): the bright
    pixel's samples point where envfit's up="z" map puts it; with up="y" the light frame
    is rotated into envfit's world by M_y."""
    m = _sun_latlong()
    want = m.directions()[4, 9]
    for up in ("z", "y"):
        mm = EnvMap(m.data, up=up)
        t = Pbrt4ImageInfiniteLight(mm)
        d, _ = t.sample(np.random.default_rng(7).random((4000, 2)))
        bright = d @ mm.directions()[4, 9] > np.cos(0.2)
        assert bright.mean() > 0.5
        if up == "z":
            assert np.dot(d[bright].mean(axis=0), want) > 0.98


def test_preset_facts():
    p = get_renderer("pbrt4")
    assert p.default_sampler == "zsobol" and p.heuristic == "power"
    assert [p.sampler("zsobol").spp(n) for n in (16, 100, 128, 1000)] == [16, 64, 128, 512]
    assert "xsamples\" [ 8 ] \"integer ysamples\" [ 4 ]" in p.snippet("map", "stratified", 32)
    assert p.strategy("mis").density == "compensated" and p.strategy("map").density == "plain"
    assert 'Integrator "path" "integer maxdepth" [ 1 ]' in p.snippet("mis")
    assert '"bool samplelights" [ false ]' in p.snippet("brdf")
    fr = pbrt_sphere_frame([[0.6, 0.0, 0.8]])[0]
    np.testing.assert_allclose(fr @ fr.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(fr[0], [0, 1, 0])         # dpdu ∝ (−n_y, n_x, 0)


@pytest.mark.parametrize("compensated", [True, False])
@pytest.mark.parametrize("fractions", [(0.5, 0.5), (0.0, 1.0)])
def test_compiled_bsdf_lookup_is_eval_and_the_power_heuristic(compensated, fractions):
    """The renderer model's compiled lookup (radiance and the BSDF sample's MIS weight at
    ``local @ frame``) equals the light's numpy eval, pdf and power_heuristic, the square's
    edges, the poles and the southern hemisphere included."""
    from oracles.numpy_kernels import bsdf_lookup_numpy, hemisphere_directions
    rng = np.random.default_rng(5)
    t = Pbrt4ImageInfiniteLight(EnvMap(rng.random((16, 32, 3)) * 4 - 0.5),
                                compensated=compensated)
    loc = hemisphere_directions(rng, 5000)
    for frame in (np.eye(3), np.linalg.qr(rng.normal(size=(3, 3)))[0]):
        rad, w = t.bsdf_lookup(loc, frame, *fractions)
        want_rad, want_w = bsdf_lookup_numpy(t, loc, frame, *fractions)
        np.testing.assert_allclose(rad, want_rad, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(w, want_w, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("compensated", [True, False])
def test_compiled_eval_pdf_is_eval_and_pdf(compensated):
    """The microfacet model's compiled lookup (radiance and the light's pdf at world
    directions, or at local ones with a frame's rows; 0 and 0 where skipped) equals the
    light's numpy eval and pdf over the whole sphere, the poles and axes included."""
    rng = np.random.default_rng(6)
    t = Pbrt4ImageInfiniteLight(EnvMap(rng.random((16, 32, 3)) * 4 - 0.5),
                                compensated=compensated)
    d = rng.standard_normal((5000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d[:4] = [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, -1, 0]]
    rad, pdf = t.eval_pdf(d)
    np.testing.assert_allclose(rad, t.eval(d), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(pdf, t.pdf(d), rtol=1e-9, atol=1e-12)
    rows = np.linalg.qr(rng.standard_normal((3, 3)))[0].T
    rad, pdf = t.eval_pdf(d, rows, skip=np.r_[0.0, np.ones(len(d) - 1)])
    np.testing.assert_allclose(rad[1:], t.eval(d @ rows)[1:], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(pdf[1:], t.pdf(d @ rows)[1:], rtol=1e-9, atol=1e-12)
    assert np.all(rad[0] == 0) and pdf[0] == 0
