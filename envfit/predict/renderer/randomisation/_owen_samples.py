r"""Owen-scrambled nets above the grid, sampled: the MSE of nested uniform scrambling for N
beyond the grid's resolution (N > M/2), as :mod:`._shift_samples` does for the digital shift.

With :math:`F = \frac1N\sum_j h(y_j)`, :math:`y_j` the scrambled points, :math:`h_A` the
grid's piecewise-constant integrand (cell means A on the level-L cells) and
:math:`F_A = \frac1N\sum_j A(y_j)`, :math:`D = F - F_A`: every scrambled point is uniform, so
:math:`E F = I`, :math:`E F_A = I_A`, and

.. math::  E(F - I)^2 = \underbrace{\mathrm{Var}\,F_A}_{\text{exact}}
           + \underbrace{\mathrm{Var}\,D + 2\,\mathrm{Cov}(F_A, D)}_{\text{sampled}} .

:math:`\mathrm{Var}\,F_A = \sum_{\kappa<L}\Gamma_\kappa\,\sigma^2_\kappa(h_A)` is Owen's
gain formula (:mod:`._owen`) on the blocks below the grid — the only ones :math:`h_A`
occupies — with the gains of the N-point net, any N (its dual net read modulo N). The rest is
estimated from Q independent scrambles :math:`y^{(q)}` by :func:`._shift_samples.sampled_above`
(sample variance of :math:`D_q` plus twice its sample covariance with :math:`F_A(y^{(q)})`,
standard error of that mean). Owen's scrambling makes the Haar ANOVA blocks' estimates
uncorrelated, so Cov(F_A, D) = 0 when A holds h's exact cell means; it is kept as the
quadrature correction of midpoint cell means, as for the shift. :math:`F_A` is a control
variate: only the power above the grid (and that correction) is left to sampling, relative
error :math:`\approx\sqrt{2/Q}` of that part.

The scramble (:func:`owen_scramble`) is a nested uniform scramble drawn bit by bit: digit s of
a coordinate is XORed with a random bit drawn for each distinct prefix (digits 1 … s−1) of the
unscrambled coordinate, independently per scramble and coordinate. A (0, m, 2)-net's first m
digits of one coordinate are all distinct (one point per interval of length 2^−m), so below
digit m every prefix is a single point's and the tail digits become independent uniform bits
— drawn as such (Owen 1995; exactly the law of the full 32-digit scramble). Renderers
scramble with a hash (e.g. the Laine–Karras hash and its improvements): a stand-in for nested
uniform scrambling whose variance the model takes as Owen's (which renderer hashes how, read
from which source, its folder says; the tests check renderers' hashed scramblers against the
same law, ``_owen``).

References: A. B. Owen, "Randomly permuted (t, m, s)-nets and (t, s)-sequences" (1995) and
"Monte Carlo variance of scrambled net quadrature", SIAM J. Numer. Anal. 34 (1997);
B. Burley, "Practical hash-based Owen scrambling", JCGT 9(4) (2020); control variates:
A. B. Owen, *Monte Carlo theory, methods and examples* (2013), §8.9.
"""
from __future__ import annotations

import numpy as np

from envfit.base import ParameterError

from ._nets import get_net
from ._shift_samples import ShiftSample

__all__ = ["owen_sample", "owen_scramble"]

_BITS = 32


def owen_scramble(digits: np.ndarray, m: int, scrambles: int,
                  rng: np.random.Generator) -> np.ndarray:
    """``scrambles`` independent nested uniform scrambles of the 2^m points ``digits``
    (2^m, 2) (32-bit integers whose digits beyond m are 0, each coordinate's first m digits
    distinct), shape (Q, 2^m, 2) (module docstring)."""
    n = digits.shape[0]
    out = np.empty((scrambles, n, 2), dtype=np.uint64)
    for d in range(2):
        top = (digits[:, d] >> np.uint64(_BITS - m)).astype(np.int64) if m else \
            np.zeros(n, dtype=np.int64)
        scr = np.zeros((scrambles, n), dtype=np.int64)
        for s in range(m):                                  # digit s + 1, its prefix: s digits
            flips = rng.integers(0, 2, size=(scrambles, 1 << s), dtype=np.int64)
            bit = (top >> (m - 1 - s)) & 1
            scr |= (bit[None, :] ^ flips[:, top >> (m - s)]) << (m - 1 - s)
        tail = rng.integers(0, 1 << (_BITS - m), size=(scrambles, n), dtype=np.uint64)
        out[:, :, d] = (scr.astype(np.uint64) << np.uint64(_BITS - m)) | tail
    return out


def owen_sample(n: int, scrambles: int, seed: int = 0, *, net: str = "sobol") -> ShiftSample:
    """The first ``n`` (= 2^m) points of ``net`` under ``scrambles`` independent nested
    uniform scrambles drawn from ``numpy.random.default_rng(seed)``
    (:class:`._shift_samples.ShiftSample`, ``randomisation="owen"``).

    >>> s = owen_sample(16, 8, seed=1)
    >>> s.digits.shape, s.randomisation
    ((8, 16, 2), 'owen')
    >>> cells = (s.digits[0] >> 28).astype(int)       # a (0, 4, 2)-net stays one
    >>> len({(a >> 2, b >> 2) for a, b in cells}), len(set(cells[:, 0])), len(set(cells[:, 1]))
    (16, 16, 16)
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1 or n & (n - 1):
        raise ParameterError(f"digital nets take N = 2^m points, got N = {n!r}")
    if isinstance(scrambles, bool) or not isinstance(scrambles, (int, np.integer)) \
            or scrambles < 4:
        raise ParameterError(f"scrambles must be an integer >= 4, got {scrambles!r}")
    m = int(n).bit_length() - 1
    digits = owen_scramble(get_net(net).digits(m), m, int(scrambles),
                           np.random.default_rng(seed))
    return ShiftSample(net, int(n), digits, "owen")
