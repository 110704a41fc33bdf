import numpy as np
import pytest

from envfit.theory._errors import TheoryParameterError
from envfit.theory._sphere_points import random_sphere, sphere_points, spherical_fibonacci_sphere


def test_fibonacci_is_unit_and_equal_area():
    p = spherical_fibonacci_sphere(10_000)
    np.testing.assert_allclose(np.linalg.norm(p, axis=1), 1.0, atol=1e-14)
    # equal-area in z: each z-band of equal height holds the same number of points
    counts, _ = np.histogram(p[:, 2], bins=20, range=(-1, 1))
    assert counts.min() == counts.max() == 500
    # integrates low-degree polynomials well: mean of x, y, z ~ 0, mean of z^2 = 1/3
    assert np.abs(p.mean(axis=0)).max() < 1e-3
    assert np.mean(p[:, 2] ** 2) == pytest.approx(1 / 3, abs=1e-6)


def test_fibonacci_has_no_close_pairs():
    from scipy.spatial import cKDTree
    n = 4000
    p = spherical_fibonacci_sphere(n)
    d, _ = cKDTree(p).query(p, k=2)
    # nearest-neighbour distance ~ sqrt(4π/N); for random points the minimum is far smaller
    assert d[:, 1].min() > 0.5 * np.sqrt(4 * np.pi / n)
    q = random_sphere(n, seed=0)
    dq, _ = cKDTree(q).query(q, k=2)
    assert dq[:, 1].min() < 0.2 * np.sqrt(4 * np.pi / n)


def test_random_is_seeded_and_uniform():
    a = random_sphere(20_000, seed=3)
    b = random_sphere(20_000, seed=3)
    c = random_sphere(20_000, seed=4)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    # mean of z^2 = 1/3 within ~4 standard errors (Var z^2 = 4/45)
    assert abs(np.mean(a[:, 2] ** 2) - 1 / 3) < 4 * np.sqrt(4 / 45 / 20_000)


def test_dispatch_and_errors():
    assert sphere_points("sf", 5).shape == (5, 3)
    with pytest.raises(TheoryParameterError):
        sphere_points("bogus", 5)
    with pytest.raises(TheoryParameterError):
        spherical_fibonacci_sphere(0)
