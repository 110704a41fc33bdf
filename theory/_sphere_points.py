r"""Point sets on the whole sphere, used to sample environment maps (Table 2, fitting s).

- Spherical Fibonacci (Hannay & Nye 2004; Marques et al. 2013):
  :math:`z_j = 1 - (2j+1)/N`, :math:`\phi_j = 2\pi\,\mathrm{frac}(j/\Phi)`, j = 0…N−1,
  Φ the golden ratio. Equal-area, deterministic, no two points coincide.
- Uniform random points (normalised Gaussian vectors), seeded.

Points are unit vectors in the map's *local* frame (z = up); for lat-long maps that is the
frame of :mod:`envfit.maps._latlong` before its fixed local→world matrix.
"""
from __future__ import annotations

import numpy as np

from envfit.theory._errors import TheoryParameterError

__all__ = ["spherical_fibonacci_sphere", "random_sphere", "sphere_points", "SPHERE_POINTSETS"]

GOLDEN_RATIO = (1.0 + 5.0 ** 0.5) / 2.0
SPHERE_POINTSETS = ("sf", "random")


def _check_n(n) -> int:
    n = int(n)
    if n < 1:
        raise TheoryParameterError(f"number of points must be >= 1, got {n}")
    return n


def spherical_fibonacci_sphere(n: int) -> np.ndarray:
    r"""N spherical Fibonacci points on the whole sphere, (N, 3).

    >>> p = spherical_fibonacci_sphere(4); p.shape
    (4, 3)
    """
    n = _check_n(n)
    j = np.arange(n, dtype=np.float64)
    z = 1.0 - (2.0 * j + 1.0) / n
    # frac(j / Φ) computed as j*(Φ-1) mod 1 keeps precision for large j
    phi = 2.0 * np.pi * np.mod(j * (GOLDEN_RATIO - 1.0), 1.0)
    r = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def random_sphere(n: int, *, seed=None) -> np.ndarray:
    """N independent uniform points on the sphere (normalised standard normal vectors)."""
    n = _check_n(n)
    rng = np.random.default_rng(seed)
    v = rng.standard_normal((n, 3))
    norm = np.linalg.norm(v, axis=1, keepdims=True)
    # a zero vector has probability zero; guard anyway
    bad = norm[:, 0] < 1e-300
    if np.any(bad):  # pragma: no cover
        v[bad] = (0.0, 0.0, 1.0)
        norm[bad] = 1.0
    return v / norm


def sphere_points(name: str, n: int, *, seed=None) -> np.ndarray:
    """Dispatch by name: ``"sf"`` (spherical Fibonacci, default) or ``"random"``."""
    if name == "sf":
        return spherical_fibonacci_sphere(n)
    if name == "random":
        return random_sphere(n, seed=seed)
    raise TheoryParameterError(f"unknown sphere point set {name!r}; choose one of {SPHERE_POINTSETS}")
