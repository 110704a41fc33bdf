"""Tests for envfit.theory._bnot: periodic power diagrams, capacity weights, BNOT, spectra."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.spatial import HalfspaceIntersection, Voronoi

from envfit.theory import _bnot as bnot
from envfit.theory._bnot import (bnot_diagnostics, bnot_square, capacity_weights,
                                 min_toroidal_distance, radial_power_spectrum)
from envfit.theory._power_cells import power_diagram
from envfit.theory._errors import TheoryParameterError

TILES = np.array([(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1)], dtype=float)


def _polygon_area_centroid(v: np.ndarray):
    """Shoelace area and centroid of a convex polygon given in any order."""
    c = v.mean(0)
    v = v[np.argsort(np.arctan2(v[:, 1] - c[1], v[:, 0] - c[0]))] - c
    w = np.roll(v, -1, axis=0)
    cr = v[:, 0] * w[:, 1] - w[:, 0] * v[:, 1]
    a = cr.sum() / 2
    return a, c + ((v + w) * cr[:, None]).sum(0) / (6 * a)


def _brute_force_power_cells(x, w):
    """Each power cell as an intersection of half-planes against all 9n-1 copies."""
    n = len(x)
    areas, cents = np.zeros(n), np.zeros((n, 2))
    for i in range(n):
        q = (x[None] + TILES[:, None]).reshape(-1, 2)
        wq = np.tile(w, 9)
        keep = np.linalg.norm(q - x[i], axis=1) > 0
        q, wq = q[keep], wq[keep]
        # |p-x_i|^2 - w_i <= |p-q|^2 - w_q  <=>  2(q-x_i).p - (|q|^2-|x_i|^2-w_q+w_i) <= 0
        A = 2 * (q - x[i])
        b = -(np.sum(q * q, 1) - x[i] @ x[i] - wq + w[i])
        # Chebyshev centre (an interior point) by linear programming
        nrm = np.linalg.norm(A, axis=1)
        res = linprog([0, 0, -1], A_ub=np.column_stack([A, nrm]), b_ub=-b,
                      bounds=[(None, None), (None, None), (0, None)])
        if res.status == 2 or (res.status == 0 and res.x[2] < 1e-12):
            areas[i], cents[i] = 0.0, np.nan      # empty (hidden) cell
            continue
        assert res.status == 0
        hs = HalfspaceIntersection(np.column_stack([A, b]), res.x[:2])
        areas[i], cents[i] = _polygon_area_centroid(hs.intersections)
    return areas, cents


def _torus_dist(a, b):
    d = a - b
    d -= np.round(d)
    return np.linalg.norm(d, axis=-1)


# ----------------------------------------------------------------------------- diagrams
@pytest.mark.parametrize("n", [3, 7, 60, 400])
def test_zero_weight_power_diagram_is_periodic_voronoi(n):
    x = np.random.default_rng(n).random((n, 2))
    pd = power_diagram(x)
    vor = Voronoi((x[None] + TILES[:, None]).reshape(-1, 2))
    centre = 4 * n                       # tile (0, 0) is the 5th block
    ref_a, ref_c = np.zeros(n), np.zeros((n, 2))
    for i in range(n):
        verts = vor.vertices[vor.regions[vor.point_region[centre + i]]]
        ref_a[i], ref_c[i] = _polygon_area_centroid(verts)
    np.testing.assert_allclose(pd.areas, ref_a, atol=1e-13)
    assert _torus_dist(pd.centroids, ref_c).max() < 1e-12
    assert pd.areas.sum() == pytest.approx(1.0, abs=1e-13)


@pytest.mark.parametrize("n,scale,empty", [(5, 0.1, False), (80, 0.05, False),
                                           (25, 0.2, True), (80, 2.0, True)])
def test_weighted_power_diagram_matches_halfplane_intersection(n, scale, empty):
    rng = np.random.default_rng(100 + n)
    x = rng.random((n, 2))
    w = rng.normal(0, scale / n, n)
    pd = power_diagram(x, w)
    ref_a, ref_c = _brute_force_power_cells(pd.sites, pd.weights)
    assert (ref_a.min() == 0) == empty       # large weights hide some cells
    np.testing.assert_allclose(pd.areas, ref_a, atol=1e-12)
    full = ref_a > 0
    assert _torus_dist(pd.centroids[full], ref_c[full]).max() < 1e-10
    assert pd.areas.sum() == pytest.approx(1.0, abs=1e-13)
    for i in np.nonzero(full)[0][[0, -1]]:  # polygons are CCW with the right area
        v = pd.polygon(i)
        assert 0.5 * np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1]) \
            == pytest.approx(pd.areas[i], rel=1e-12)


def test_power_diagram_margin_certificate_and_periodicity():
    rng = np.random.default_rng(3)
    x = rng.random((300, 2))
    w = rng.normal(0, 1.0 / 300, 300)
    full = power_diagram(x, w, margin=1.0)
    thin = power_diagram(x, w, margin=0.02)      # certificate fails -> falls back
    auto = power_diagram(x, w)
    np.testing.assert_allclose(thin.areas, full.areas, atol=1e-14)
    np.testing.assert_allclose(auto.areas, full.areas, atol=1e-14)
    assert thin.margin == 1.0 and auto.margin < 1.0
    shifted = power_diagram(x + [0.37, 0.81], w)   # translation on the torus
    np.testing.assert_allclose(shifted.areas, full.areas, atol=1e-13)
    np.testing.assert_allclose(power_diagram(x, w + 5.0).areas, full.areas, atol=1e-13)


def test_area_jacobian_matches_finite_differences():
    rng = np.random.default_rng(7)
    n = 30
    x, w = rng.random((n, 2)), rng.normal(0, 0.3 / n, n)
    J = power_diagram(x, w).area_jacobian().toarray()
    h = 1e-7
    fd = np.empty((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        fd[:, j] = (power_diagram(x, w + e).areas - power_diagram(x, w - e).areas) / (2 * h)
    np.testing.assert_allclose(J, fd, atol=1e-6 * np.abs(J).max())
    np.testing.assert_allclose(J.sum(1), 0, atol=1e-12)
    np.testing.assert_allclose(J, J.T, atol=1e-12)


def test_capacity_weights_equalise_areas():
    x = np.random.default_rng(9).random((500, 2))
    w, pd = capacity_weights(x, tol=1e-12)
    assert np.max(np.abs(pd.areas * 500 - 1)) < 1e-12
    # an independent diagram at the returned weights agrees
    np.testing.assert_allclose(power_diagram(x, w, margin=1.0).areas, 1 / 500, rtol=1e-11)
    with pytest.raises(TheoryParameterError):
        capacity_weights(np.array([[0.1, 0.2], [0.1, 0.2], [0.5, 0.5]]))


# ----------------------------------------------------------------------------- BNOT
@pytest.fixture(scope="module")
def bnot256():
    return bnot_square(256, seed=0)


def test_bnot_capacity_constraint_and_lloyd_fixed_point(bnot256):
    x = bnot256
    assert x.shape == (256, 2) and x.min() >= 0 and x.max() < 1
    d = bnot_diagnostics(x)
    assert d.max_relative_area_error < 1e-4
    assert np.max(np.abs(d.areas * 256 - 1)) < 1e-4
    assert d.areas.sum() == pytest.approx(1.0, abs=1e-12)
    # sites sit (nearly) at the centroids of their capacity-constrained cells
    assert d.centroid_residual < 0.05
    r = bnot_diagnostics(np.random.default_rng(0).random((256, 2)))
    assert r.centroid_residual > 10 * d.centroid_residual


def test_bnot_spectrum_is_blue_and_points_well_separated(bnot256):
    n = 256
    rnd = np.random.default_rng(12).random((n, 2))
    rb, pb = radial_power_spectrum(bnot256)
    rr, pr = radial_power_spectrum(rnd)
    low_b = pb[rb < 0.5 * np.sqrt(n)].mean()
    low_r = pr[rr < 0.5 * np.sqrt(n)].mean()
    assert low_b < 0.2 and 0.5 < low_r < 1.5
    assert pb[rb < 0.7 * np.sqrt(n)].max() < 0.2
    assert pb.max() > 2.0                              # the blue-noise peak near √n
    assert abs(pb[rb > 2.5 * np.sqrt(n)].mean() - 1) < 0.25   # flat at high frequency
    db, dr = min_toroidal_distance(bnot256), min_toroidal_distance(rnd)
    assert db * np.sqrt(n) > 0.6 and db > 10 * dr


def test_bnot_is_seeded_and_small_n_work():
    bnot._bnot_cached.cache_clear()
    a = bnot_square(40, seed=5)
    bnot._bnot_cached.cache_clear()
    np.testing.assert_array_equal(a, bnot_square(40, seed=5))
    assert not np.allclose(a, bnot_square(40, seed=6))
    for n in (1, 2, 3):
        p = bnot_square(n, seed=1)
        assert p.shape == (n, 2) and p.min() >= 0 and p.max() < 1
        assert bnot_diagnostics(p).max_relative_area_error < 1e-8 if n > 1 else True
    with pytest.raises(TheoryParameterError):
        bnot_square(0)


# ----------------------------------------------------------------------------- analysis
def test_radial_spectrum_of_a_lattice_and_of_random_points():
    m = 16
    g = (np.arange(m) + 0.3) / m
    lat = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    r, p, cnt = radial_power_spectrum(lat, kmax=40, return_counts=True)
    # periodogram of the lattice: n at k ∈ (m Z)^2, 0 elsewhere
    k = np.arange(-40, 41)
    kx, ky = np.meshgrid(k, k, indexing="ij")
    rad = np.hypot(kx, ky)
    sel = (rad > 0) & (rad <= 40)
    b = np.floor(rad[sel] + 0.5).astype(int)
    hits = ((kx % m == 0) & (ky % m == 0))[sel]
    ref = np.bincount(b, weights=hits * float(m * m))[np.bincount(b) > 0]
    ref = ref / np.bincount(b)[np.bincount(b) > 0]
    np.testing.assert_allclose(p, ref, atol=1e-9)
    np.testing.assert_array_equal(cnt, np.bincount(b)[np.bincount(b) > 0])
    rr, pr = radial_power_spectrum(np.random.default_rng(2).random((400, 2)), kmax=40)
    assert abs(pr.mean() - 1) < 0.1


def test_min_toroidal_distance_matches_brute_force():
    x = np.random.default_rng(4).random((60, 2))
    d = _torus_dist(x[:, None], x[None])
    d[np.diag_indices(60)] = np.inf
    assert min_toroidal_distance(x) == pytest.approx(d.min(), rel=1e-12)
    assert min_toroidal_distance([[0.01, 0.5], [0.99, 0.5]]) == pytest.approx(0.02)
    assert min_toroidal_distance([[0.2, 0.3]]) == np.inf


def test_invalid_sites_raise():
    with pytest.raises(TheoryParameterError):
        power_diagram(np.zeros((4, 3)))
    with pytest.raises(TheoryParameterError):
        power_diagram([[np.nan, 0.1]])
    with pytest.raises(TheoryParameterError):
        power_diagram(np.random.default_rng(0).random((5, 2)), np.zeros(4))
