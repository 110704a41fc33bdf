r"""Mitsuba 3's ``ldsampler`` ported to numpy, many pixels at once: the points of every 2-D
dimension of a pixel in the order Mitsuba pairs them. Its digital shift (one XOR scramble per
pixel, the same for every dimension) is modelled exactly on the grid
(``_digital_shift``, ``_shift_samples``) whatever the order; the order matters where a
dimension's points meet another's in one sample: the film position (dimension 0) with the
techniques' (:func:`envfit.predict.renderer._footprint.paired_footprint_mse`).

* :func:`sample_tea_32` — ``include/mitsuba/core/random.h``: ``sample_tea_32`` (TEA, the pair
  (v0, v1) after ``rounds`` rounds);
* :func:`permute` — ``random.h``: ``permute`` (a shuffling network: at level l the index's
  bit l is flipped when bit l of ``sample_tea_32(index | 2^l, seed, rounds)`` is set, so the
  two indices that may swap draw the same number);
* :func:`ldsampler_points` — ``src/samplers/ldsampler.cpp``: ``next_2d`` — dimension d of
  sample j is the (0, 2)-net's point ``permute(j, N, scramble_seed + d)``, x by
  ``radical_inverse_2`` (bit reversal) and y by ``sobol_2``, each XOR one per-pixel scramble
  ``sample_tea_32(scramble_seed, 0x98bc51ab)`` (x read as a float32 mantissa, y as the
  integer rounded to float32 times 2^-32, as the installed build returns them).

Which of TEA's two words ``permute`` reads is taken from the installed build's own
``mi.permute``, and ``ldsampler``'s 2 rounds from its points: with the per-pixel
``scramble_seed`` = ``compute_per_sequence_seed(seed)`` = ``sample_tea_32(base_seed = 0,
seed).first`` (``src/render/sampler.cpp``, scalar variants), the port repeats
``sampler.seed(seed)``'s points exactly (tests/test_randomisation_mitsuba.py). Two rounds of
TEA on the seeds ``scramble_seed + d`` order consecutive dimensions alike: the product of the
first binary digits of x in dimensions 0 and 1 has (N − 1) × the variance of its pixel mean
1.9, 3.0, 8.6 and ≈ 15 at 16, 64, 256 and 1024 spp, 1 for a uniform pairing.
"""
from __future__ import annotations

import numba
import numpy as np

__all__ = ["sample_tea_32", "permute", "ldsampler_points", "ldsampler_numbers",
           "pixel_scramble_seeds"]

M32 = np.uint64(0xFFFFFFFF)
#: the word of the TEA pair that ``permute`` reads (the installed build's), and the rounds
#: ``ldsampler`` calls it with (C++'s default, 2; the Python binding ``mi.permute`` defaults
#: to 4)
PERMUTE_WORD, LD_ROUNDS = 0, 2


def _u(x) -> np.ndarray:
    return np.asarray(x, dtype=np.uint64) & M32


def sample_tea_32(v0, v1, rounds: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """TEA of (v0, v1), element-wise, as 32-bit words: the pair (v0, v1)."""
    v0, v1 = _u(v0), _u(v1)
    v0, v1 = np.broadcast_arrays(v0, v1)
    v0, v1 = v0.copy(), v1.copy()
    s = np.uint64(0)
    for _ in range(rounds):
        s = (s + np.uint64(0x9E3779B9)) & M32
        v0 = (v0 + ((((v1 << np.uint64(4)) + np.uint64(0xA341316C)) & M32)
                    ^ ((v1 + s) & M32) ^ (((v1 >> np.uint64(5)) + np.uint64(0xC8013EA4)) & M32))) & M32
        v1 = (v1 + ((((v0 << np.uint64(4)) + np.uint64(0xAD90777D)) & M32)
                    ^ ((v0 + s) & M32) ^ (((v0 >> np.uint64(5)) + np.uint64(0x7E95761E)) & M32))) & M32
    return v0, v1


def permute(index, size: int, seed, rounds: int = 4, word: int = PERMUTE_WORD) -> np.ndarray:
    """``mi.permute(index, size, seed, rounds)`` element-wise (size a power of two)."""
    index, seed = np.broadcast_arrays(_u(index), _u(seed))
    index = index.copy()
    for level in range(int(size).bit_length() - 1):
        bit = np.uint64(1 << level)
        rand = sample_tea_32(index | bit, seed, rounds)[word]
        flip = (rand & bit) != 0
        index = np.where(flip, index ^ bit, index)
    return index


@numba.njit(cache=True)
def _tea_word(v0, v1, rounds, word):  # pragma: no cover - numba
    """One word of :func:`sample_tea_32` for scalars (64-bit arithmetic masked to 32)."""
    m = 0xFFFFFFFF
    s = 0
    for _ in range(rounds):
        s = (s + 0x9E3779B9) & m
        v0 = (v0 + ((((v1 << 4) + 0xA341316C) & m) ^ ((v1 + s) & m)
                    ^ (((v1 >> 5) + 0xC8013EA4) & m))) & m
        v1 = (v1 + ((((v0 << 4) + 0xAD90777D) & m) ^ ((v0 + s) & m)
                    ^ (((v0 >> 5) + 0x7E95761E) & m))) & m
    return v0 if word == 0 else v1


@numba.njit(cache=True, parallel=True)
def _permuted(seeds, n, offset, rounds, word, out):  # pragma: no cover - numba
    """:func:`permute` of every sample index j < n for each pixel's seed + ``offset``."""
    levels = 0
    while (1 << levels) < n:
        levels += 1
    for r in numba.prange(seeds.shape[0]):
        seed = (seeds[r] + offset) & 0xFFFFFFFF
        for j in range(n):
            index = j
            for level in range(levels):
                bit = 1 << level
                if _tea_word(index | bit, seed, rounds, word) & bit:
                    index ^= bit
            out[r, j] = index


def _permuted_indices(seeds: np.ndarray, n: int, offset: int) -> np.ndarray:
    """(R, N) ``permute(j, N, seed + offset, LD_ROUNDS)`` compiled (the numpy
    :func:`permute` is the reference)."""
    out = np.empty((len(seeds), n), dtype=np.int64)
    _permuted(np.ascontiguousarray(seeds, dtype=np.int64), int(n), int(offset), LD_ROUNDS,
              PERMUTE_WORD, out)
    return out.astype(np.uint64)


def _reverse32(v: np.ndarray) -> np.ndarray:
    out = np.zeros_like(v)
    for t in range(32):
        out |= ((v >> np.uint64(t)) & np.uint64(1)) << np.uint64(31 - t)
    return out


def _sobol2(v: np.ndarray) -> np.ndarray:
    out = np.zeros_like(v)
    d = np.uint64(1 << 31)
    for t in range(32):
        out ^= np.where((v >> np.uint64(t)) & np.uint64(1), d, np.uint64(0))
        d = d ^ (d >> np.uint64(1))
    return out


def _float(bits: np.ndarray) -> np.ndarray:
    """The float32 in [0, 1) of Mitsuba's ``(bits >> 9) | 0x3f800000`` minus 1."""
    f = ((bits >> np.uint64(9)) | np.uint64(0x3F800000)).astype(np.uint32).view(np.float32)
    return f.astype(np.float64) - 1.0


def _scaled(bits: np.ndarray) -> np.ndarray:
    """``sobol_2``'s float: the 32-bit integer to float32 (rounded), times 2^-32."""
    return (bits.astype(np.float32) * np.float32(2.0 ** -32)).astype(np.float64)


def ldsampler_points(scramble_seeds, n: int, dims: int) -> np.ndarray:
    """(R, N, dims, 2): ``next_2d`` of ``dims`` consecutive dimensions (from index 0) for
    every sample of R pixels with the given per-pixel scramble seeds (N a power of two).

    >>> p = ldsampler_points([1, 2], 4, 2)
    >>> p.shape, sorted((p[0, :, 0, 0] * 4).astype(int).tolist())   # one point per column
    ((2, 4, 2, 2), [0, 1, 2, 3])
    """
    seeds = _u(scramble_seeds).reshape(-1, 1)
    sx, sy = sample_tea_32(seeds, np.uint64(0x98BC51AB))
    out = np.empty((seeds.shape[0], n, dims, 2))
    for d in range(dims):
        i = _permuted_indices(seeds[:, 0], n, d)
        out[:, :, d, 0] = _float(_reverse32(i) ^ sx)
        out[:, :, d, 1] = _scaled(_sobol2(i) ^ sy)
    return out


def ldsampler_numbers(scramble_seeds, n: int, call: int) -> np.ndarray:
    """(R, N): ``next_1d`` at dimension index ``call`` for every sample of R pixels —
    ``radical_inverse_2(permute(j, N, scramble_seed + call), sample_tea_32(scramble_seed,
    0x48bc48eb).first)`` (``ldsampler.cpp``: ``next_1d``), x read as a float32 mantissa as
    :func:`ldsampler_points` reads it.

    >>> u = ldsampler_numbers([5], 8, 2)
    >>> sorted((u[0] * 8).astype(int).tolist())          # one number in each eighth
    [0, 1, 2, 3, 4, 5, 6, 7]
    """
    seeds = _u(scramble_seeds).reshape(-1, 1)
    i = _permuted_indices(seeds[:, 0], n, call)
    return _float(_reverse32(i) ^ sample_tea_32(seeds, np.uint64(0x48BC48EB))[0])


def pixel_scramble_seeds(count: int, seed: int) -> np.ndarray:
    """``count`` per-pixel scramble seeds: uniform 32-bit words (``numpy.random.default_rng
    (seed)``), as ``compute_per_sequence_seed`` (4 rounds of TEA) makes of consecutive pixel
    seeds."""
    return np.random.default_rng(seed).integers(0, 1 << 32, size=int(count), dtype=np.uint64)
