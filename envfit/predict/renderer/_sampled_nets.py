r"""The randomised nets a pass of the renderer model samples: one table of points at the pass's
largest N, read as prefixes for every smaller N, and the variance of every prefix.

**Prefixes.** The first N points of a randomised (0, 2)-sequence (Sobol' dimensions 0, 1)
under one random digital shift or one nested uniform scramble are the randomised N-point net
with the law the model assumes for N = 2^m (the first 2^m points of the sequence are a
(0, m, 2)-net, and a scramble of the sequence restricted to them is a scramble of that net).
So the model draws :math:`Q` randomisations of the first ``base`` points once (the spp the
model resolves, :meth:`SampledNets.sample`: a cell's points never depend on the other cells
asked with it), a pass evaluates the integrand at the prefix of its largest N once per
normal, and every N of the pass reads its own prefix: the power above the grid of :mod:`.randomisation._shift_samples`
for all of them from cumulative sums (:func:`.randomisation.sampled_above_prefixes`).

**Any N** (:meth:`SampledNets.between`). A sampler whose record sets
:attr:`~envfit.renderers.SamplerSpec.prefix` runs any spp: its N points are the first N of the
pixel's sequence after an index shuffle (a hashed shuffle of the sample index; which
renderers' samplers, read from which source, their folders say).
The shuffle keeps aligned blocks of indices together, and an aligned block of Sobol' indices
is a digital shift of the sequence's first block of that size (the generator matrices are
linear over GF(2); the first 2^m points are a group under XOR), so the N points are one
digital shift of the first N — which the nested uniform scramble absorbs: their law is the
prefix's. For N between the powers of two :math:`2^m < N < 2^{m+1}` the model has no exact
formula; it estimates :math:`S(N) = \sum_a \varpi_a \mathrm{Var}_q F_q(N)` (the plain
sample variance over the Q scrambles of the prefix means, weighted over the normals) and
calibrates it at the two exact predictions :math:`E` around it,

.. math::  \mathrm{MSE}(N) = S(N)\Bigl[(1-t)\frac{E(2^m)}{S(2^m)} + t\,\frac{E(2^{m+1})}{S(2^{m+1})}\Bigr],
           \qquad t = \log_2 N - m,

which equals the exact prediction at both powers of two and, since :math:`S(N)` and
:math:`S(2^m)` share their scrambles and the first :math:`2^m` points, cancels most of the
sampling error of :math:`S` (relative error :math:`\approx\sqrt{2/Q}` per normal without it).
The streams of a two-technique strategy are independent (such samplers scramble the light
and BSDF dimensions apart: pairing ``independent``): their variances add.

Reference: A. B. Owen, "Randomly permuted (t, m, s)-nets and (t, s)-sequences" (1995);
B. Burley, "Practical hash-based Owen scrambling", JCGT 9(4) (2020).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from envfit.predict.renderer.randomisation import (ShiftSample, owen_sample,
                                                   sampled_above_prefixes, shift_sample)

__all__ = ["SampledNets", "prefix_variance", "curve_parts"]

#: the randomisations sampled above a grid coarser than 2N → the tag of their points
SAMPLE_TAG = {"digital_shift": "shift", "owen": "owen"}


def curve_parts(strategy: str, shared: bool) -> tuple[str, ...]:
    """The parts whose prefix variances add to a strategy's (module docstring)."""
    if strategy == "mis":
        return ("mis_t",) if shared else ("mis_e", "mis_b")
    return (strategy,)


@numba.njit(cache=True, parallel=True)
def _prefix_moments(vals, out):  # pragma: no cover - numba
    """Per block b of rows (parallel: rows b, b + B, …) and prefix length n: the sum over
    the block's rows of the prefix mean and of its square, ``out[b, 0, n-1, c]`` and
    ``out[b, 1, n-1, c]``, each channel's mean over all values taken out first."""
    q, top, chans = vals.shape
    blocks = out.shape[0]
    part = np.zeros((blocks, chans))
    for b in numba.prange(blocks):
        for i in range(b, q, blocks):
            for n in range(top):
                for c in range(chans):
                    part[b, c] += vals[i, n, c]
    mu = np.zeros(chans)
    for b in range(blocks):
        for c in range(chans):
            mu[c] += part[b, c] / (q * top)
    for b in numba.prange(blocks):
        for c in range(chans):
            for i in range(b, q, blocks):
                s = 0.0
                for n in range(top):
                    s += vals[i, n, c] - mu[c]
                    m = s / (n + 1)
                    out[b, 0, n, c] += m
                    out[b, 1, n, c] += m * m


def prefix_variance(values: np.ndarray) -> np.ndarray:
    """The sample variance over the Q rows (ddof 1) of the mean of the first n values, for
    every n: values (Q, top, C) → (top, C). The channel means are taken out first (the
    variance does not change; the sums of squares keep their digits).

    >>> v = np.arange(8.0).reshape(2, 4, 1)          # rows 0 1 2 3 and 4 5 6 7
    >>> prefix_variance(v)[:, 0].tolist()
    [8.0, 8.0, 8.0, 8.0]
    """
    v = np.asarray(values, dtype=np.float64)
    q = v.shape[0]
    blocks = min(q, 2 * numba.get_num_threads())
    mom = np.zeros((blocks, 2) + v.shape[1:])
    _prefix_moments(v, mom)
    mom = mom.sum(axis=0)
    mean = mom[0] / q
    return np.clip((mom[1] - q * mean * mean) / (q - 1), 0.0, None)


class SampledNets:
    """The sampled nets of a model's passes (module docstring): ``shifts`` randomisations
    (Q) seeded by ``seed``; :meth:`plan` sets a pass's largest N and its curves."""

    def __init__(self, shifts: int, seed: int, base: int = 1):
        self.shifts, self.seed = int(shifts), int(seed)
        self.base = 1 << max(0, int(base) - 1).bit_length()     # a power of two ≥ base
        self._draws: dict = {}
        self.top = 0                    # the pass's largest sampled N
        self.ns: dict = {}              # (tag, level) → the pass's sampled N
        self.curve_top = 0              # > 0: the pass accumulates prefix variances to it
        self.curve_strategies: dict = {}  # strategy → shared
        self._acc: dict = {}
        self.curves: dict = {}          # part → (top, C) weighted over the normals
        self.curves_top = 0

    def plan(self, sampled, curve_top: int = 0, curve_strategies: dict | None = None):
        """A pass's sampled requests (``.name``, ``.n``, ``.level``) and, with ``curve_top``,
        the prefix variances to accumulate to it for ``curve_strategies`` (strategy →
        shared)."""
        self.top = max([r.n for r in sampled] + [int(curve_top)])
        self.ns = {}
        for r in sampled:
            self.ns.setdefault((SAMPLE_TAG[r.name], r.level), set()).add(r.n)
        self.curve_top = int(curve_top)
        self.curve_strategies = dict(curve_strategies or {})
        self._acc = {}

    def sample(self, tag: str, n: int) -> ShiftSample:
        """The first N points of the Sobol' net under Q random shifts (``"shift"``) or nested
        uniform scrambles (``"owen"``): the prefix of one draw of :attr:`base` points (more
        only for an N above it), so that a cell's points never depend on the other cells of
        its pass."""
        size = max(int(n), self.base)
        if (tag, size) not in self._draws:
            draw = owen_sample if tag == "owen" else shift_sample
            self._draws[tag, size] = draw(size, self.shifts, self.seed)
        full = self._draws[tag, size]
        if n == size:
            return full
        if (tag, size, n) not in self._draws:
            self._draws[tag, size, n] = ShiftSample(full.net, int(n), full.digits[:, :n],
                                                    full.randomisation)
        return self._draws[tag, size, n]

    def above(self, tag: str, level: int, n: int, mean: np.ndarray, values: np.ndarray,
              memo: dict, part: str):
        """(estimate, standard error) of the power above the level-``level`` grid of cell
        means ``mean`` for the pass's sampled N, from the integrand ``values`` at the
        pass's table (or a function that gives them, called only where the estimate is not
        yet kept per normal in ``memo``)."""
        key = ("above", part, level, tag, max(n, self.top))
        if key not in memo or n not in memo[key]:
            ns = self.ns.get((tag, level), set()) | {n}
            memo[key] = sampled_above_prefixes(self.sample(tag, max(n, self.top)), mean,
                                               values() if callable(values) else values, ns,
                                               draws=True)
        return memo[key][n][:2]

    def draws(self, tag: str, level: int, n: int, memo: dict, part: str) -> np.ndarray:
        """Each draw's term (Q, C) of the estimate :meth:`above` made for ``part``."""
        return memo["above", part, level, tag, max(n, self.top)][n][2]

    def add_curves(self, weight: float, values: dict) -> None:
        """Accumulate one normal's prefix variances (weight ``weight``) of the parts of
        :attr:`curve_strategies`, from its integrand at the owen table (part → (Q·top, C))."""
        parts = {p for s, sh in self.curve_strategies.items() for p in curve_parts(s, sh)}
        for p in parts:
            v = values[p].reshape(self.shifts, self.top, -1)[:, :self.curve_top]
            add = weight * prefix_variance(v)
            self._acc[p] = self._acc[p] + add if p in self._acc else add

    def finish_curves(self) -> None:
        """The pass's accumulated prefix variances become :attr:`curves`."""
        if self.curve_top:
            self.curves, self.curves_top = dict(self._acc), self.curve_top
        self._acc = {}

    def has_curves(self, strategies: dict, top: int) -> bool:
        """Whether :attr:`curves` hold ``strategies`` (strategy → shared) to ``top``."""
        return self.curves_top >= top and all(
            p in self.curves for s, sh in strategies.items() for p in curve_parts(s, sh))

    def between(self, strategy: str, shared: bool, n: int, lo_mse: np.ndarray,
                hi_mse: np.ndarray) -> np.ndarray:
        """The MSE (C,) at N between the powers of two whose exact MSE are ``lo_mse`` and
        ``hi_mse`` (module docstring)."""
        s = sum(self.curves[p] for p in curve_parts(strategy, shared))        # (top, C)
        lo = 1 << (int(n).bit_length() - 1)
        t = math.log2(n / lo)
        with np.errstate(invalid="ignore", divide="ignore"):
            c_lo = np.where(s[lo - 1] > 0, lo_mse / s[lo - 1], 0.0)
            c_hi = np.where(s[2 * lo - 1] > 0, hi_mse / s[2 * lo - 1], 0.0)
        return np.clip(s[n - 1] * ((1.0 - t) * c_lo + t * c_hi), 0.0, None)
