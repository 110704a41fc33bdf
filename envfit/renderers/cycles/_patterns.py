r"""Cycles' sampling patterns as its kernel draws them (blender/cycles @ v5.0.0; the same code in
Blender 5.0.1 and on its main branch of 2026-07): the points a pixel's film, light and BSDF
requests read under *Tabulated Sobol* (``tabulated_sobol``, the factory scene's "Classic") and
*Blue Noise* (``blue_noise``: what *Automatic*, a new scene's pattern, renders a final frame
with) — for the adaptive model (:mod:`envfit.renderers.cycles._adaptive`) and for the fixed-spp
model's drawn blue noise (:data:`BLUE_NOISE`).

**The requests of a camera ray's first hit** (``src/kernel/types.h``: ``PRNG_FILTER`` 0,
``PRNG_LIGHT`` 1, ``PRNG_SURFACE_BSDF`` 3, ``PRNG_BOUNCE_NUM`` 16;
``src/kernel/integrator/path_state.h``: ``path_state_init_integrator`` sets ``rng_offset`` to
16, ``path_state_next`` adds 16 after the bounce): the film's 2-D request at dimension 0
(``init_from_camera.h``: ``integrate_camera_sample``; sample 0 at the pixel's centre), the
light's 3-D request at 17 and the BSDF's at 19 (``shade_surface.h``); each takes its (x, y)
from the request's first two coordinates.

**Tabulated Sobol** (``src/kernel/sample/tabulated_sobol.h``, ``src/scene/tabulated_sobol.cpp``):
256 tables of L = clamp(next power of two of samples − 1, 256, 8192) 4-D points made by
``tabulated_sobol_generate_4D`` (Helmer, Christensen & Kensler); sample s of request d reads
table ``hash_shuffle_uint(d, 256, seed)`` at ``nested_uniform_scramble(s,
hash_wang_seeded_uint(d, seed)) & (L − 1)``, seed the pixel's hash — a random table and order
per pixel and request (:func:`pattern_points` draws them). The generator is transcribed in
float32 / uint32 as the source computes it (``bench/cycles_tabulated_sobol_nets.py`` checks
its nets).

**Blue noise** (``src/kernel/sample/pattern.h``: ``blue_noise_indexing``,
``path_rng_pixel_init``; ``src/kernel/sample/sobol_burley.h``; Blender's
``intern/cycles/blender/sync.cpp``: ``BlenderSync::sync_integrator`` turns *Automatic* into
``SAMPLING_PATTERN_BLUE_NOISE_PURE`` for a final render, ``BLUE_NOISE_FIRST`` for the
viewport; ``src/scene/integrator.cpp``: ``Integrator::device_update``): one Sobol–Burley
sequence for the whole image — its seed 0, so every request's index shuffle and coordinate
scrambles are the *same fixed* Owen scrambles in every pixel and every render — and pixel p
takes its indices ``sample + p · length``, length = the render's samples (``blue_noise_round``
would round it up to a power of two; ``pure`` does not), p = ``nested_uniform_scramble_base4(
morton2d(x, y), hash_uint(seed))``. What varies from pixel to pixel is only *which* run of
the sequence it takes. At N = 2^m the run is one aligned block (its high index bits fixed): a
(0, m, 2)-net digitally shifted by the block, then the fixed scramble — not the independent
nested scramble of Tabulated Sobol's tables, so its error is not Owen's (above or below it,
by the integrand: on test integrands 0.65–1.25 × Owen's at 16–256 points, by the request's
fixed scramble). At other N the run straddles aligned blocks, a union of smaller nets.
:data:`BLUE_NOISE` draws the runs of uniformly random pixels (p uniform on 32 bits: over the
pixels of a frame and the seeds, the scrambled Morton code's), exactly as the kernel computes
them (uint32 wrap-around included).

Example
-------
>>> import numpy as np
>>> u = BLUE_NOISE.points(16, 3, np.random.default_rng(0), "light")
>>> u.shape, [sorted(np.floor(u[q, :, 0] * 16).astype(int).tolist()) == list(range(16))
...           for q in range(3)]
((3, 16, 2), [True, True, True])
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from envfit.base import ParameterError

__all__ = ["FILTER", "LIGHT", "BSDF", "PATTERNS", "MIN_TABLE", "MAX_TABLE", "hash_hp_uint",
           "reversed_bit_owen", "nested_uniform_scramble", "class_a", "tabulated_sobol_tables",
           "table_size", "sobol_digits", "sobol_burley_xy", "sobol_burley_z", "blue_noise_indices",
           "pattern_points", "first_hit_points", "film_points_of", "lobe_points_of",
           "BlueNoiseRuns", "BLUE_NOISE"]

U32 = np.uint32

#: the dimensions of the film's, the light's and the BSDF's requests at the first hit
#: (module docstring)
FILTER, LIGHT, BSDF = 0, 16 + 1, 16 + 3
#: each request's width (``path_rng_2D`` / ``path_rng_3D``)
_WIDTH = {FILTER: 2, LIGHT: 3, BSDF: 3}
_STREAMS = {"film": FILTER, "light": LIGHT, "bsdf": BSDF}

#: ``tabulated_sobol_generate_4D``'s xor tables of dimensions 0, 1 and 2
_XORS = (
    (0,) * 32,
    (0x00000000, 0x00000001, 0x00000001, 0x00000007, 0x00000001, 0x00000013, 0x00000015,
     0x0000007f, 0x00000001, 0x00000103, 0x00000105, 0x0000070f, 0x00000111, 0x00001333,
     0x00001555, 0x00007fff, 0x00000001, 0x00010003, 0x00010005, 0x0007000f, 0x00010011,
     0x00130033, 0x00150055, 0x007f00ff, 0x00010101, 0x01030303, 0x01050505, 0x070f0f0f,
     0x01111111, 0x13333333, 0x15555555, 0x7fffffff),
    (0x00000000, 0x00000001, 0x00000003, 0x00000001, 0x00000005, 0x0000001f, 0x0000002b,
     0x0000003d, 0x00000011, 0x00000133, 0x00000377, 0x00000199, 0x00000445, 0x00001ccf,
     0x00002ddb, 0x0000366d, 0x00000101, 0x00010303, 0x00030707, 0x00010909, 0x00051515,
     0x001f3f3f, 0x002b6b6b, 0x003dbdbd, 0x00101011, 0x01303033, 0x03707077, 0x01909099,
     0x04515145, 0x1cf3f3cf, 0x2db6b6db, 0x36dbdb6d),
)
#: ``NUM_TAB_SOBOL_PATTERNS``, ``MIN_TAB_SOBOL_SAMPLES``, ``MAX_TAB_SOBOL_SAMPLES``
#: (``src/kernel/types.h``)
PATTERNS, MIN_TABLE, MAX_TABLE = 256, 256, 8192


def hash_hp_uint(i):
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
    return (hash_hp_uint(i).astype(np.float32) * np.float32(1.0 / 4294967808.0))


def _reverse_bits(x: np.ndarray) -> np.ndarray:
    """``reverse_integer_bits`` on uint32."""
    x = np.asarray(x, dtype=U32)
    x = ((x >> U32(1)) & U32(0x55555555)) | ((x & U32(0x55555555)) << U32(1))
    x = ((x >> U32(2)) & U32(0x33333333)) | ((x & U32(0x33333333)) << U32(2))
    x = ((x >> U32(4)) & U32(0x0F0F0F0F)) | ((x & U32(0x0F0F0F0F)) << U32(4))
    x = ((x >> U32(8)) & U32(0x00FF00FF)) | ((x & U32(0x00FF00FF)) << U32(8))
    return (x >> U32(16)) | (x << U32(16))


def reversed_bit_owen(n, seed) -> np.ndarray:
    """``reversed_bit_owen`` (``src/kernel/sample/util.h``): base-2 Owen scrambling of a
    reversed-bit integer by Vegdahl's Laine–Karras-style hash (each bit flipped by a hash of
    the bits below it); ``n`` and ``seed`` broadcast (uint32)."""
    with np.errstate(over="ignore"):
        n = np.asarray(n, dtype=U32)
        seed = np.asarray(seed, dtype=U32)
        n = n ^ (n * U32(0x3D20ADEA))
        n = n + seed
        n = n * ((seed >> U32(16)) | U32(1))
        n = n ^ (n * U32(0x05526C56))
        return n ^ (n * U32(0x53A22864))


def nested_uniform_scramble(i, seed) -> np.ndarray:
    """``nested_uniform_scramble`` (``src/kernel/sample/util.h``): ``reversed_bit_owen`` on the
    reversed bits; ``i`` and ``seed`` broadcast (uint32)."""
    return _reverse_bits(reversed_bit_owen(_reverse_bits(i), seed))


def class_a(n: int) -> np.ndarray:
    """``sample_is_class_A`` for the samples 0 … n − 1: popcount(s & 0xaaaaaaaa) odd."""
    s = np.arange(int(n), dtype=np.uint64) & np.uint64(0xAAAAAAAA)
    bits = np.zeros(len(s), dtype=np.uint8)
    for b in range(1, 32, 2):
        bits ^= ((s >> np.uint64(b)) & np.uint64(1)).astype(np.uint8)
    return bits.astype(bool)


@functools.lru_cache(maxsize=4)
def tabulated_sobol_tables(size: int, patterns: int = PATTERNS, dims: int = 2) -> np.ndarray:
    """The first ``dims`` (2 or 3) dimensions of the ``patterns`` tables of ``size`` points
    Cycles generates (``tabulated_sobol_generate_4D(points, size, j)``, j = 0 … patterns − 1),
    shape (patterns, size, dims) float32, read-only; the four dimensions' random numbers are
    drawn in the source's order (4 per point) so that these dimensions are the source's."""
    if dims not in (2, 3):
        raise ParameterError(f"dims must be 2 or 3, got {dims!r}")
    size = int(size)
    j = np.arange(patterns, dtype=U32)
    with np.errstate(over="ignore"):
        seed = U32(0x44605A73)
        seed = seed ^ U32(seed << U32(19))                 # hash_hp_seeded_uint(j, 0x44605a73)
        rng = hash_hp_uint(j ^ seed)
    pts = np.zeros((patterns, size, dims), dtype=np.float32)
    with np.errstate(over="ignore"):
        for d in range(dims):
            pts[:, 0, d] = _hash_hp_float(rng + U32(d))
        rng = rng + U32(4)
        n, log_n = 1, 0
        while n < size:
            strata = np.float32(2 * n)
            count = min(n, size - n)
            i = np.arange(count)
            # the random numbers of points n … n + count − 1: 4 each, in order
            base = rng[:, None] + (4 * i).astype(U32)[None, :]
            for d in range(dims):
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


# ----------------------------------------------------------------------------- Sobol–Burley

#: ``sobol_burley_table`` (``src/kernel/tables.h``) of dimensions 0 and 1: dimension 0 is the
#: van der Corput sequence (its fast path), dimension 1 Sobol's second
_SOBOL_1 = np.array([
    0x00000001, 0x00000003, 0x00000005, 0x0000000f, 0x00000011, 0x00000033, 0x00000055,
    0x000000ff, 0x00000101, 0x00000303, 0x00000505, 0x00000f0f, 0x00001111, 0x00003333,
    0x00005555, 0x0000ffff, 0x00010001, 0x00030003, 0x00050005, 0x000f000f, 0x00110011,
    0x00330033, 0x00550055, 0x00ff00ff, 0x01010101, 0x03030303, 0x05050505, 0x0f0f0f0f,
    0x11111111, 0x33333333, 0x55555555, 0xffffffff], dtype=U32)
#: ``sobol_burley_table`` of dimension 2 (Sobol's third)
_SOBOL_2 = np.array([
    0x00000001, 0x00000003, 0x00000006, 0x00000009, 0x00000017, 0x0000003a, 0x00000071,
    0x000000a3, 0x00000116, 0x00000339, 0x00000677, 0x000009aa, 0x00001601, 0x00003903,
    0x00007706, 0x0000aa09, 0x00010117, 0x0003033a, 0x00060671, 0x000909a3, 0x00171616,
    0x003a3939, 0x00717777, 0x00a3aaaa, 0x01170001, 0x033a0003, 0x06710006, 0x09a30009,
    0x16160017, 0x3939003a, 0x77770071, 0xaaaa00a3], dtype=U32)
_SOBOL = {1: _SOBOL_1, 2: _SOBOL_2}
#: the constants ``sobol_burley_sample_2D`` / ``_3D`` xor into the seed: the index
#: shuffle's, then the coordinates x's, y's (and z's: ``_3D``)
_SEEDS = {2: (0xF8ADE99A, 0xE0AAAF76, 0x94964D4E),
          3: (0xCAA726AC, 0x9E78E391, 0x67C33241, 0x78C395C5)}
_TO_FLOAT = np.float32(1.0 / 4294967808.0)          # uint_to_float_excl


def sobol_digits(index, dimension: int) -> np.ndarray:
    """Sobol' point ``index`` of ``dimension`` 0, 1 or 2 unscrambled, as ``sobol_burley``
    holds it before its Owen scramble: uint32 with the point's first binary digit in bit 0
    (the direction numbers of the index's set bits xored; dimension 0 the van der Corput
    fast path)."""
    index = np.asarray(index, dtype=U32)
    if dimension == 0:
        return index.copy()
    result = np.zeros_like(index)
    table = _SOBOL[int(dimension)]
    for t in range(32):
        result ^= np.where((index >> U32(t)) & U32(1), table[t], U32(0))
    return result


def _sobol_burley(rev_index: np.ndarray, dimension: int, seed) -> np.ndarray:
    """``sobol_burley(rev_bit_index, dimension, scramble_seed)`` for dimension 0, 1 or 2: the
    unscrambled digits (:func:`sobol_digits` of the index), Owen-scrambled
    (:func:`reversed_bit_owen`), reversed, to float32 (``uint_to_float_excl``)."""
    result = sobol_digits(_reverse_bits(rev_index), dimension)
    result = _reverse_bits(reversed_bit_owen(result, seed))
    return result.astype(np.float32) * _TO_FLOAT


def sobol_burley_xy(index, dimension_set: int, seed=0, mask: int = 0xFFFFFFFF,
                    width: int = 3) -> np.ndarray:
    """The (x, y) of ``sobol_burley_sample_2D`` (``width`` 2) or ``_3D`` (3) at ``index``
    (uint32, any shape), float32 (…, 2): the seed xored with ``hash_hp_uint(dimension_set)``,
    the reversed index Owen-shuffled and masked, Sobol' dimensions 0 and 1 each scrambled with
    its own seed (``src/kernel/sample/sobol_burley.h``)."""
    c = _SEEDS[int(width)]
    seed = np.asarray(seed, dtype=U32) ^ hash_hp_uint(U32(dimension_set))
    rev = reversed_bit_owen(_reverse_bits(index), seed ^ U32(c[0])) & U32(mask)
    return np.stack([_sobol_burley(rev, 0, seed ^ U32(c[1])),
                     _sobol_burley(rev, 1, seed ^ U32(c[2]))], axis=-1)


def sobol_burley_z(index, dimension_set: int, seed=0, mask: int = 0xFFFFFFFF) -> np.ndarray:
    """The z of ``sobol_burley_sample_3D`` at ``index`` (uint32, any shape), float32: Sobol'
    dimension 2 of the same shuffled index as :func:`sobol_burley_xy` (width 3), scrambled
    with its own seed."""
    c = _SEEDS[3]
    seed = np.asarray(seed, dtype=U32) ^ hash_hp_uint(U32(dimension_set))
    rev = reversed_bit_owen(_reverse_bits(index), seed ^ U32(c[0])) & U32(mask)
    return _sobol_burley(rev, 2, seed ^ U32(c[3]))


def blue_noise_indices(samples: int, pixels, length: int) -> np.ndarray:
    """``blue_noise_indexing`` under ``BLUE_NOISE_PURE``: the indices ``s + p · length`` (uint32,
    wrapping as the kernel's ``uint``) of the samples 0 … samples − 1 of the pixels ``p``
    (uint32, (R,)), shape (R, samples)."""
    s = np.arange(int(samples), dtype=np.uint64)
    p = np.asarray(pixels, dtype=np.uint64).reshape(-1, 1)
    return ((s[None, :] + p * np.uint64(int(length))) & np.uint64(0xFFFFFFFF)).astype(U32)


def _tabulated(samples: int, realizations: int, length: int, rng, streams) -> list:
    """Tabulated Sobol: per pixel and request a distinct random table in its own scrambled
    order (module docstring), the requests' (x, y) (R, samples, 2) float64."""
    size = table_size(length)
    tables = tabulated_sobol_tables(size)
    r = int(realizations)
    pick = np.argsort(rng.random((r, PATTERNS)), axis=1)[:, :3]     # distinct tables
    seeds = rng.integers(0, 1 << 32, size=(r, 3), dtype=np.uint64).astype(U32)
    s = np.arange(int(samples), dtype=U32)
    out = []
    for k in range(len(streams)):
        idx = nested_uniform_scramble(s[None, :], seeds[:, k:k + 1]) & U32(size - 1)
        out.append(tables[pick[:, k:k + 1], idx.astype(np.int64)].astype(np.float64))
    return out


def _blue_noise(samples: int, realizations: int, length: int, rng, streams) -> list:
    """Blue noise: each request's (x, y) at the runs of uniformly random pixels (module
    docstring), (R, samples, 2) float64."""
    p = rng.integers(0, 1 << 32, size=int(realizations), dtype=np.uint64)
    idx = blue_noise_indices(samples, p, length)
    return [sobol_burley_xy(idx, d, 0, 0xFFFFFFFF, _WIDTH[d]).astype(np.float64)
            for d in streams]


def _sobol_burley_pixels(samples: int, realizations: int, length: int, rng, streams) -> list:
    """Sobol–Burley (the debug pattern): each pixel its own sequence, its seed the pixel's
    hash (random here), the index masked by ``sobol_index_mask`` = the bits below the next
    power of two of length − 1, reversed (``Integrator::device_update``)."""
    seeds = rng.integers(0, 1 << 32, size=(int(realizations), 1), dtype=np.uint64).astype(U32)
    top = 1 << (int(length) - 1).bit_length() if length > 1 else 1
    mask = int(_reverse_bits(U32(top - 1)))
    idx = np.broadcast_to(np.arange(int(samples), dtype=U32)[None, :],
                          (int(realizations), int(samples)))
    return [sobol_burley_xy(idx, d, seeds, mask, _WIDTH[d]).astype(np.float64)
            for d in streams]


def pattern_points(sampler: str, samples: int, realizations: int, rng: np.random.Generator,
                   *, film: bool = False, length: int | None = None) -> tuple:
    """The light's and the BSDF's (x, y) of the samples 0 … samples − 1 of ``realizations``
    pixels (two arrays (R, samples, 2), float64) under ``sampler`` (``tabulated_sobol``,
    ``blue_noise`` or the debug pattern ``sobol_burley``) for a render of ``length`` samples (default ``samples``: Tabulated Sobol's
    table size, blue noise's run length); with ``film``, the film position in the pixel too
    (``PRNG_FILTER``; sample 0 at the pixel's centre, which the box filter of width 1 keeps)."""
    streams = (LIGHT, BSDF, FILTER) if film else (LIGHT, BSDF)
    length = int(samples if length is None else length)
    if sampler == "tabulated_sobol":
        out = _tabulated(samples, realizations, length, rng, streams)
    elif sampler == "blue_noise":
        out = _blue_noise(samples, realizations, length, rng, streams)
    elif sampler == "sobol_burley":
        out = _sobol_burley_pixels(samples, realizations, length, rng, streams)
    else:
        raise ParameterError(f"no points of Cycles' {sampler!r} pattern here: "
                             f"tabulated_sobol, blue_noise or sobol_burley")
    if film:
        out[2][:, 0] = 0.5
    return tuple(out)


def _distinct_tables(rng: np.random.Generator, r: int) -> np.ndarray:
    """(r, 3) three distinct tables of :data:`PATTERNS` per pixel, uniformly (the requests'
    ``hash_shuffle_uint`` picks, taken as distinct)."""
    k0 = rng.integers(0, PATTERNS, r)
    k1 = rng.integers(0, PATTERNS - 1, r)
    k1 += k1 >= k0
    lo, hi = np.minimum(k0, k1), np.maximum(k0, k1)
    k2 = rng.integers(0, PATTERNS - 2, r)
    k2 += k2 >= lo
    k2 += k2 >= hi
    return np.stack([k0, k1, k2], axis=1)


@functools.lru_cache(maxsize=4)
def first_hit_points(sampler: str, samples: int, pixels: int, seed: int) -> tuple:
    """The film's (x, y), the light's (x, y) and the BSDF's (x, y, z) of the samples
    0 … samples − 1 of ``pixels`` pixels of a render of ``samples`` spp under ``sampler``
    (``tabulated_sobol``, ``sobol_burley`` or ``blue_noise``; float64 (R, samples, 2 or 3),
    read-only), drawn from ``seed``: each pixel's requests read as the kernel reads them
    (Tabulated Sobol: a random table and index scramble per request; Sobol–Burley: the
    pixel's seed; blue noise: the run of a uniformly random pixel, as :data:`BLUE_NOISE`
    draws them), the film's sample 0 at the pixel's centre
    (``src/kernel/integrator/init_from_camera.h``: ``integrate_camera_sample``), the BSDF's
    z the third coordinate of its 3-D request — what ``surface_shader_bsdf_bssrdf_pick``
    picks a closure with."""
    rng = np.random.default_rng([int(seed), int(samples), 0xC7C1E5])
    r, n = int(pixels), int(samples)
    if sampler == "tabulated_sobol":
        size = table_size(n)
        tables = tabulated_sobol_tables(size, PATTERNS, 3)
        pick = _distinct_tables(rng, r)
        seeds = rng.integers(0, 1 << 32, size=(r, 3), dtype=np.uint64).astype(U32)
        s = np.arange(n, dtype=U32)
        out = []
        for k, width in enumerate((2, 2, 3)):         # film, light, BSDF
            idx = nested_uniform_scramble(s[None, :], seeds[:, k:k + 1]) & U32(size - 1)
            out.append(tables[pick[:, k:k + 1], idx.astype(np.int64), :width].astype(np.float64))
    elif sampler == "sobol_burley":
        seeds = rng.integers(0, 1 << 32, size=(r, 1), dtype=np.uint64).astype(U32)
        top = 1 << (n - 1).bit_length() if n > 1 else 1
        mask = int(_reverse_bits(U32(top - 1)))
        idx = np.broadcast_to(np.arange(n, dtype=U32)[None, :], (r, n))
        out = [sobol_burley_xy(idx, d, seeds, mask, _WIDTH[d]).astype(np.float64)
               for d in (FILTER, LIGHT, BSDF)]
        z = sobol_burley_z(idx, BSDF, seeds, mask).astype(np.float64)
        out[2] = np.concatenate([out[2], z[..., None]], axis=-1)
    elif sampler == "blue_noise":
        p = rng.integers(0, 1 << 32, size=r, dtype=np.uint64)
        idx = blue_noise_indices(n, p, n)
        out = [sobol_burley_xy(idx, d, 0, 0xFFFFFFFF, _WIDTH[d]).astype(np.float64)
               for d in (FILTER, LIGHT, BSDF)]
        z = sobol_burley_z(idx, BSDF, 0, 0xFFFFFFFF).astype(np.float64)
        out[2] = np.concatenate([out[2], z[..., None]], axis=-1)
    else:
        raise ParameterError(f"no first-hit points of Cycles' {sampler!r} pattern here: "
                             f"tabulated_sobol, sobol_burley or blue_noise")
    out[0][:, 0] = 0.5                  # integrate_camera_sample: sample 0 at the centre
    for a in out:
        a.flags.writeable = False
    return tuple(out)


def film_points_of(sampler: str):
    """The record's ``film_points`` of ``sampler`` (:attr:`envfit.renderers.SamplerSpec.
    film_points`): ``(pixels, n, dims, seed) -> (pixels, n, dims, 2)``, dimension 0 the film's,
    1 the light's, 2 the BSDF's (x, y), 3 the BSDF's z twice (:func:`first_hit_points`)."""
    def points(pixels: int, n: int, dims: int, seed: int) -> np.ndarray:
        film, light, bsdf = first_hit_points(sampler, int(n), int(pixels), int(seed))
        planes = [film, light, bsdf[..., :2], np.repeat(bsdf[..., 2:], 2, axis=-1)]
        if not 1 <= dims <= len(planes):
            raise ParameterError(f"Cycles' first hit has {len(planes)} point planes, asked "
                                 f"for {dims}")
        return np.stack(planes[:dims], axis=2)
    return points


def lobe_points_of(sampler: str):
    """The record's ``lobe_points`` of ``sampler`` (:attr:`envfit.renderers.SamplerSpec.
    lobe_points`): ``(pixels, n, call, seed) -> (pixels, n)`` the BSDF request's z (call 3,
    the plane :func:`film_points_of` gives it), the same pixels as ``film_points``."""
    def numbers(pixels: int, n: int, call: int, seed: int) -> np.ndarray:
        if int(call) != 3:
            raise ParameterError(f"Cycles' closure pick reads the BSDF request's z (call 3), "
                                 f"asked for call {call}")
        return first_hit_points(sampler, int(n), int(pixels), int(seed))[2][..., 2]
    return numbers


@dataclass(frozen=True)
class BlueNoiseRuns:
    """The law of Cycles' blue-noise pixels at N spp, the option ``points`` of the
    ``shared_sequence`` randomisation (:mod:`envfit.predict.renderer.randomisation`): each
    pixel's run of the one fixed Sobol–Burley sequence (module docstring), for a request
    (``stream``: ``light``, ``bsdf``, ``film``)."""

    name: str = "cycles_blue_noise"
    source: str = ("blender/cycles @ v5.0.0 src/kernel/sample/pattern.h: blue_noise_indexing, "
                   "path_rng_pixel_init; src/kernel/sample/sobol_burley.h")

    @staticmethod
    def step(n: int) -> int:
        """The spacing of the run starts p·N (mod 2^32) over uniform p: the largest power of
        two dividing N (p·N mod 2^32 is uniform over its multiples)."""
        n = int(n)
        return n & -n

    def runs(self, step: int, length: int, draws: int, rng: np.random.Generator,
             stream: str = "light") -> np.ndarray:
        """``draws`` runs of ``length`` points of request ``stream`` (draws, length, 2),
        float64, each starting at a uniformly random multiple of ``step`` (the pixels of
        N with :meth:`step` = ``step`` read the runs' first N points; the film's sample 0 at
        the pixel's centre)."""
        if stream not in _STREAMS:
            raise ParameterError(f"stream must be one of {', '.join(_STREAMS)}, got {stream!r}")
        d = _STREAMS[stream]
        k = rng.integers(0, (1 << 32) // int(step), size=int(draws), dtype=np.uint64)
        idx = blue_noise_indices(int(length), k * np.uint64(step), 1)
        u = sobol_burley_xy(idx, d, 0, 0xFFFFFFFF, _WIDTH[d]).astype(np.float64)
        if d == FILTER:
            u[:, 0] = 0.5
        return u

    def points(self, n: int, draws: int, rng: np.random.Generator,
               stream: str = "light") -> np.ndarray:
        """``draws`` pixels' N points of request ``stream`` (draws, N, 2), float64 (a fixed-spp
        render: the run's length is N): :meth:`runs` at :meth:`step`."""
        return self.runs(self.step(n), n, draws, rng, stream)


#: Cycles' blue-noise runs (:class:`BlueNoiseRuns`), the ``blue_noise`` sampler's option
BLUE_NOISE = BlueNoiseRuns()
