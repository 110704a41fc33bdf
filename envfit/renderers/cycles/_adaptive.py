r"""Cycles' adaptive sampling as its source runs it (blender/cycles @ v5.0.0; the same code in
Blender 5.0.1 and on its main branch of 2026-07), and the points a pixel of the Tabulated
Sobol pattern draws — everything the adaptive model
(:mod:`envfit.predict.renderer._adaptive`) needs of Cycles.

**The settings** (``src/scene/integrator.cpp``: ``Integrator::get_adaptive_sampling``).
Blender's *Noise Threshold* τ (default 0.01; 0 = automatic: max(0.001, 1/samples)) and *Min
Samples* (default 0 = automatic: max(4, ⌈16/τ^0.3⌉) — "threshold 0.1 → 32, 0.01 → 64,
0.001 → 128"); the threshold the kernel compares is 5τ ("arbitrary factor"); the step is 16.

**When a pixel is tested** (``src/integrator/adaptive_sampling.cpp``: ``need_filter``,
``align_samples``): after the 0-based sample s with s > min_samples and s & 15 = 15, i.e. at the
sample counts n = 16k > min_samples + 1; the render's work is cut so that every pixel stops
exactly there. A final render (``background``) compares the full threshold from the first
test on (``src/integrator/render_scheduler.cpp``: the progressive noise floor is for
viewport renders only).

**The test** (``src/kernel/film/adaptive_sampling.h``:
``film_adaptive_sampling_convergence_check``). The pixel holds the sum I of its samples and,
in the auxiliary pass, A = 2 × the sum of its *class A* samples (``src/kernel/film/
light_passes.h``: ``film_write_adaptive_buffer``; ``src/kernel/sample/pattern.h``:
``sample_is_class_A``: popcount(s & 0xaaaaaaaa) odd, which splits every 16 consecutive samples
8 : 8). With n its samples,

.. math::  e = \frac{\sum_c |I_c - A_c| / n}{10^{-4} + g(\sum_c I_c / n)},\qquad
           g(x) = \sqrt{x}\ (x < 1),\ x\ (x \ge 1),

and the pixel has converged when e < 5τ.

**Its neighbours** (``film_adaptive_sampling_filter_x``, ``_y``): after each test a pixel whose
3 × 3 neighbourhood holds an unconverged pixel is marked unconverged, so a pixel stops at the
first test where it and its eight neighbours pass (each of them sampled as long as it was).

**The points** (``src/kernel/sample/tabulated_sobol.h``, ``src/scene/tabulated_sobol.cpp``):
256 tables (``NUM_TAB_SOBOL_PATTERNS``) of L = clamp(next power of two of samples − 1, 256,
8192) 4-D points made by ``tabulated_sobol_generate_4D`` (Helmer, Christensen & Kensler);
sample s of a pixel's request of dimension d reads table ``hash_shuffle_uint(d, 256, seed)``
at ``nested_uniform_scramble(s, hash_wang_seeded_uint(d, seed)) & (L − 1)``, seed the pixel's
hash. The light's and the BSDF's 3-D requests (``PRNG_LIGHT``, ``PRNG_SURFACE_BSDF``) take
their (x, y) from the table's dimensions 0, 1, from two different tables, each index order
scrambled with its own seed: :meth:`CyclesAdaptive.points` draws both for random pixel hashes.
The generator is transcribed in float32 / uint32 as the source computes it
(``bench/cycles_tabulated_sobol_nets.py`` checks its nets).

Example
-------
>>> from envfit.renderers.cycles._adaptive import CYCLES_ADAPTIVE
>>> s = CYCLES_ADAPTIVE.settings(0.01, samples=4096)
>>> s.min_samples, s.scaled_threshold, int(s.checks[0]), int(s.checks[-1])
(64, 0.05, 80, 4096)
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from envfit.base import ParameterError

__all__ = ["AdaptiveSettings", "CyclesAdaptive", "CYCLES_ADAPTIVE", "tabulated_sobol_tables",
           "nested_uniform_scramble", "class_a"]

U32 = np.uint32
_SRC = "blender/cycles @ v5.0.0 "

#: ``tabulated_sobol_generate_4D``'s xor tables of dimensions 0 and 1
_XORS = (
    (0,) * 32,
    (0x00000000, 0x00000001, 0x00000001, 0x00000007, 0x00000001, 0x00000013, 0x00000015,
     0x0000007f, 0x00000001, 0x00000103, 0x00000105, 0x0000070f, 0x00000111, 0x00001333,
     0x00001555, 0x00007fff, 0x00000001, 0x00010003, 0x00010005, 0x0007000f, 0x00010011,
     0x00130033, 0x00150055, 0x007f00ff, 0x00010101, 0x01030303, 0x01050505, 0x070f0f0f,
     0x01111111, 0x13333333, 0x15555555, 0x7fffffff),
)
#: ``NUM_TAB_SOBOL_PATTERNS``, ``MIN_TAB_SOBOL_SAMPLES``, ``MAX_TAB_SOBOL_SAMPLES``
#: (``src/kernel/types.h``)
PATTERNS, MIN_TABLE, MAX_TABLE = 256, 256, 8192


def _hash_hp_uint(i):
    """``hash_hp_uint`` (``src/util/hash.h``), elementwise on uint32."""
    with np.errstate(over="ignore"):
        i = np.asarray(i, dtype=U32)
        i = i ^ (i >> U32(16))
        i = i * U32(0x21F0AAAD)
        i = i ^ (i >> U32(15))
        i = i * U32(0xD35A2D97)
        i = i ^ (i >> U32(15))
        return i ^ U32(0xE6FE3BEB)


def _hash_hp_float(i) -> np.ndarray:
    """``hash_hp_float``: ``uint_to_float_excl(hash_hp_uint(i))`` in float32."""
    return (_hash_hp_uint(i).astype(np.float32) * np.float32(1.0 / 4294967808.0))


def _reverse_bits(x: np.ndarray) -> np.ndarray:
    """``reverse_integer_bits`` on uint32."""
    x = np.asarray(x, dtype=U32)
    x = ((x >> U32(1)) & U32(0x55555555)) | ((x & U32(0x55555555)) << U32(1))
    x = ((x >> U32(2)) & U32(0x33333333)) | ((x & U32(0x33333333)) << U32(2))
    x = ((x >> U32(4)) & U32(0x0F0F0F0F)) | ((x & U32(0x0F0F0F0F)) << U32(4))
    x = ((x >> U32(8)) & U32(0x00FF00FF)) | ((x & U32(0x00FF00FF)) << U32(8))
    return (x >> U32(16)) | (x << U32(16))


def nested_uniform_scramble(i, seed) -> np.ndarray:
    """``nested_uniform_scramble`` (``src/kernel/sample/util.h``): ``reversed_bit_owen`` on the
    reversed bits; ``i`` and ``seed`` broadcast (uint32)."""
    with np.errstate(over="ignore"):
        n = _reverse_bits(i)
        seed = np.asarray(seed, dtype=U32)
        n = n ^ (n * U32(0x3D20ADEA))
        n = n + seed
        n = n * ((seed >> U32(16)) | U32(1))
        n = n ^ (n * U32(0x05526C56))
        n = n ^ (n * U32(0x53A22864))
        return _reverse_bits(n)


def class_a(n: int) -> np.ndarray:
    """``sample_is_class_A`` for the samples 0 … n − 1: popcount(s & 0xaaaaaaaa) odd."""
    s = np.arange(int(n), dtype=np.uint64) & np.uint64(0xAAAAAAAA)
    bits = np.zeros(len(s), dtype=np.uint8)
    for b in range(1, 32, 2):
        bits ^= ((s >> np.uint64(b)) & np.uint64(1)).astype(np.uint8)
    return bits.astype(bool)


@functools.lru_cache(maxsize=4)
def tabulated_sobol_tables(size: int, patterns: int = PATTERNS) -> np.ndarray:
    """Dimensions 0 and 1 of the ``patterns`` tables of ``size`` points Cycles generates
    (``tabulated_sobol_generate_4D(points, size, j)``, j = 0 … patterns − 1), shape
    (patterns, size, 2) float32, read-only; the four dimensions' random numbers are drawn in
    the source's order (4 per point) so that dimensions 0 and 1 are the source's."""
    size = int(size)
    j = np.arange(patterns, dtype=U32)
    with np.errstate(over="ignore"):
        seed = U32(0x44605A73)
        seed = seed ^ U32(seed << U32(19))                 # hash_hp_seeded_uint(j, 0x44605a73)
        rng = _hash_hp_uint(j ^ seed)
    pts = np.zeros((patterns, size, 2), dtype=np.float32)
    with np.errstate(over="ignore"):
        pts[:, 0, 0] = _hash_hp_float(rng)
        pts[:, 0, 1] = _hash_hp_float(rng + U32(1))
        rng = rng + U32(4)
        n, log_n = 1, 0
        while n < size:
            strata = np.float32(2 * n)
            count = min(n, size - n)
            i = np.arange(count)
            # the random numbers of points n … n + count − 1: 4 each, in order
            base = rng[:, None] + (4 * i).astype(U32)[None, :]
            for d in range(2):
                occ = (pts[:, i ^ _XORS[d][log_n], d] * strata).astype(np.uint32)
                pts[:, n:n + count, d] = ((occ ^ U32(1)).astype(np.float32)
                                          + _hash_hp_float(base + U32(d))) / strata
            rng = rng + U32(4 * count)
            n, log_n = 2 * n, log_n + 1
    pts.flags.writeable = False
    return pts


def table_size(samples: int) -> int:
    """L: ``clamp(next_power_of_two(samples − 1), 256, 8192)`` (``Integrator::device_update``;
    ``next_power_of_two(x)`` = 1 << (32 − clz(x)), the power of two above x)."""
    x = int(samples) - 1
    return int(min(max(1 << x.bit_length() if x > 0 else 1, MIN_TABLE), MAX_TABLE))


@dataclass(frozen=True)
class AdaptiveSettings:
    """Cycles' adaptive sampling for one render (module docstring).

    Attributes
    ----------
    threshold : τ as the user sets it (Blender's *Noise Threshold*; the automatic one
        resolved).
    samples : the most samples a pixel takes (Blender's *Max Samples*).
    min_samples : the automatic rule's or the user's (at least 4).
    scaled_threshold : 5τ, what the test compares.
    checks : the sample counts at which a pixel is tested (ascending; the last one is
        ``samples``, where every pixel stops).
    """

    threshold: float
    samples: int
    min_samples: int
    scaled_threshold: float
    checks: np.ndarray


class CyclesAdaptive:
    """Cycles' adaptive sampling (module docstring): its settings, its test and the points of
    the patterns it is modelled for."""

    name = "adaptive sampling"
    words = "Noise Threshold"
    source = _SRC + "src/kernel/film/adaptive_sampling.h, src/scene/integrator.cpp"
    step = 16
    scale = 5.0
    epsilon = 1e-4
    #: a pixel stops only with its (2r + 1)² neighbourhood
    neighbourhood = 1
    #: the sampling patterns whose points :meth:`points` draws
    samplers = ("tabulated_sobol",)
    default_threshold, default_samples = 0.01, 4096

    def settings(self, threshold: float, samples: int = 4096,
                 min_samples: int = 0) -> AdaptiveSettings:
        """The render's settings from Blender's ``adaptive_threshold``, ``samples`` and
        ``adaptive_min_samples`` (0: automatic)."""
        if not isinstance(samples, (int, np.integer)) or not 1 <= samples <= 1 << 24:
            raise ParameterError(f"samples must be an integer from 1 to {1 << 24}, got "
                                 f"{samples!r}")
        if not isinstance(min_samples, (int, np.integer)) or min_samples < 0:
            raise ParameterError(f"min samples must be an integer >= 0, got {min_samples!r}")
        t = float(threshold)
        if not math.isfinite(t) or t < 0:
            raise ParameterError(f"the noise threshold must be >= 0, got {threshold!r}")
        if t == 0.0:
            t = max(0.001, 1.0 / samples)
        if min_samples == 0:
            lo = max(4, math.ceil(np.float32(16.0) / np.float32(t) ** np.float32(0.3)))
        else:
            lo = max(4, int(min_samples))
        first = ((lo + 1) | (self.step - 1)) + 1           # align_samples' first filter
        checks = np.arange(first, samples + 1, self.step, dtype=np.int64)
        if len(checks) == 0 or checks[-1] != samples:
            checks = np.append(checks, samples)
        return AdaptiveSettings(t, int(samples), int(lo), self.scale * t, checks)

    @staticmethod
    def class_a(n: int) -> np.ndarray:
        """Which of the samples 0 … n − 1 are class A (:func:`class_a`)."""
        return class_a(n)

    def error(self, total: np.ndarray, half: np.ndarray, n) -> np.ndarray:
        """e of the test (module docstring) from the sums I (…, C) and A (…, C, twice the
        class-A sum) of n samples."""
        n = np.asarray(n, dtype=np.float64)
        diff = np.sum(np.abs(total - half), axis=-1) / n
        x = np.sum(total, axis=-1) / n
        norm = np.where(x < 1.0, np.sqrt(np.maximum(x, 0.0)), x)
        return diff / (self.epsilon + norm)

    def points(self, sampler: str, samples: int, realizations: int,
               rng: np.random.Generator, *, film: bool = False) -> tuple:
        """The light's and the BSDF's (x, y) of the samples 0 … samples − 1 of
        ``realizations`` pixels with random hashes: two arrays (R, samples, 2), float64 (each
        pixel reads two different tables, each in its own scrambled order); with ``film``, the
        film position in the pixel too (``PRNG_FILTER``, a third table; sample 0 at the
        pixel's centre: ``kernel/integrator/init_from_camera.h``:
        ``integrate_camera_sample``; the box filter of width 1 keeps it)."""
        if sampler not in self.samplers:
            raise ParameterError(f"Cycles' adaptive sampling is modelled for the "
                                 f"{', '.join(self.samplers)} pattern only, not {sampler!r}")
        size = table_size(samples)
        tables = tabulated_sobol_tables(size)
        r = int(realizations)
        pick = np.argsort(rng.random((r, PATTERNS)), axis=1)[:, :3]     # distinct tables
        seeds = rng.integers(0, 1 << 32, size=(r, 3), dtype=np.uint64).astype(U32)
        s = np.arange(int(samples), dtype=U32)
        out = []
        for k in range(3 if film else 2):
            idx = nested_uniform_scramble(s[None, :], seeds[:, k:k + 1]) & U32(size - 1)
            out.append(tables[pick[:, k:k + 1], idx.astype(np.int64)].astype(np.float64))
        if film:
            out[2][:, 0] = 0.5
        return tuple(out)


#: the record's adaptive sampling (:attr:`envfit.renderers.Renderer.adaptive`)
CYCLES_ADAPTIVE = CyclesAdaptive()
