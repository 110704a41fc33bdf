r"""The power of a digitally shifted net above the grid, sampled: the digital shift's MSE for
any N, also where the grid is coarser than the net (N > M/2).

With :math:`F(\Delta) = \frac1N\sum_j h(x_j\oplus\Delta)` and :math:`h_A` the grid's
piecewise-constant integrand (the cell means A of :class:`._grid.DyadicGrid` on the level-L
cells), :math:`F_A(\Delta) = \frac1N\sum_j A(x_j\oplus\Delta)`. The Walsh functions of index
:math:`k < M` (both coordinates) span the functions constant on the cells, so
:math:`\hat h_A(k) = \hat h(k)` for k < M and 0 elsewhere; with the dual-net expansion of
:mod:`._digital_shift`,

.. math::  F - I = \underbrace{\sum_{k\in D^*\setminus0,\,k<M}\hat h(k)\,\mathrm{wal}_k(\Delta)}
           _{F_A - I} + \underbrace{\sum_{k\in D^*,\,k\not<M}\hat h(k)\,\mathrm{wal}_k(\Delta)}
           _{F - F_A},

two sums over disjoint indices, orthogonal in Δ, hence

.. math::  E_\Delta(F - I)^2 = \sum_{k\in D^*\setminus0,\,k<M}\hat h(k)^2
           + E_\Delta(F - F_A)^2 + 2\,E_\Delta[(F_A - I_A)(F - F_A)],

the last term 0 when A holds h's exact cell means and the correction of their quadrature
error (:meth:`._grid.DyadicGrid.from_callable`, the tables' midpoints) when it does not —
kept, so that the sum is :math:`E(F - I)^2` whatever the cell means' accuracy.

The first sum is exact (the grid's Walsh coefficients; the dual net of :math:`N = 2^m` points
read modulo :math:`2^m`, any M). The second — the power above the grid that the dual net
keeps, with the correction — is estimated from Q uniform shifts :math:`\Delta_q` (32-bit
integers, as a sampler XORs them into the net's 32-bit digits) by the sample variance of
:math:`D_q = F(\Delta_q) - F_A(\Delta_q)` plus twice its sample covariance with
:math:`F_A(\Delta_q)` (the sample means absorb :math:`I - I_A`), with the standard error of
that mean. It may be negative (a correction); the sum is clipped at 0. :math:`F_A` is a control
variate: only the power above the grid is left to sampling, so the estimate is unbiased at
every N and its relative error is :math:`\approx\sqrt{2/Q}` of that part alone. (For a smooth
h most of the dual net's power lies at indices ≥ N — a ramp's Walsh coefficients sit at powers
of two — so where M < 2N the sampled part is most of the MSE.) Two parts
evaluated at the same shifted points (:class:`ShiftSample`) give the cross term of one shared
net (:mod:`._mis`) by polarisation, consistently.

Reference: J. Dick, F. Pillichshammer, *Digital Nets and Sequences* (2010), ch. 13 (the
digital-shift variance as a dual-net sum); control variates: A. B. Owen, *Monte Carlo
theory, methods and examples* (2013), §8.9.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from envfit.base import ParameterError

from ._nets import get_net

__all__ = ["ShiftSample", "shift_sample", "sampled_above", "sampled_above_prefixes"]

_BITS = 32


@dataclass(frozen=True)
class ShiftSample:
    """The first ``n`` points of ``net`` under ``shifts`` independent randomisations:
    ``digits`` (Q, N, 2) as 32-bit integers (x = value / 2^32); ``randomisation`` how they were
    drawn: ``digital_shift`` (uniform XOR shifts, :func:`shift_sample`) or ``owen`` (nested
    uniform scrambles, :func:`._owen_samples.owen_sample`). :func:`sampled_above` takes
    either: its estimate needs only that each randomised point is uniform."""

    net: str
    n: int
    digits: np.ndarray
    randomisation: str = "digital_shift"
    _cells: dict = field(default_factory=dict, repr=False, compare=False)

    def cells(self, level: int) -> np.ndarray:
        """The flat index i·M + j of each point's cell on the grid of ``level``, (Q·N,)
        (computed once per level)."""
        if level not in self._cells:
            c = (self.digits.reshape(-1, 2) >> np.uint64(_BITS - level)).astype(np.int64)
            self._cells[level] = c[:, 0] * (1 << level) + c[:, 1]
        return self._cells[level]

    @property
    def shifts(self) -> int:
        """Q, the number of shifts (scrambles)."""
        return int(self.digits.shape[0])

    @property
    def points(self) -> np.ndarray:
        """The shifted points in [0, 1)², shape (Q·N, 2), shift by shift."""
        return self.digits.reshape(-1, 2).astype(np.float64) / 2.0 ** _BITS


def shift_sample(n: int, shifts: int, seed: int = 0, *, net: str = "sobol") -> ShiftSample:
    """The first ``n`` (= 2^m) points of ``net`` XOR-shifted by ``shifts`` uniform 32-bit
    shifts drawn from ``numpy.random.default_rng(seed)``.

    >>> s = shift_sample(4, 8, seed=1)
    >>> s.digits.shape, s.points.shape
    ((8, 4, 2), (32, 2))
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1 or n & (n - 1):
        raise ParameterError(f"digital nets take N = 2^m points, got N = {n!r}")
    if isinstance(shifts, bool) or not isinstance(shifts, (int, np.integer)) or shifts < 4:
        raise ParameterError(f"shifts must be an integer >= 4, got {shifts!r}")
    base = get_net(net).digits(int(n).bit_length() - 1)                      # (N, 2)
    rng = np.random.default_rng(seed)
    delta = rng.integers(0, 1 << _BITS, size=(int(shifts), 1, 2), dtype=np.uint64)
    return ShiftSample(net, int(n), base[None, :, :] ^ delta)


def sampled_above(sample: ShiftSample, mean: np.ndarray,
                  values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r""":math:`E_\Delta(F - F_A)^2 + 2E_\Delta[(F_A - I_A)(F - F_A)]` per channel and its
    standard error (module docstring).

    Parameters
    ----------
    sample : ShiftSample
        The shifted points.
    mean : ndarray, shape (C, M, M)
        The grid's cell means A (:attr:`._grid.DyadicGrid.mean`).
    values : ndarray, shape (Q·N, C)
        h at ``sample.points``.

    Returns
    -------
    (ndarray, ndarray)
        The estimate and its standard error, shape (C,) each.
    """
    q, n = sample.digits.shape[:2]
    vals = np.asarray(values, dtype=np.float64).reshape(q, n, -1)
    mean = np.asarray(mean, dtype=np.float64)
    if mean.shape[0] != vals.shape[-1]:
        raise ParameterError(f"{vals.shape[-1]} channels of values, {mean.shape[0]} of the grid")
    level = mean.shape[1].bit_length() - 1
    flat = sample.cells(level)
    f_a = np.take(mean.reshape(mean.shape[0], -1), flat, axis=1)
    f_a = f_a.reshape(-1, q, n).mean(axis=-1).T                              # (Q, C)
    d = vals.mean(axis=1) - f_a
    d = d - d.mean(axis=0)
    f_a = f_a - f_a.mean(axis=0)
    z = (d * d + 2.0 * f_a * d) * (q / (q - 1.0))
    return z.mean(axis=0), z.std(axis=0, ddof=1) / np.sqrt(q)


def sampled_above_prefixes(sample: ShiftSample, mean: np.ndarray, values: np.ndarray,
                           ns, *, draws: bool = False) -> dict:
    r""":func:`sampled_above` of every prefix ``n`` in ``ns`` of ``sample`` — the first n
    points of each randomisation, a randomised n-point net of the same sequence — from one
    table of h at all of ``sample``'s points: sums of the segments between the prefixes give
    every :math:`F(\Delta_q)` and :math:`F_A(\Delta_q)` at once (what ``sampled_above`` of
    the prefix sample computes, to rounding).

    Returns
    -------
    dict
        n → (estimate, standard error), shape (C,) each; with ``draws``, also each draw's
        term (Q, C), whose mean is the estimate.

    Examples
    --------
    >>> s = shift_sample(16, 8, seed=1)
    >>> v = s.points[:, :1] ** 2
    >>> a = sampled_above_prefixes(s, np.full((1, 2, 2), 1 / 3), v, [4, 16])
    >>> b = sampled_above(ShiftSample("sobol", 4, s.digits[:, :4]), np.full((1, 2, 2), 1 / 3),
    ...                   v.reshape(8, 16, 1)[:, :4])
    >>> bool(np.allclose(a[4][0], b[0]))
    True
    """
    q, top = sample.digits.shape[:2]
    vals = np.asarray(values, dtype=np.float64).reshape(q, top, -1)
    mean = np.asarray(mean, dtype=np.float64)
    if mean.shape[0] != vals.shape[-1]:
        raise ParameterError(f"{vals.shape[-1]} channels of values, {mean.shape[0]} of the grid")
    ns = sorted({int(n) for n in ns})
    if not ns or ns[0] < 1 or ns[-1] > top:
        raise ParameterError(f"prefixes must lie between 1 and the sample's {top} points")
    level = mean.shape[1].bit_length() - 1
    f_a = np.take(mean.reshape(mean.shape[0], -1), sample.cells(level), axis=1)
    cuts = [0] + ns[:-1]                       # the segments between the prefixes, summed
    cs_a = np.cumsum(np.add.reduceat(f_a.reshape(-1, q, top), cuts, axis=2), axis=2)
    cs_v = np.cumsum(np.add.reduceat(vals, cuts, axis=1), axis=1)   # (Q, len(ns), C)
    out = {}
    for j, n in enumerate(ns):
        fa = cs_a[:, :, j].T / n                                           # (Q, C)
        d = cs_v[:, j] / n - fa
        d = d - d.mean(axis=0)
        fa = fa - fa.mean(axis=0)
        z = (d * d + 2.0 * fa * d) * (q / (q - 1.0))
        out[n] = (z.mean(axis=0), z.std(axis=0, ddof=1) / np.sqrt(q)) + ((z,) if draws else ())
    return out
