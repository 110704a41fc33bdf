r"""One fixed scrambled sequence shared by every pixel, each pixel a run of it: the MSE as the
variance over the runs of random pixels.

Some samplers do not randomise a pixel's points independently of the others: they scramble
*one* low-discrepancy sequence once, with a fixed seed, and give pixel p the N consecutive
indices starting at p·N (the pixels' order along the sequence is what makes the image's
noise blue). A pixel's estimate is random only through *which* run it takes. At N = 2^m a run
aligned on a multiple of N is a (0, m, 2)-net digitally shifted by the run's high index bits,
seen through the fixed scramble, so its error is neither Owen's (an independent nested
scramble per pixel, :mod:`._owen`) nor the digital shift's (:mod:`._digital_shift`): the
fixed scramble's top levels pair the strata the same way in every pixel, for better or for
worse by the integrand. At other N the run straddles aligned blocks — a union of smaller nets.
No closed form covers a fixed scramble, so the law is drawn: Q runs of uniformly random
pixels, the sampler's own points (the option ``points``: an object whose ``step(n)`` is the
spacing of the N-point pixels' run starts and whose ``runs(step, length, draws, rng,
stream)`` gives Q runs, (Q, L, 2); which sampler is whose, the renderer's folder says), and
per channel

.. math::  \widehat{\mathrm{MSE}}(N) = \frac1{Q-1}\sum_{q=1}^{Q}\big(F_q - \bar F\big)^2,
           \qquad F_q = \frac1N\sum_{i=1}^{N} h(u_{q,i}),

unbiased for :math:`E(F - I)^2` when the runs' points are uniform over the square taken over
all pixels (the union of all runs is the whole sequence; :mod:`._strata_samples` has the same
estimator and its standard error). The renderer model evaluates its integrand at the points
(``envfit.predict.renderer._drawn_strata``); :func:`shared_sequence_mse` evaluates a grid's
cell means there and adds the within-cell variance / N (below the grid the sequence's deeper
digits are scrambled by hashes of the higher ones, which make points in different cells
practically independent there).

The check (``tests/test_randomisation_shared_sequence.py``): with each pixel's scramble seeded
at random instead (the same code, a per-pixel seed) the drawn MSE equals Owen's exact one; with
the fixed seed it does not.

References: A. G. M. Ahmed, P. Wonka, "Screen-space blue-noise diffusion of Monte Carlo
sampling error via hierarchical ordering of pixels", ACM TOG 39(6) (2020); B. Burley,
"Practical hash-based Owen scrambling", JCGT 9(4) (2020); the renderers' folders cite the
source they read.
"""
from __future__ import annotations

import functools

import numpy as np

from envfit.base import ParameterError

from ._grid import DyadicGrid, RandomisedMSE, make_result

__all__ = ["shared_sequence_mse", "SHARED_POINTS"]

#: the integrand points per stream the drawn MSE evaluates (Q·N, at least 16 runs)
SHARED_POINTS = 1 << 16


def _cell_values(grid: DyadicGrid, u: np.ndarray) -> np.ndarray:
    """The grid's cell means (C, …) at points u (…, 2), as (…, C)."""
    m = grid.size
    i = np.minimum((u[..., 0] * m).astype(np.int64), m - 1)
    j = np.minimum((u[..., 1] * m).astype(np.int64), m - 1)
    return np.moveaxis(grid.mean[:, i, j], 0, -1)


@functools.lru_cache(maxsize=64)
def _runs(points, step: int, length: int, draws: int, seed: int, stream: str) -> np.ndarray:
    """The sampler's ``draws`` runs of ``length`` points (read-only; the same for every grid a
    model asks at these N: the frames' and normals' integrands)."""
    u = points.runs(step, length, draws, np.random.default_rng(seed), stream)
    u.flags.writeable = False
    return u


def shared_sequence_mse(grid: DyadicGrid, n: int, *, points, stream: str = "light",
                        draws: int | None = None, seed: int = 0) -> RandomisedMSE:
    """The MSE of N points of one request (``stream``) of a shared-sequence sampler (module
    docstring) on the grid's integrand: the variance over ``draws`` runs (default
    max(16, 2^16 // L)) of the cell means at the sampler's points, plus the within-cell
    variance / N; the runs, L = the power of two at least N long, start where the sampler's
    N-point pixels start (``points.step(n)``: their spacing) and serve every N of that
    spacing up to L (their prefixes; drawn once, by ``numpy.random.default_rng(seed)``), so
    ``exact`` is False and the note gives Q. ``points`` gives ``step(n)`` and
    ``runs(step, length, draws, rng, stream)`` (Q, L, 2)."""
    if not (callable(getattr(points, "runs", None)) and callable(getattr(points, "step", None))):
        raise ParameterError("points must give the sampler's runs (an object with step(n) "
                             "and runs(step, length, draws, rng, stream))")
    n = int(n)
    length = 1 << (n - 1).bit_length()
    q = int(draws) if draws is not None else max(16, SHARED_POINTS // length)
    if q < 2:
        raise ParameterError(f"draws must be at least 2 (a sample variance), got {draws!r}")
    step = int(points.step(n))
    key = ("shared_sequence", points, stream, step, length, q, int(seed))
    if key not in grid.sampled:             # the runs' prefix sums serve every N of the class
        u = _runs(points, step, length, q, int(seed), stream)
        grid.sampled[key] = np.cumsum(_cell_values(grid, u), axis=1)
    f = grid.sampled[key][:, n - 1] / n                              # (Q, C)
    resolved = f.var(axis=0, ddof=1)
    return make_result("shared_sequence", n, resolved, grid.above / n, exact=False,
                       note=f"variance over {q} runs of random pixels")
