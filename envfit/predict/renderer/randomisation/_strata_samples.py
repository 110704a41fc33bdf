r"""Correlated multi-jittered and orthogonal-array point sets drawn, for the N whose fine cells
(1/N × 1/N) no affordable grid resolves: the MSE as the variance over Q independent draws.

The exact models (:mod:`._cmj`, :mod:`._orthogonal`) sum over the N × N fine cells of the
integrand's grid, so they hold to N = M (the grid's cells a side) and cost O(N²); a renderer's
answer at 1 % often needs thousands of spp. Above that reach the renderer model draws the
sampler's own law instead — the same construction as the exact models' docstrings, with the
permutations drawn (uniformly at random, or by the sampler's hash at uniformly random 32-bit
seeds: :attr:`~envfit.renderers.PermutationLaw.permute`) and fresh uniform jitter — evaluates
the integrand at the Q·N points and takes, per channel,

.. math::  \widehat{\mathrm{MSE}}(N) = \frac1{Q-1}\sum_{q=1}^{Q}\big(F_q - \bar F\big)^2,
           \qquad F_q = \frac1N\sum_{i=1}^{N} h(u_{q,i}),

unbiased for :math:`\mathrm{Var}\,F = E(F - I)^2` (the samplers are unbiased: each point is
uniform on the square), with relative standard error :math:`\approx\sqrt{2/(Q-1)}` per
integrand. :func:`sampled_strata_mse` also returns the per-draw terms
:math:`z_q = \frac{Q}{Q-1}(F_q - \bar F)^2` (their mean is the estimate), so that the
renderer model adds them over its normals draw by draw (the same Q draws at every normal:
:func:`envfit.predict.renderer._model_error.draws_error`).

The exact models are the check: at an N both reach, the sampled MSE equals theirs within its
standard error (``tests/test_randomisation_strata_samples.py``).

Reference: A. Kensler, "Correlated Multi-Jittered Sampling", Pixar Technical Memo 13-01 (2013);
W. Jarosz et al., "Orthogonal Array Sampling for Monte Carlo Rendering", CGF 38(4) (2019);
A. B. Owen, *Monte Carlo theory, methods and examples* (2013), §2.3 (the sample variance).
"""
from __future__ import annotations

import numpy as np

from envfit.base import ParameterError

from ._cmj import _shape
from ._orthogonal import _prime_root, bose_indices

__all__ = ["STRATA_SAMPLED", "ALWAYS_DRAWN", "cmj_points", "orthogonal_points",
           "strata_points", "sampled_strata_mse", "sampled_mse"]

#: the randomisations whose point sets are drawn above their exact model's reach
STRATA_SAMPLED = ("cmj", "orthogonal", "shared_sequence")
#: those drawn at every N (no exact model: :mod:`._shared_sequence`)
ALWAYS_DRAWN = ("shared_sequence",)


def _permutations(length: int, draws: int, rng: np.random.Generator, law) -> np.ndarray:
    """``draws`` permutations of {0, …, length − 1} (draws, length): uniformly random, or by
    ``law.permute(index, length, seeds)`` at uniformly random 32-bit seeds."""
    if law == "uniform":
        return np.argsort(rng.random((draws, length)), axis=1)
    permute = getattr(law, "permute", None)
    if permute is None:
        raise ParameterError(f"the permutation law {getattr(law, 'name', law)!r} cannot be "
                             f"drawn (it has no permute)")
    seeds = rng.integers(0, 1 << 32, size=(draws, 1), dtype=np.uint64).astype(np.uint32)
    return np.asarray(permute(np.arange(length)[None, :], length, seeds), dtype=np.int64)


def cmj_points(n: int, draws: int, rng: np.random.Generator, *, nx: int | None = None,
               ny: int | None = None, permutations="uniform") -> np.ndarray:
    r"""``draws`` correlated multi-jittered sets of N = nx·ny points (draws, N, 2): coarse cell
    (x, y) holds :math:`\big((x + (\sigma_y(y) + j_x)/n_y)/n_x,\ (y + (\sigma_x(x) + j_y)/n_x)/
    n_y\big)` (:mod:`._cmj`'s construction), σ_x, σ_y drawn per set by ``permutations``.

    >>> u = cmj_points(16, 3, np.random.default_rng(0))
    >>> u.shape, bool(np.all(np.sort(np.floor(u[0, :, 0] * 16)) == np.arange(16)))
    ((3, 16, 2), True)
    """
    nx, ny = _shape(int(n), nx, ny)
    sx = _permutations(nx, draws, rng, permutations)                 # (Q, nx)
    sy = _permutations(ny, draws, rng, permutations)                 # (Q, ny)
    x = np.arange(nx)[None, :, None]
    y = np.arange(ny)[None, None, :]
    u1 = (x + (sy[:, None, :] + rng.random((draws, nx, ny))) / ny) / nx
    u2 = (y + (sx[:, :, None] + rng.random((draws, nx, ny))) / nx) / ny
    return np.stack([u1, u2], axis=-1).reshape(draws, nx * ny, 2)


def orthogonal_points(n: int, draws: int, rng: np.random.Generator, *,
                      dimension: int = 2) -> np.ndarray:
    r"""``draws`` sets of a Bose orthogonal array's 2-D draw at dimensions (``dimension``,
    ``dimension`` + 1), N = p² points (draws, N, 2): sample i uniform in the fine cell
    :math:`(\pi_1(A)p + \pi_2(B),\ \pi_3(C)p + \pi_4(D))` of its forms (A, B, C, D)
    (:func:`._orthogonal.bose_indices`), four uniformly random permutations per set.

    >>> u = orthogonal_points(9, 2, np.random.default_rng(0))
    >>> u.shape, bool(np.all(np.sort(np.floor(u[1, :, 1] * 9)) == np.arange(9)))
    ((2, 9, 2), True)
    """
    p = _prime_root(int(n))
    t = bose_indices(p, dimension)                                   # (N, 4)
    pi = np.stack([_permutations(p, draws, rng, "uniform") for _ in range(4)], axis=1)
    rows = np.arange(draws)[:, None]
    fx = pi[:, 0][rows, t[None, :, 0]] * p + pi[:, 1][rows, t[None, :, 1]]
    fy = pi[:, 2][rows, t[None, :, 2]] * p + pi[:, 3][rows, t[None, :, 3]]
    jitter = rng.random((draws, p * p, 2))
    return (np.stack([fx, fy], axis=-1) + jitter) / float(p * p)


def strata_points(name: str, n: int, draws: int, seed: int, **options) -> np.ndarray:
    """``draws`` point sets of randomisation ``name`` (:data:`STRATA_SAMPLED`) with its
    registry options (``nx``, ``ny``, ``permutations`` of ``cmj``; ``dimension`` of
    ``orthogonal``; ``points`` and ``stream`` of ``shared_sequence``: the sampler's runs),
    drawn by ``numpy.random.default_rng(seed)``."""
    if name not in STRATA_SAMPLED:
        raise ParameterError(f"no drawn point sets of {name!r}: one of {STRATA_SAMPLED}")
    if int(draws) < 2:
        raise ParameterError(f"draws must be at least 2 (a sample variance), got {draws!r}")
    rng = np.random.default_rng(seed)
    if name == "cmj":
        return cmj_points(n, int(draws), rng, **options)
    if name == "shared_sequence":
        return options["points"].points(int(n), int(draws), rng, options.get("stream", "light"))
    return orthogonal_points(n, int(draws), rng, **options)


def sampled_mse(means: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`sampled_strata_mse` from the draws' estimates :math:`F_q` (Q, C).

    >>> mse, z = sampled_mse(np.array([[1.0], [2.0]]))
    >>> float(mse[0]), z.tolist()
    (0.5, [0.5, 0.5])
    """
    f = np.asarray(means, dtype=np.float64)
    q = f.shape[0]
    dev2 = (f - f.mean(axis=0)) ** 2 * (q / (q - 1.0))
    return dev2.mean(axis=0), dev2.mean(axis=1)


def sampled_strata_mse(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""(the sample variance of the draws' means per channel (C,), the per-draw terms
    :math:`z_q` averaged over channels (Q,)) of the integrand's ``values`` (Q, N, C) at
    :func:`strata_points` (module docstring).

    >>> v = np.array([[[0.0], [2.0]], [[2.0], [2.0]]])          # draws' means 1 and 2
    >>> mse, z = sampled_strata_mse(v)
    >>> float(mse[0]), z.tolist()
    (0.5, [0.5, 0.5])
    """
    return sampled_mse(np.asarray(values, dtype=np.float64).mean(axis=1))
