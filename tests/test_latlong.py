"""Tests of envfit.maps._latlong: the lat-long convention, solid angles, coordinates, bilinear lookup."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

import envfit.maps._latlong as ll
from envfit.base._errors import ParameterError


# -- angles and solid angles -------------------------------------------------------------
def test_pixel_angles_half_integer_centres():
    theta, phi = ll.pixel_angles(3)
    assert theta.shape == (3,) and phi.shape == (6,)
    np.testing.assert_allclose(theta, [np.pi / 6, np.pi / 2, 5 * np.pi / 6], rtol=0, atol=1e-15)
    np.testing.assert_allclose(phi, np.pi / 6 * np.array([1, 3, 5, 7, 9, 11]), rtol=0, atol=1e-15)
    _, phi = ll.pixel_angles(3, 5)
    assert phi.shape == (5,)
    np.testing.assert_allclose(phi[0], np.pi / 5, rtol=1e-15)


@pytest.mark.parametrize("bad", [(0, None), (-2, None), (4, 0), (2.5, None), ("a", None)])
def test_bad_sizes_raise(bad):
    with pytest.raises(ParameterError):
        ll.pixel_angles(*bad)


@pytest.mark.parametrize("h,w", [(1, 2), (2, 4), (3, 6), (7, 14), (64, 128), (1000, 2000),
                                 (4096, 8192), (5, 7)])
def test_solid_angles_sum_to_4pi(h, w):
    if h * w <= 2_000_000:
        om = ll.pixel_solid_angles(h, w)
        assert om.shape == (h, w)
        assert abs(om.sum() - 4 * np.pi) < 1e-12
    assert abs(w * ll.row_solid_angles(h, w).sum() - 4 * np.pi) < 1e-12


@pytest.mark.parametrize("h", [1, 4, 33, 500])
def test_row_solid_angles_match_difference_of_cosines(h):
    # direct definition Δφ (cos θ_top − cos θ_bottom) with edge angles π i / H
    w = 2 * h
    edges = np.pi * np.arange(h + 1) / h
    direct = (2 * np.pi / w) * (np.cos(edges[:-1]) - np.cos(edges[1:]))
    np.testing.assert_allclose(ll.row_solid_angles(h), direct, rtol=1e-12, atol=1e-17)


def test_row_solid_angles_match_quadrature():
    # ∫_{θt}^{θb} sin θ dθ by Gauss-Legendre, an independent integration
    h, w = 9, 18
    x, wq = np.polynomial.legendre.leggauss(20)
    for i in range(h):
        a, b = np.pi * i / h, np.pi * (i + 1) / h
        t = 0.5 * (b - a) * x + 0.5 * (a + b)
        integral = 0.5 * (b - a) * np.sum(wq * np.sin(t)) * 2 * np.pi / w
        assert abs(ll.row_solid_angles(h, w)[i] - integral) < 1e-15


# -- frames and directions ---------------------------------------------------------------
def test_local_to_world_orthogonal_and_bad_up():
    for up in ll.UPS:
        m = ll.local_to_world(up)
        np.testing.assert_allclose(m @ m.T, np.eye(3), atol=0)
    assert abs(np.linalg.det(ll.local_to_world("y")) + 1) < 1e-15
    np.testing.assert_array_equal(ll.local_to_world("z"), np.eye(3))
    for bad in ("Y", "w", None, 3):
        with pytest.raises(ParameterError):
            ll.local_to_world(bad)
    with pytest.raises(ParameterError):
        ll.pixel_directions(4, up="-y")


def test_up_y_matches_openexr_latlong():
    # OpenEXR ImfEnvmap LatLong::direction: (sin lon cos lat, sin lat, cos lon cos lat) with
    # latitude = π/2 − θ (top = +π/2) and longitude = π − φ (left = +π).
    h, w = 6, 12
    theta, phi = ll.pixel_angles(h, w)
    lat = np.pi / 2 - theta[:, None]
    lon = np.pi - phi[None, :]
    exr = np.stack(np.broadcast_arrays(np.sin(lon) * np.cos(lat), np.sin(lat),
                                       np.cos(lon) * np.cos(lat)), axis=-1)
    np.testing.assert_allclose(ll.pixel_directions(h, w, up="y"), exr, atol=1e-15)
    # and the documented formula
    t, p = theta[:, None], phi[None, :]
    doc = np.stack(np.broadcast_arrays(np.sin(t) * np.sin(p), np.cos(t), -np.sin(t) * np.cos(p)),
                   axis=-1)
    np.testing.assert_allclose(ll.pixel_directions(h, w), doc, atol=1e-15)


def test_up_z_and_x_frames():
    h = 5
    theta, phi = ll.pixel_angles(h)
    t, p = theta[:, None], phi[None, :]
    z = np.stack(np.broadcast_arrays(np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)), -1)
    np.testing.assert_allclose(ll.pixel_directions(h, up="z"), z, atol=1e-15)
    x = ll.pixel_directions(h, up="x")
    np.testing.assert_allclose(x[..., 0], np.cos(t) + 0 * p, atol=1e-15)   # world x = local z
    # top row is near each frame's up axis
    for up, axis in (("y", 1), ("z", 2), ("x", 0)):
        assert np.all(ll.pixel_directions(h, up=up)[0, :, axis] > np.cos(np.pi / h))


@pytest.mark.parametrize("up", ll.UPS)
def test_directions_are_unit(up):
    d = ll.pixel_directions(37, up=up)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, rtol=0, atol=2e-16 * 4)


@pytest.mark.parametrize("up", ll.UPS)
def test_pixel_direction_pixel_round_trip(up):
    h, w = 16, 32
    rng = np.random.default_rng(1)
    row = rng.uniform(-0.5, h - 0.5, 1000)
    col = rng.uniform(-0.5, w - 0.5, 1000)
    d = ll.pixel_to_direction(row, col, h, w, up=up)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-15)
    r2, c2 = ll.direction_to_pixel(3.7 * d, h, w, up=up)        # length does not matter
    np.testing.assert_allclose(r2, row, atol=1e-11)
    np.testing.assert_allclose(c2, col, atol=1e-11)
    # integer grid = pixel centres
    r, c = ll.direction_to_pixel(ll.pixel_directions(h, w, up=up), h, w, up=up)
    np.testing.assert_allclose(r, np.arange(h)[:, None] + 0 * c, atol=1e-11)
    np.testing.assert_allclose(c, np.arange(w)[None, :] + 0 * r, atol=1e-11)


def test_direction_to_pixel_wraps_and_ranges():
    h, w = 8, 16
    r, c = ll.direction_to_pixel(ll.pixel_to_direction(3.0, w - 0.5 + 0.25, h, w), h, w)
    assert abs(c - (-0.25)) < 1e-12 and abs(r - 3.0) < 1e-12
    rng = np.random.default_rng(2)
    r, c = ll.direction_to_pixel(rng.normal(size=(5000, 3)), h, w)
    assert r.min() >= -0.5 and r.max() <= h - 0.5
    assert c.min() >= -0.5 and c.max() < w - 0.5
    # poles and the zero vector
    r, c = ll.direction_to_pixel(np.array([[0, 1, 0], [0, -1, 0], [0, 0, 0]], float), h, w)
    np.testing.assert_allclose(r, [-0.5, h - 0.5, -0.5], atol=1e-15)
    with pytest.raises(ParameterError):
        ll.direction_to_pixel([np.nan, 0, 1], h, w)
    with pytest.raises(ParameterError):
        ll.direction_to_pixel(np.zeros((4, 2)), h, w)


def test_pixel_to_direction_continues_over_pole():
    # row −1 − r at φ is the same point as row r at φ + π
    h, w = 8, 16
    a = ll.pixel_to_direction(-1 - 0.3, 2.0, h, w)
    b = ll.pixel_to_direction(0.3, 2.0 + w / 2, h, w)
    np.testing.assert_allclose(a, b, atol=1e-15)


# -- bilinear lookup ---------------------------------------------------------------------
def _smooth(d):
    """A smooth function on the sphere, 3 channels."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([np.exp(0.7 * x - 0.4 * y + 0.2 * z), x * y + z, np.cos(2 * y + x * z)], -1)


def _reference_bilinear(img, dirs, up):
    """Independent implementation: RegularGridInterpolator on a padded grid
    (wrap in longitude, rows −1 and H = rows 0 and H−1 shifted by W/2)."""
    h, w, c = img.shape
    top = np.roll(img[:1], w // 2, axis=1)
    bot = np.roll(img[-1:], w // 2, axis=1)
    ext = np.concatenate([top, img, bot], axis=0)
    ext = np.concatenate([ext[:, -1:], ext, ext[:, :1]], axis=1)
    grid = (np.arange(-1, h + 1, dtype=float), np.arange(-1, w + 1, dtype=float))
    interp = RegularGridInterpolator(grid, ext, method="linear")
    r, col = ll.direction_to_pixel(dirs, h, w, up=up)
    return interp(np.stack([r, col], -1))


@pytest.mark.parametrize("up", ll.UPS)
def test_lookup_exact_at_pixel_centres(up):
    h = 24
    img = _smooth(ll.pixel_directions(h, up=up))
    got = ll.bilinear_lookup(img, ll.pixel_directions(h, up=up), up=up)
    np.testing.assert_array_equal(got, img)
    f32 = img.astype(np.float32)
    np.testing.assert_array_equal(ll.bilinear_lookup(f32, ll.pixel_directions(h, up=up), up=up),
                                  f32.astype(np.float64))


@pytest.mark.parametrize("up", ll.UPS)
def test_lookup_matches_independent_bilinear(up):
    h = 10
    rng = np.random.default_rng(3)
    img = rng.random((h, 2 * h, 2))
    d = rng.normal(size=(4000, 3))
    # add directions very close to both poles and to the seam
    pole = ll.local_to_world(up) @ np.array([0.0, 0.0, 1.0])
    d[:500] = pole + 0.05 * rng.normal(size=(500, 3))
    d[500:1000] = -pole + 0.05 * rng.normal(size=(500, 3))
    seam = ll.pixel_to_direction(rng.uniform(-0.5, h - 0.5, 500), -0.5 + rng.normal(0, 0.1, 500),
                                 h, up=up)
    d[1000:1500] = seam
    np.testing.assert_allclose(ll.bilinear_lookup(img, d, up=up), _reference_bilinear(img, d, up),
                               rtol=0, atol=1e-12)


def test_lookup_second_order_accurate():
    rng = np.random.default_rng(4)
    d = rng.normal(size=(20000, 3))
    exact = _smooth(d / np.linalg.norm(d, axis=-1, keepdims=True))
    errs = []
    for h in (32, 64, 128):
        img = _smooth(ll.pixel_directions(h))
        errs.append(np.abs(ll.bilinear_lookup(img, d) - exact).max())
    assert errs[-1] < 2e-3
    # O(h²): halving h divides the error by ~4
    assert errs[0] / errs[1] > 3.0 and errs[1] / errs[2] > 3.0


def test_lookup_continuous_over_pole_and_seam():
    h = 16
    rng = np.random.default_rng(5)
    img = rng.random((h, 2 * h, 3))
    eps = 1e-9
    # along a great circle through the up pole (+y): crossing it is continuous
    for phi in rng.uniform(0, 2 * np.pi, 5):
        e = np.array([np.sin(phi), 0.0, -np.cos(phi)])
        up = np.array([0.0, 1.0, 0.0])
        a = ll.bilinear_lookup(img, np.cos(eps) * up + np.sin(eps) * e)
        b = ll.bilinear_lookup(img, np.cos(eps) * up - np.sin(eps) * e)
        np.testing.assert_allclose(a, b, atol=1e-6)
        a = ll.bilinear_lookup(img, -np.cos(eps) * up + np.sin(eps) * e)
        b = ll.bilinear_lookup(img, -np.cos(eps) * up - np.sin(eps) * e)
        np.testing.assert_allclose(a, b, atol=1e-6)
    # at the pole row coordinate −½ the value is the mean of row 0 at φ and φ + π
    d = ll.pixel_to_direction(-0.5 + 1e-12, 3.0, h)
    np.testing.assert_allclose(ll.bilinear_lookup(img, d), 0.5 * (img[0, 3] + img[0, 3 + h]),
                               atol=1e-9)
    # across the longitude seam (col −½ ≡ W − ½)
    for row in (0.0, 3.3, h - 1.0):
        a = ll.bilinear_lookup(img, ll.pixel_to_direction(row, -0.5 + 1e-10, h))
        b = ll.bilinear_lookup(img, ll.pixel_to_direction(row, 2 * h - 0.5 - 1e-10, h))
        np.testing.assert_allclose(a, b, atol=1e-8)
    # the seam value is the average of the first and last column
    a = ll.bilinear_lookup(img, ll.pixel_to_direction(2.0, -0.5, h))
    np.testing.assert_allclose(a, 0.5 * (img[2, 0] + img[2, -1]), atol=1e-12)


def test_lookup_blocking_shapes_and_2d(monkeypatch):
    h = 8
    rng = np.random.default_rng(6)
    img = rng.random((h, 2 * h, 3))
    d = rng.normal(size=(5, 7, 3))
    full = ll.bilinear_lookup(img, d)
    assert full.shape == (5, 7, 3)
    monkeypatch.setattr(ll, "LOOKUP_BLOCK", 4)
    np.testing.assert_array_equal(ll.bilinear_lookup(img, d), full)
    g = ll.bilinear_lookup(img[..., 1], d)
    assert g.shape == (5, 7)
    np.testing.assert_array_equal(g, full[..., 1])
    with pytest.raises(ParameterError):
        ll.bilinear_lookup(img, np.full((2, 3), np.inf))
    with pytest.raises(ParameterError):
        ll.bilinear_lookup(np.zeros(5), d)
