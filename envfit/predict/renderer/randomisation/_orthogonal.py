r"""Orthogonal-array sampling (Jarosz, Enayet, Kensler, Kilpatrick, Christensen 2019), the Bose
construction of strength 2 with permuted strata and jitter: the exact MSE of one 2-D draw over
uniformly random permutations and jitter (which renderer's sampler builds it so, read from
which source, its folder says).

Construction: N = p² samples, p prime; sample i (after one shared permutation of the index,
which only reorders) is the pair :math:`(a_0, a_1) = (\lfloor i/p\rfloor, i \bmod p)`.
Dimension j takes the linear forms

.. math::  a_{ij} = a_0 + (j - 1)\,a_1,\qquad a_{ik} = a_0 + (k - 1)\,a_1 \pmod p,\qquad
           k = j - 1 \text{ (j odd)},\; j + 1 \text{ (j even)},

with :math:`(a_{ij}, a_{ik}) = (a_0, a_1)` at j = 0 and :math:`(a_1, a_0)` at j = 1, and returns
:math:`\big(\pi_j(a_{ij}) + (\pi'_j(a_{ik}) + \xi)/p\big)/p` — stratum and sub-stratum each
permuted by a per-pixel, per-dimension permutation, ξ fresh uniform jitter. A 2-D draw is
two consecutive 1-D ones, so a 2-D draw at dimensions (j, j + 1) puts
sample (a₀, a₁) uniformly in the fine cell (1/N × 1/N)

.. math::  \big(\pi_1(A)\,p + \pi_2(B),\; \pi_3(C)\,p + \pi_4(D)\big),

:math:`(A, B, C, D)` the four forms of that sample (:func:`bose_indices`). At an even j the
forms are (A, B, B, A): Kensler's correlated multi-jittering on a p × p grid (:mod:`._cmj`);
at an odd j they are four different forms, a pattern CMJ is not.

Exact MSE over four independent uniformly random permutations (the formula of :mod:`._cmj`,
generalised to any tuples): for two samples whose tuples are equal exactly on the axes S, the
pair of fine cells is uniform over the index pairs equal exactly on S, so with
:math:`G[X, b, Y, a]` the mean of h − I over fine cell (X p + b, Y p + a), W its within-cell
variance,

.. math::  E(F - I)^2 = \frac1{N^2}\Big[\sum_{S} n_S\,\frac{R_S}{c_S} + N\,\bar W\Big],
           \qquad c_S = \prod_{\text{axes}} \begin{cases}p & \in S\\ p(p-1) & \notin S
           \end{cases},

:math:`n_S` the ordered sample pairs (a sample with itself included) with pattern S, and
:math:`R_S` the sum of G·G' over the index pairs equal exactly on S (inclusion–exclusion over
marginals of G, ``_cmj._restricted``).

A sampler's hashed permutations need not be uniform; the tests measure the difference on a
renderer's own points (``tests/test_randomisation_orthogonal.py``).

Two streams (the emitter's 2-D draw and the BSDF's) are columns of the same array but their
dimensions' permutations are drawn independently, so given every permutation and jitter of the
emitter's dimensions each BSDF point is still uniform on the square: the cross term of MIS is
0 (:mod:`._mis`, independent streams).

Reference: W. Jarosz, A. Enayet, A. Kensler, C. Kilpatrick, P. Christensen, "Orthogonal Array
Sampling for Monte Carlo Rendering", Computer Graphics Forum 38(4) (EGSR 2019), §4 (Bose
construction, "MJ-style" offsets).
"""
from __future__ import annotations

import numpy as np

from envfit.base import ParameterError

from ._cmj import _restricted
from ._grid import DyadicGrid, RandomisedMSE, make_result
from ._strata import rectangle_moments

__all__ = ["bose_indices", "orthogonal_mse", "strata_tuples_mse"]

_AXES = ("x", "b", "y", "a")            # as _cmj: column, sub-column, row, sub-row


def _prime_root(n: int) -> int:
    p = int(round(np.sqrt(n)))
    if p < 2 or p * p != n or any(p % q == 0 for q in range(2, int(np.sqrt(p)) + 1)):
        raise ParameterError(f"an orthogonal array of strength 2 takes N = p² points, p prime "
                             f"(a sampler of such arrays rounds its spp up to one); got N = {n}")
    return p


def _forms(a0: np.ndarray, a1: np.ndarray, j: int, p: int) -> tuple[np.ndarray, np.ndarray]:
    """(a_ij, a_ik) of dimension j (``OrthogonalSampler::bose``)."""
    if j == 0:
        return a0, a1
    if j == 1:
        return a1, a0
    k = j - 1 if j % 2 else j + 1
    return (a0 + (j - 1) * a1) % p, (a0 + (k - 1) * a1) % p


def bose_indices(p: int, dimension: int) -> np.ndarray:
    """The forms (A, B, C, D) (N, 4) of the p² samples of a 2-D draw at dimensions
    (``dimension``, ``dimension`` + 1): x stratum, x sub-stratum, y stratum, y sub-stratum,
    before the permutations (module docstring).

    >>> bose_indices(3, 2)[:4].tolist()
    [[0, 0, 0, 0], [1, 2, 2, 1], [2, 1, 1, 2], [1, 1, 1, 1]]
    """
    if isinstance(dimension, bool) or not isinstance(dimension, (int, np.integer)) \
            or dimension < 0:
        raise ParameterError(f"dimension must be an integer >= 0, got {dimension!r}")
    i = np.arange(p * p, dtype=np.int64)
    a0, a1 = i // p, i % p
    x = _forms(a0, a1, int(dimension), p)
    y = _forms(a0, a1, int(dimension) + 1, p)
    return np.stack([x[0], x[1], y[0], y[1]], axis=1)


def _pattern_counts(tuples: np.ndarray) -> np.ndarray:
    """Ordered pairs of rows per equality pattern (bit t: equal on axis t), shape (16,)."""
    code = np.zeros((len(tuples), len(tuples)), dtype=np.int64)
    for t in range(4):
        code |= (tuples[:, None, t] == tuples[None, :, t]).astype(np.int64) << t
    return np.bincount(code.ravel(), minlength=16)


def _pair_sum(g: np.ndarray, counts: np.ndarray, p: int) -> float:
    r""":math:`E(\sum_i g_i)^2` for one channel over uniform permutations, G (p, p, p, p)."""
    out = 0.0
    for s in np.flatnonzero(counts):
        equal = tuple(_AXES[t] for t in range(4) if s >> t & 1)
        different = tuple(_AXES[t] for t in range(4) if not s >> t & 1)
        c = float(p) ** len(equal) * float(p * (p - 1)) ** len(different)
        out += counts[s] * _restricted(g, equal, different) / c
    return out


def strata_tuples_mse(grid: DyadicGrid, tuples, p: int, method: str = "orthogonal_array",
                      note: str = "") -> RandomisedMSE:
    """The exact MSE of N points, point i uniform in fine cell
    (π₁(A)p + π₂(B), π₃(C)p + π₄(D)) for its row (A, B, C, D) of ``tuples`` (values < p), over
    four independent uniform permutations of {0, …, p − 1} and fresh jitter (module
    docstring); N = len(tuples) = p²."""
    t = np.asarray(tuples, dtype=np.int64)
    n = p * p
    if t.shape != (n, 4) or t.min() < 0 or t.max() >= p:
        raise ParameterError(f"tuples must be ({n}, 4) integers from 0 to {p - 1}")
    edges = np.arange(n + 1) / n
    fine, within = rectangle_moments(grid, edges, edges)       # (C, N, N): X along u1
    g = fine.reshape(grid.channels, p, p, p, p)                 # [c, x, b, y, a]
    counts = _pattern_counts(t)
    pairs = np.array([_pair_sum(g[c], counts, p) for c in range(grid.channels)])
    total = (pairs + within.mean(axis=(1, 2)) * n) / float(n * n)
    above = grid.above / n
    exact = grid.size % n == 0
    note = (note + "; " if note else "") + ("exact (N divides M)" if exact else
                                            "fine cells cut grid cells: their share by the "
                                            "cell-constant interpolant")
    return make_result(method, n, total - above, above, exact=exact, note=note)


def orthogonal_mse(grid: DyadicGrid, n: int, *, dimension: int = 2) -> RandomisedMSE:
    """The MSE of a Bose orthogonal array (strength 2, N = p²) for the 2-D draw at
    dimensions (``dimension``, ``dimension`` + 1), over uniform permutations and jitter."""
    p = _prime_root(int(n))
    return strata_tuples_mse(grid, bose_indices(p, dimension), p,
                             note=f"Bose array, dimensions {dimension} and {dimension + 1}, "
                                  f"uniform permutations")
