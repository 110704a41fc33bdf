r"""Brute-force randomisations of N points on the unit square, and test integrands with closed-form
integrals: the second algorithm the exact predictions of
:mod:`envfit.predict.renderer.randomisation` are checked against. Nothing here imports envfit.

Each ``*_points(rng, reps, ...)`` returns an array (reps, N, 2): ``reps`` independent
randomisations of one point set, built the way the method is defined (not from the prediction's
formulas):

* :func:`jittered_points` — r × r strata, a uniform point in each;
* :func:`kensler_cmj_points` — Kensler's (2013) array algorithm, §3 of the memo: the canonical
  multi-jittered arrangement, then the x coordinates swapped between rows by *one*
  Fisher–Yates shuffle shared by all columns, and the y coordinates between columns likewise;
* :func:`sobol_digits` — the (0, 2)-sequence by Mitsuba's loops (``radical_inverse_2`` by bit
  reversal, ``sobol_2`` by its ``v ^= v >> 1`` loop);
* :func:`xor_shifted_points` — a uniform random 32-bit XOR per replicate (both coordinates);
* :func:`owen_scrambled_points` — nested uniform scrambling bit by bit: digit s of a coordinate
  is flipped by a random bit drawn for each distinct prefix (digits 1…s−1) in that replicate,
  and the digits below the net's resolution, all 0 with distinct prefixes, become a uniform
  random tail; :func:`owen_tabled_points` the same scramble with each digit's flips drawn as
  one table of 2^(s−1) bits per replicate, looked up by prefix (O(N) per digit: for N in the
  thousands);
* :func:`pbrt_scrambled_points` — pbrt-v4's own hashed scramblers, ported from
  ``src/pbrt/util/lowdiscrepancy.h`` (``FastOwenScrambler``: Laine–Karras-style
  multiply-xor on the reversed bits; ``OwenScrambler``: bit by bit, the flip of bit b a bit of
  ``MixBits((v & prefix mask) ^ seed)``, ``src/pbrt/util/hash.h``), one random 32-bit seed per
  replicate and coordinate as ``PaddedSobolSampler::Get2D`` draws them from its hash.

:func:`mse_estimate` gives the mean of (F − I)² over the replicates and its standard error.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np


@dataclass(frozen=True)
class Integrand:
    """h on [0, 1)² (vectorised over (..., 2)) and its exact integral."""

    name: str
    h: Callable[[np.ndarray], np.ndarray]
    integral: float


def _smooth(u):
    return np.exp(0.9 * u[..., 0]) * (1.0 + 0.5 * np.sin(3.0 * u[..., 1] + 0.4)) \
        + u[..., 0] * u[..., 1] ** 2


def _edge(u):
    return 1.0 + 0.2 * u[..., 1] + 2.0 * (u[..., 0] + 0.7 * u[..., 1] > 0.63)


PEAK_CENTRE, PEAK_WIDTH, PEAK_HEIGHT = (0.3127, 0.6841), 0.03, 20.0


def _peak(u):
    d2 = (u[..., 0] - PEAK_CENTRE[0]) ** 2 + (u[..., 1] - PEAK_CENTRE[1]) ** 2
    return 1.0 + PEAK_HEIGHT * np.exp(-d2 / (2.0 * PEAK_WIDTH ** 2))


def _peak_integral() -> float:
    """1 + height · ∫∫ of the Gaussian over the square (erf per axis, exact)."""
    s = PEAK_WIDTH * math.sqrt(2.0)
    per_axis = [0.5 * math.sqrt(math.pi) * s * (math.erf((1 - c) / s) + math.erf(c / s))
                for c in PEAK_CENTRE]
    return 1.0 + PEAK_HEIGHT * per_axis[0] * per_axis[1]


INTEGRANDS = {
    "smooth": Integrand("smooth", _smooth,
                        (math.e ** 0.9 - 1) / 0.9 * (1 + 0.5 * (math.cos(0.4) - math.cos(3.4)) / 3)
                        + 1.0 / 6.0),
    # the region u1 + 0.7 u2 > 0.63 has area 0.9·0.37 + 0.35·0.81 + 0.1 = 0.7165
    "edge": Integrand("edge", _edge, 1.0 + 0.1 + 2.0 * 0.7165),
    "peak": Integrand("peak", _peak, _peak_integral()),
}


def jittered_points(rng: np.random.Generator, reps: int, r: int) -> np.ndarray:
    a, b = np.meshgrid(np.arange(r), np.arange(r), indexing="ij")
    cells = np.stack((a.ravel(), b.ravel()), axis=-1)[None]
    return (cells + rng.random((reps, r * r, 2))) / r


def _shuffles(rng: np.random.Generator, reps: int, n: int) -> np.ndarray:
    """``reps`` uniform random permutations of n (Fisher–Yates, one per row)."""
    perm = np.tile(np.arange(n), (reps, 1))
    for j in range(n - 1):
        k = j + (rng.random(reps) * (n - j)).astype(np.int64)
        rows = np.arange(reps)
        perm[rows, j], perm[rows, k] = perm[rows, k].copy(), perm[rows, j].copy()
    return perm


def kensler_cmj_points(rng: np.random.Generator, reps: int, m: int, n: int) -> np.ndarray:
    """Kensler's correlated multi-jittering, m columns × n rows (N = m·n), array form:
    p[j·m + i] = ((i + (j + ξ)/n)/m, (j + (i + η)/m)/n); then x swapped between rows j and
    k (same k for every column i), y between columns i and k (same k for every row j)."""
    i = np.arange(m)[None, None, :]
    j = np.arange(n)[None, :, None]
    x = (i + (j + rng.random((reps, n, m))) / n) / m            # [rep, j, i]
    y = (j + (i + rng.random((reps, n, m))) / m) / n
    rows = _shuffles(rng, reps, n)                              # row j takes x of row rows[j]
    cols = _shuffles(rng, reps, m)
    x = np.take_along_axis(x, rows[:, :, None].repeat(m, axis=2), axis=1)
    y = np.take_along_axis(y, cols[:, None, :].repeat(n, axis=1), axis=2)
    return np.stack((x.reshape(reps, -1), y.reshape(reps, -1)), axis=-1)


def sobol_digits(n: int) -> np.ndarray:
    """The first n points of (van der Corput, Sobol' dimension 2) as 32-bit integers."""
    out = np.zeros((n, 2), dtype=np.uint64)
    for idx in range(n):
        rev = int(f"{idx:032b}"[::-1], 2)
        y, v, i = 0, 1 << 31, idx
        while i:
            if i & 1:
                y ^= v
            i >>= 1
            v ^= v >> 1
        out[idx] = (rev, y)
    return out


def xor_shifted_points(rng: np.random.Generator, reps: int, digits: np.ndarray) -> np.ndarray:
    shift = rng.integers(0, 1 << 32, size=(reps, 1, 2), dtype=np.uint64)
    return (digits[None] ^ shift).astype(np.float64) / 2.0 ** 32


def owen_scrambled_points(rng: np.random.Generator, reps: int, digits: np.ndarray,
                          m: int) -> np.ndarray:
    """Nested uniform scrambling of the first 2^m points (whose digits beyond m are 0)."""
    n = digits.shape[0]
    out = np.empty((reps, n, 2))
    rep = np.repeat(np.arange(reps, dtype=np.int64), n)
    for d in range(2):
        top = (digits[:, d] >> np.uint64(32 - m)).astype(np.int64)      # the first m digits
        top = np.tile(top, reps)
        scr = np.zeros_like(top)
        for s in range(m):                                                # digit s + 1
            prefix = top >> (m - s)                                       # digits 1..s
            keys, inverse = np.unique(rep * (1 << s) + prefix, return_inverse=True)
            flip = rng.integers(0, 2, size=keys.size)[inverse]
            bit = (top >> (m - 1 - s)) & 1
            scr |= (bit ^ flip) << (m - 1 - s)
        out[:, :, d] = ((scr + rng.random(reps * n)) / float(1 << m)).reshape(reps, n)
    return out


def _reverse32(v: np.ndarray) -> np.ndarray:
    v = v.astype(np.uint32)
    out = np.zeros_like(v)
    for t in range(32):
        out |= ((v >> np.uint32(t)) & np.uint32(1)) << np.uint32(31 - t)
    return out


def fast_owen(v: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """pbrt-v4 ``FastOwenScrambler(seed)(v)`` on uint32 arrays."""
    u32 = np.uint32
    with np.errstate(over="ignore"):
        v = _reverse32(v)
        v ^= v * u32(0x3D20ADEA)
        v = v + seed
        v = v * ((seed >> u32(16)) | u32(1))
        v ^= v * u32(0x05526C56)
        v ^= v * u32(0x53A22864)
    return _reverse32(v)


def _mix_bits(v: np.ndarray) -> np.ndarray:
    u64 = np.uint64
    with np.errstate(over="ignore"):
        v = v ^ (v >> u64(31))
        v = v * u64(0x7FB5D329728EA185)
        v = v ^ (v >> u64(27))
        v = v * u64(0x81DADEF4BC2DD44D)
        return v ^ (v >> u64(33))


def pbrt_owen(v: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """pbrt-v4 ``OwenScrambler(seed)(v)`` on uint32 arrays."""
    v = v.astype(np.uint64) & np.uint64(0xFFFFFFFF)
    seed = seed.astype(np.uint64)
    v = np.where(seed & np.uint64(1), v ^ np.uint64(1 << 31), v)
    for b in range(1, 32):
        mask = np.uint64((0xFFFFFFFF << (32 - b)) & 0xFFFFFFFF)
        flip = (_mix_bits((v & mask) ^ seed) & np.uint64(1 << b)) != 0
        v = np.where(flip, v ^ np.uint64(1 << (31 - b)), v)
    return v.astype(np.uint32)


def pbrt_scrambled_points(rng: np.random.Generator, reps: int, digits: np.ndarray,
                          scrambler: str) -> np.ndarray:
    """(reps, N, 2): the net's 32-bit points scrambled per replicate and coordinate by pbrt's
    ``"fastowen"`` or ``"owen"`` scrambler with uniformly random 32-bit seeds."""
    f = {"fastowen": fast_owen, "owen": pbrt_owen}[scrambler]
    seeds = rng.integers(0, 1 << 32, size=(reps, 1, 2), dtype=np.uint64).astype(np.uint32)
    v = np.broadcast_to(digits.astype(np.uint32)[None], (reps,) + digits.shape)
    return f(v, np.broadcast_to(seeds, v.shape)).astype(np.float64) / 2.0 ** 32


def owen_tabled_points(rng: np.random.Generator, reps: int, digits: np.ndarray,
                       m: int) -> np.ndarray:
    """:func:`owen_scrambled_points` with the flips of digit s + 1 a (reps, 2^s) table of
    random bits indexed by the prefix (digits 1..s): the same nested uniform scramble."""
    n = digits.shape[0]
    out = np.empty((reps, n, 2))
    rows = np.arange(reps)[:, None]
    for d in range(2):
        top = (digits[:, d] >> np.uint64(32 - m)).astype(np.int64)
        scr = np.zeros((reps, n), dtype=np.int64)
        for s in range(m):
            table = rng.integers(0, 2, size=(reps, 1 << s))
            flip = table[rows, (top >> (m - s))[None, :]]
            scr |= (((top >> (m - 1 - s)) & 1)[None, :] ^ flip) << (m - 1 - s)
        out[:, :, d] = (scr + rng.random((reps, n))) / float(1 << m)
    return out


def mse_estimate(integrand: Integrand, points: np.ndarray) -> tuple[float, float]:
    """Mean over replicates of (F − I)², F the mean of h over each replicate's points, and its
    standard error."""
    err2 = (integrand.h(points).mean(axis=1) - integrand.integral) ** 2
    return float(err2.mean()), float(err2.std(ddof=1) / math.sqrt(err2.size))
