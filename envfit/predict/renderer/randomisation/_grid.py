r"""The common input and output of every randomisation: a warped integrand h on the unit square
summarised on a dyadic grid (:class:`DyadicGrid`), and the predicted mean squared error
(:class:`RandomisedMSE`).

A renderer's estimate with one 2-D sample per technique is :math:`F = \frac1N\sum_j h(u_j)`
with h the *warped integrand* (f·cos/pdf at the direction the sampler's warp makes of u). Every
exact error formula of this sub-package needs only, per channel c,

* the cell means :math:`A_{ij} = M^2\int_{Q_{ij}} h` and :math:`B_{ij} = M^2\int_{Q_{ij}} h^2`
  on the cells :math:`Q_{ij} = [i/M,(i+1)/M)\times[j/M,(j+1)/M)`, :math:`M = 2^L` (axis 1 of
  the arrays is :math:`u_1`, axis 2 is :math:`u_2`);
* the total variance :math:`V = \int h^2 - (\int h)^2`.

The variance splits exactly into the part the grid resolves and the power *above the grid*:

.. math::  V = \underbrace{\tfrac1{M^2}\sum_{ij}(A_{ij} - \bar A)^2}_{\text{resolved}}
           + \underbrace{\tfrac1{M^2}\sum_{ij}(B_{ij} - A_{ij}^2)}_{P_\text{above}},

the second term being the Walsh (or Haar) power of h at indices :math:`k_1\ge M` or
:math:`k_2 \ge M` — the within-cell variance.

Accuracy of :meth:`DyadicGrid.from_callable`: a ``nodes`` × ``nodes`` Gauss–Legendre product
rule per cell (``nodes=1`` is the midpoint rule) integrates h and h² exactly when they are
polynomials of degree ≤ 2·nodes − 1 in each coordinate on each cell; for smooth h the error of
A and B is :math:`O(M^{-2\,\mathrm{nodes}})` relative; in a cell cut by a jump of h the error is
at most the jump (of h, resp. h²) times the cell's area, so the totals err by at most
(jump)²·(cells cut)/M² ≈ jump²·(length of the discontinuity)/M; a peak narrower than a cell
needs a finer level or more nodes.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from envfit.base import ParameterError

from ._strata import cumulative_integral
from ._walsh import walsh_coefficients

__all__ = ["DyadicGrid", "RandomisedMSE"]

#: largest grid level accepted (M = 2^LEVEL_MAX cells per side)
LEVEL_MAX = 13
#: points per call of the integrand in :meth:`DyadicGrid.from_callable`
CHUNK_POINTS = 1 << 21


def _as_channels(a, what: str) -> np.ndarray:
    """``a`` as a float64 array (channels, M, M); an (M, M) array is one channel."""
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1] != arr.shape[2]:
        raise ParameterError(f"{what} must be an (M, M) or (channels, M, M) array, got shape "
                             f"{np.shape(a)}")
    m = arr.shape[1]
    if m < 1 or m & (m - 1) or m > (1 << LEVEL_MAX):
        raise ParameterError(f"{what}: M = {m} cells per side must be a power of two "
                             f"from 1 to {1 << LEVEL_MAX}")
    if not np.all(np.isfinite(arr)):
        raise ParameterError(f"{what} holds NaN or Inf values")
    return arr


@dataclass(frozen=True)
class DyadicGrid:
    r"""A warped integrand h on [0, 1)² summarised on a 2^L × 2^L grid, per channel.

    Parameters
    ----------
    mean : ndarray, shape (C, M, M)
        :math:`A_{ij}`, the mean of h over cell (i, j) (i along :math:`u_1`).
    mean_sq : ndarray, shape (C, M, M)
        :math:`B_{ij}`, the mean of h² over the cell (≥ :math:`A_{ij}^2`).
    variance : ndarray, shape (C,)
        :math:`V = \int h^2 - (\int h)^2`.

    sampled : dict
        Sampled power above the grid, {(randomisation, net, N): (estimate (C,), standard
        error (C,))} (:mod:`._shift_samples`; :meth:`with_sampled_above`), read by the
        digital shift's and Owen scrambling's predictions in place of their values from the
        grid (:attr:`shift_above`: the digital shift's, by (net, N)); and a shared sequence's
        runs' prefix sums of the cell means, by ("shared_sequence", sampler, stream, spacing,
        length, Q, seed) (:mod:`._shared_sequence`: kept so that every N of a class reads
        them).

    Use :meth:`from_callable` or :meth:`from_arrays`; they check and reconcile the inputs.
    """

    mean: np.ndarray
    mean_sq: np.ndarray
    variance: np.ndarray = field(repr=False)
    sampled: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def shift_above(self) -> dict:
        """The digital shift's sampled power above the grid, {(net, N): (estimate, se)}."""
        return {k[1:]: v for k, v in self.sampled.items() if k[0] == "digital_shift"}

    @property
    def size(self) -> int:
        """M, cells per side."""
        return int(self.mean.shape[1])

    @property
    def level(self) -> int:
        """L = log2 M."""
        return self.size.bit_length() - 1

    @property
    def channels(self) -> int:
        return int(self.mean.shape[0])

    @property
    def integral(self) -> np.ndarray:
        r""":math:`\int h` per channel."""
        return self.mean.mean(axis=(1, 2))

    @property
    def resolved_variance(self) -> np.ndarray:
        """The variance of the cell means (the power the grid resolves), per channel."""
        return np.clip(self.variance - self.above, 0.0, None)

    @cached_property
    def above(self) -> np.ndarray:
        r""":math:`P_\text{above}`, the mean within-cell variance (power above the grid)."""
        return self.within.mean(axis=(1, 2))

    @property
    def within(self) -> np.ndarray:
        """The within-cell variances B − A² (≥ 0), shape (C, M, M)."""
        return np.clip(self.mean_sq - self.mean ** 2, 0.0, None)

    @classmethod
    def from_arrays(cls, mean, mean_sq=None, variance=None) -> "DyadicGrid":
        r"""A grid from precomputed cell means of h and of h², and/or the exact variance.

        Parameters
        ----------
        mean : array_like, shape (M, M) or (C, M, M)
            Cell means of h.
        mean_sq : array_like, optional
            Cell means of h². Without it the power above the grid,
            :math:`V - \mathrm{Var}(A)`, is spread evenly over the cells (needs ``variance``).
        variance : array_like, shape (C,), optional
            The exact :math:`V`. With ``mean_sq`` too, the within-cell variances
            :math:`B - A^2` are rescaled so that they sum to :math:`V - \mathrm{Var}(A)`
            (the variance is trusted, the split over cells taken from ``mean_sq``).

        Raises
        ------
        ParameterError
            Shapes, non-finite values, M not a power of two, B < A², neither optional input.
        """
        a = _as_channels(mean, "mean")
        resolved = ((a - a.mean(axis=(1, 2), keepdims=True)) ** 2).mean(axis=(1, 2))
        if mean_sq is None and variance is None:
            raise ParameterError("DyadicGrid.from_arrays needs mean_sq or variance")
        if mean_sq is not None:
            b = _as_channels(mean_sq, "mean_sq")
            if b.shape != a.shape:
                raise ParameterError(f"mean_sq has shape {b.shape}, mean {a.shape}")
            within = b - a ** 2
            scale = np.maximum(np.abs(b), 1e-300)
            if np.any(within < -1e-9 * scale):
                raise ParameterError("mean_sq is below mean² in some cells (not a mean of h²)")
            within = np.clip(within, 0.0, None)
        else:
            within = np.zeros_like(a)
        if variance is None:
            return cls(a, a ** 2 + within, resolved + within.mean(axis=(1, 2)))
        v = np.broadcast_to(np.asarray(variance, dtype=np.float64), resolved.shape).copy()
        if not np.all(np.isfinite(v)):
            raise ParameterError("variance holds NaN or Inf values")
        target = np.clip(v - resolved, 0.0, None)
        have = within.mean(axis=(1, 2))
        for c in range(a.shape[0]):
            within[c] = within[c] * (target[c] / have[c]) if have[c] > 0 else target[c]
        return cls(a, a ** 2 + within, resolved + target)

    @classmethod
    def from_callable(cls, h, level: int, *, nodes: int = 3) -> "DyadicGrid":
        r"""A grid from a vectorised integrand by a Gauss–Legendre product rule per cell.

        Parameters
        ----------
        h : callable
            ``h(u)`` with u of shape (n, 2) in [0, 1)² returns shape (n,) or (n, C).
        level : int
            L, the grid has M = 2^L cells per side (0 ≤ L ≤ 13).
        nodes : int
            Gauss–Legendre nodes per axis and cell (1: midpoint rule); accuracy in the
            module docstring.

        Returns
        -------
        DyadicGrid
            Cell means of h and h² by the rule, V from them (exact split, see the module).
        """
        if not (isinstance(level, (int, np.integer)) and 0 <= level <= LEVEL_MAX):
            raise ParameterError(f"level must be an integer from 0 to {LEVEL_MAX}, got {level!r}")
        if not (isinstance(nodes, (int, np.integer)) and 1 <= nodes <= 16):
            raise ParameterError(f"nodes must be an integer from 1 to 16, got {nodes!r}")
        m = 1 << int(level)
        x, w = np.polynomial.legendre.leggauss(int(nodes))
        x, w = (x + 1.0) / 2.0, w / 2.0
        q = int(nodes)
        rows = max(1, CHUNK_POINTS // (m * q * q))
        sums, sums_sq = None, None
        for i0 in range(0, m, rows):
            i = np.arange(i0, min(m, i0 + rows))
            u1 = (i[:, None] + x[None, :]) / m                      # (rows, q)
            u2 = (np.arange(m)[:, None] + x[None, :]) / m           # (M, q)
            pts = np.empty((i.size, q, m, q, 2))
            pts[..., 0] = u1[:, :, None, None]
            pts[..., 1] = u2[None, None, :, :]
            val = np.asarray(h(pts.reshape(-1, 2)), dtype=np.float64)
            val = val.reshape(i.size, q, m, q, -1)
            wt = (w[:, None] * w[None, :])[None, :, None, :, None]
            s1 = (val * wt).sum(axis=(1, 3))
            dev = val - s1[:, None, :, None, :]
            s2 = s1 ** 2 + (dev ** 2 * wt).sum(axis=(1, 3))       # A² + within, no cancellation
            if sums is None:
                sums = np.empty((m, m, s1.shape[-1]))
                sums_sq = np.empty_like(sums)
            sums[i0:i0 + i.size], sums_sq[i0:i0 + i.size] = s1, s2
        a = np.moveaxis(sums, -1, 0)
        b = np.maximum(np.moveaxis(sums_sq, -1, 0), a ** 2)
        return cls.from_arrays(a, b)

    def with_shift_above(self, net: str, n: int, above, se) -> "DyadicGrid":
        """This grid with the sampled power above it of ``net``'s first ``n`` points under a
        digital shift (:func:`._shift_samples.sampled_above`)."""
        return self.with_sampled_above("digital_shift", net, n, above, se)

    def with_sampled_above(self, randomisation: str, net: str, n: int, above,
                           se) -> "DyadicGrid":
        """This grid with the sampled power above it of ``net``'s first ``n`` points under
        ``randomisation`` (``digital_shift`` or ``owen``; :func:`._shift_samples.sampled_above`
        at :func:`._shift_samples.shift_sample`'s or :func:`._owen_samples.owen_sample`'s
        points)."""
        d = dict(self.sampled)
        d[(str(randomisation), str(net), int(n))] = (np.asarray(above, dtype=np.float64),
                                                     np.asarray(se, dtype=np.float64))
        new = replace(self, sampled=d)
        if "walsh" in self.__dict__:                   # the same cell means: keep the transform
            new.__dict__["walsh"] = self.__dict__["walsh"]
        return new

    def combined(self, other: "DyadicGrid", cross_mean: np.ndarray) -> "DyadicGrid":
        """The grid of h + h' from this grid (h), ``other`` (h') and the cell means of h·h'."""
        c = _as_channels(cross_mean, "cross_mean")
        return DyadicGrid.from_arrays(self.mean + other.mean,
                                      self.mean_sq + other.mean_sq + 2.0 * c)

    @cached_property
    def walsh(self) -> np.ndarray:
        r""":math:`\hat h(k)` for :math:`k_1, k_2 < M` of the centred cell means, (C, M, M)
        (:func:`._walsh.walsh_coefficients`; computed once per grid, read by every net's
        prediction at this level)."""
        return walsh_coefficients(self.centred()[0])

    @cached_property
    def strata_tables(self) -> tuple[np.ndarray, np.ndarray]:
        r"""The cumulative integrals (C, M + 1, M + 1) of the centred cell means a and of
        a² + the within-cell variance (:func:`._strata.cumulative_integral`): a rectangle's
        moments where strata cut cells are bilinear reads of them
        (:func:`._strata.rectangle_moments`); made once per grid, read at every N."""
        a, w = self.centred()[0], self.within
        return cumulative_integral(a), cumulative_integral(a * a + w)

    def centred(self) -> tuple[np.ndarray, np.ndarray]:
        r"""(A − ∫h, B − 2A∫h + (∫h)²): the cell means of h − ∫h and of its square (the
        variance formulas are invariant to the constant; centring keeps their sums exact)."""
        mu = self.integral[:, None, None]
        return self.mean - mu, self.mean_sq - 2.0 * mu * self.mean + mu ** 2


@dataclass(frozen=True)
class RandomisedMSE:
    r"""The exact mean squared error of :math:`F = \frac1N\sum_j h(u_j)` over a randomisation.

    Attributes
    ----------
    method : str
        The randomisation (a key of ``RANDOMISATIONS``).
    n : int
        N, points per estimate.
    mse : ndarray, shape (C,)
        :math:`E(F - I)^2` per channel = ``resolved + above``.
    resolved : ndarray, shape (C,)
        The part from the power the grid resolves.
    above : ndarray, shape (C,)
        The part from the power above the grid.
    exact : bool
        Whether ``above`` is exact (False: an approximation, see ``note``).
    note : str
        How ``above`` was obtained, and any rounding of N or of the strata.
    above_se : ndarray or None
        The standard error of ``above`` where it is sampled, per channel.
    """

    method: str
    n: int
    mse: np.ndarray
    resolved: np.ndarray
    above: np.ndarray
    exact: bool = True
    note: str = ""
    above_se: np.ndarray | None = None

    @property
    def rmse(self) -> np.ndarray:
        """√mse per channel."""
        return np.sqrt(np.clip(self.mse, 0.0, None))

    @property
    def rms_rmse(self) -> float:
        """The RMSE as the RMS over the channels, :math:`\\sqrt{\\overline{mse}}`."""
        return float(np.sqrt(max(0.0, float(np.mean(self.mse)))))


def make_result(method: str, n: int, resolved, above, *, exact: bool = True,
                note: str = "", above_se=None) -> RandomisedMSE:
    """A :class:`RandomisedMSE` from its two parts (arrays per channel; tiny negatives of
    rounding are clipped to 0). A sampled ``above`` (``above_se`` given) is a correction that
    may be negative: only the sum is clipped."""
    r = np.clip(np.asarray(resolved, dtype=np.float64), 0.0, None)
    a = np.asarray(above, dtype=np.float64)
    a = np.clip(a, 0.0, None) if above_se is None else np.maximum(a, -r)
    return RandomisedMSE(method, int(n), r + a, r, a, exact, note,
                         None if above_se is None else np.asarray(above_se, dtype=np.float64))
