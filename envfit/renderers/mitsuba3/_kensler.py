r"""Mitsuba 3's ``multijitter`` permutations: Kensler's hashed permutation
(``permute_kensler``), the distribution of the permutations it makes over uniformly random
seeds (:func:`pair_table`, the law :data:`KENSLER_PERMUTATIONS` the sampler's record hands the
exact ``cmj`` model), and the sampler's grid (:func:`multijitter_shape`).

``permute_kensler(i, l, p)`` (A. Kensler, "Correlated Multi-Jittered Sampling", Pixar Technical
Memo 13-01, 2013, §3 ``permute``; Mitsuba 3 ``include/mitsuba/core/random.h``:
``permute_kensler``) hashes i under the mask w = 2^⌈log2 l⌉ − 1 by a fixed sequence of
xor-shifts and multiplications seeded by p, cycle-walks until the value is below l, and returns
(value + p) mod l (32-bit arithmetic throughout). For a fixed p it is a bijection of
{0, …, l − 1}; over p it is *not* a uniformly random permutation: for l = 4 the pairs
(σ(y), σ(y')) are not uniform over the distinct pairs, and Mitsuba's ``multijitter`` MSE differs
from the uniform-permutation value by up to 7 % at spp 16 (bench/randomisation_check.py).
Mitsuba's ``stratified`` (where the index's permutation only reorders the strata) and
``orthogonal`` (modelled with uniform permutations; ``tests/test_randomisation_orthogonal.py``
measures the difference on Mitsuba's own points) permute by it too.

:func:`pair_table` estimates :math:`P[(y, b), (y', b')] = \Pr(\sigma(y) = b, \sigma(y') = b')`
over uniformly random 32-bit seeds (Mitsuba's ``multijitter`` seeds are
``perm_seed · 0x68bc21eb`` and ``perm_seed · 0x02e5be93``, odd multiples of a per-pixel hash:
uniform; σ_x and σ_y independent) from a fixed set of seeds (:data:`TABLE_SEEDS`, a seeded numpy
Generator; the entries' relative standard error is about :math:`l/\sqrt{S}`).
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from envfit.renderers._base import PermutationLaw

__all__ = ["KENSLER_PERMUTATIONS", "TABLE_SEEDS", "multijitter_shape", "pair_table",
           "permute_kensler"]

#: seeds drawn to estimate a pair table
TABLE_SEEDS = 1 << 18

_U = np.uint32


def _mix(v: np.ndarray, seed: np.ndarray, w: np.uint32) -> np.ndarray:
    """One application of Kensler's hash (the loop body of ``permute_kensler``)."""
    t = v ^ seed
    t = t * _U(0xE170893D)
    t ^= seed >> _U(16)
    t ^= (t & w) >> _U(4)
    t ^= seed >> _U(8)
    t = t * _U(0x0929EB3F)
    t ^= seed >> _U(23)
    t ^= (t & w) >> _U(1)
    t = t * (_U(1) | (seed >> _U(27)))
    t = t * _U(0x6935FA69)
    t ^= (t & w) >> _U(11)
    t = t * _U(0x74DCB303)
    t ^= (t & w) >> _U(2)
    t = t * _U(0x9E501CC3)
    t ^= (t & w) >> _U(2)
    t = t * _U(0xC860A3DF)
    t &= w
    t ^= t >> _U(5)
    return t


def permute_kensler(index, length: int, seed) -> np.ndarray:
    """Mitsuba's ``permute_kensler(index, length, seed)``, vectorised (broadcast) in uint32."""
    idx = np.array(index, dtype=np.uint32)
    seeds = np.array(seed, dtype=np.uint32)
    idx, seeds = np.broadcast_arrays(idx, seeds)
    idx = idx.copy()
    if length == 1:
        return np.zeros(idx.shape, dtype=np.int64)
    w = int(length - 1)
    for s in (1, 2, 4, 8, 16):
        w |= w >> s
    w = _U(w)
    with np.errstate(over="ignore"):
        invalid = np.ones(idx.shape, dtype=bool)
        while invalid.any():
            idx[invalid] = _mix(idx[invalid], seeds[invalid], w)
            invalid = idx >= length
        return ((idx + seeds) % _U(length)).astype(np.int64)


@lru_cache(maxsize=32)
def pair_table(length: int, seeds: int = TABLE_SEEDS) -> np.ndarray:
    r""":math:`\Pr(\sigma(y) = b, \sigma(y') = b')` of ``permute_kensler`` over ``seeds`` random
    32-bit seeds, shape (l², l²), rows (y, b), columns (y', b'). Cached (read-only)."""
    rng = np.random.default_rng(0x6B656E73)
    counts = np.zeros(length ** 4)
    y = np.arange(length)
    chunk = max(1, (1 << 22) // (length * length))
    for s0 in range(0, seeds, chunk):
        p = rng.integers(0, 1 << 32, size=min(chunk, seeds - s0), dtype=np.uint64)
        sigma = permute_kensler(y[None, :], length, p[:, None].astype(np.uint32))
        cell = y[None, :] * length + sigma                                   # (S, l)
        flat = cell[:, :, None] * (length * length) + cell[:, None, :]
        counts += np.bincount(flat.ravel(), minlength=length ** 4)
    table = counts.reshape(length * length, length * length) / seeds
    table.flags.writeable = False
    return table


#: the law of ``multijitter``'s permutations: the value of the ``cmj`` model's
#: ``permutations`` option in the sampler's record (``_envmap.SAMPLERS``)
KENSLER_PERMUTATIONS = PermutationLaw(
    "kensler", pair_table, f"Mitsuba's permutation pairs estimated from {TABLE_SEEDS} seeds",
    permute_kensler)


def multijitter_shape(spp: int) -> tuple[int, int]:
    r"""Mitsuba 3.9's ``multijitter`` grid :math:`(n_x, n_y)` = (⌈spp/⌊√spp⌋⌉, ⌊√spp⌋)
    (``src/samplers/multijitter.cpp``: ``MultijitterSampler::set_sample_count``); the sample
    count becomes :math:`n_x n_y` (32 → 35).

    >>> multijitter_shape(32), multijitter_shape(35)
    ((7, 5), (7, 5))
    """
    ny = max(1, math.isqrt(int(spp)))
    return -(-int(spp) // ny), ny
