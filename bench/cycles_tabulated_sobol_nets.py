"""What one pixel of Cycles' Tabulated Sobol pattern uses for one 2-D request, checked by
re-running Cycles' own generator (numpy transcription, uint32 arithmetic, float32 points):

1. ``nested_uniform_scramble(i, seed) & (L − 1)`` for i < N = 2^m (``tabulated_sobol.h``,
   ``tabulated_sobol_shuffled_sample_index``): the high bits are the same for every i, the
   low m bits are a permutation of 0 … N − 1 — so the pixel's N points are ONE aligned block
   of N consecutive entries of the table;
2. every aligned block of 2^m points of a table made by ``tabulated_sobol_generate_4D``
   (``scene/tabulated_sobol.cpp``, Helmer, Christensen & Kensler) is a (0, m, 2)-net in the
   table's dimensions (0, 1) — the (x, y) of the light's and of the BSDF's 3-D request (z
   picks the light or the closure) — while dimensions (1, 2) and, from m = 6, (0, 2) are not
   (printed for contrast: Sobol' dimensions beyond the first two have t > 0).

Sources: blender/cycles @ v5.0.0 ``src/util/hash.h`` (``hash_hp_uint``,
``hash_hp_seeded_uint``, ``uint_to_float_excl``), ``src/kernel/sample/util.h``
(``reversed_bit_owen``, ``nested_uniform_scramble``), ``src/scene/tabulated_sobol.cpp``.

Run: ``python bench/cycles_tabulated_sobol_nets.py [--tables 16]`` (< 1 s); prints, per pair
of dimensions and m, how many aligned blocks are nets, and how many (seed, m) index sets are
one aligned block. Result (v5.0.0): 800/800 index sets are blocks; in dims (0, 1) every
block is a net for m = 2, 4, 6, 8; in dims (1, 2) none is.
"""
from __future__ import annotations

import argparse

import numpy as np

U32 = np.uint32
_XORS = [
    [0] * 32,
    [0x00000000, 0x00000001, 0x00000001, 0x00000007, 0x00000001, 0x00000013, 0x00000015,
     0x0000007f, 0x00000001, 0x00000103, 0x00000105, 0x0000070f, 0x00000111, 0x00001333,
     0x00001555, 0x00007fff, 0x00000001, 0x00010003, 0x00010005, 0x0007000f, 0x00010011,
     0x00130033, 0x00150055, 0x007f00ff, 0x00010101, 0x01030303, 0x01050505, 0x070f0f0f,
     0x01111111, 0x13333333, 0x15555555, 0x7fffffff],
    [0x00000000, 0x00000001, 0x00000003, 0x00000001, 0x00000005, 0x0000001f, 0x0000002b,
     0x0000003d, 0x00000011, 0x00000133, 0x00000377, 0x00000199, 0x00000445, 0x00001ccf,
     0x00002ddb, 0x0000366d, 0x00000101, 0x00010303, 0x00030707, 0x00010909, 0x00051515,
     0x001f3f3f, 0x002b6b6b, 0x003dbdbd, 0x00101011, 0x01303033, 0x03707077, 0x01909099,
     0x04515145, 0x1cf3f3cf, 0x2db6b6db, 0x36dbdb6d],
]


def hash_hp_uint(i):
    with np.errstate(over="ignore"):
        i = U32(i)
        i ^= i >> U32(16)
        i = U32(i * U32(0x21F0AAAD))
        i ^= i >> U32(15)
        i = U32(i * U32(0xD35A2D97))
        i ^= i >> U32(15)
        return U32(i ^ U32(0xE6FE3BEB))


def hash_hp_float(i) -> np.float32:
    return np.float32(np.float32(hash_hp_uint(i)) * np.float32(1.0 / 4294967808.0))


def generate(size: int, rng_seed: int) -> np.ndarray:
    """``tabulated_sobol_generate_4D`` (dimensions 0–2; the 4th is not needed here)."""
    pts = np.zeros((size, 3), dtype=np.float32)
    with np.errstate(over="ignore"):               # hash_hp_seeded_uint(rng_seed, 0x44605a73)
        seed = U32(0x44605A73)
        seed ^= U32(seed << U32(19))
        rng_i = int(hash_hp_uint(U32(rng_seed) ^ seed))
    for d in range(3):
        pts[0, d] = hash_hp_float(rng_i + d)
    rng_i += 4
    n, log_n = 1, 0
    while n < size:
        strata = np.float32(2 * n)
        for i in range(n):
            if n + i >= size:
                break
            for d in range(3):
                occ = int(pts[i ^ _XORS[d][log_n], d] * strata)
                pts[n + i, d] = (np.float32(occ ^ 1) + hash_hp_float(rng_i + d)) / strata
            rng_i += 4
        n, log_n = 2 * n, log_n + 1
    return pts


def reverse_bits(x):
    x = np.asarray(x, dtype=np.uint64) & 0xFFFFFFFF
    r = np.zeros_like(x)
    for b in range(32):
        r |= ((x >> np.uint64(b)) & np.uint64(1)) << np.uint64(31 - b)
    return r.astype(np.uint32)


def reversed_bit_owen(n, seed):
    with np.errstate(over="ignore"):
        n = np.asarray(n, dtype=np.uint32)
        seed = U32(seed)
        n = n ^ (n * U32(0x3D20ADEA))
        n = n + seed
        n = n * (U32(seed >> U32(16)) | U32(1))
        n = n ^ (n * U32(0x05526C56))
        n = n ^ (n * U32(0x53A22864))
        return n


def nested_uniform_scramble(i, seed):
    return reverse_bits(reversed_bit_owen(reverse_bits(i), seed))


def is_net(p: np.ndarray, m: int) -> bool:
    """Every elementary box of volume 2^-m (all splits a + b = m) holds one point."""
    for a in range(m + 1):
        ix = np.floor(p[:, 0].astype(np.float64) * 2 ** a).astype(int)
        iy = np.floor(p[:, 1].astype(np.float64) * 2 ** (m - a)).astype(int)
        if len(set(zip(ix.tolist(), iy.tolist()))) != len(p):
            return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tables", type=int, default=32)
    ap.add_argument("--length", type=int, default=256, help="table length (256 for spp <= 257)")
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    blocks = 0
    for seed in rng.integers(0, 2 ** 32, 200, dtype=np.uint64):
        for m in (2, 4, 6, 8):
            idx = nested_uniform_scramble(np.arange(2 ** m), int(seed)) & np.uint32(args.length - 1)
            hi = idx >> np.uint32(m)
            blocks += bool(np.all(hi == hi[0]) and sorted((idx & np.uint32(2 ** m - 1)).tolist())
                           == list(range(2 ** m)))
    print(f"index sets that are one aligned block: {blocks}/{200 * 4}")
    for dims in ((0, 1), (1, 2), (0, 2)):
        for m in (2, 4, 6, 8):
            good = total = 0
            for t in range(args.tables):
                pts = generate(args.length, t)
                for k in range(args.length // 2 ** m):
                    total += 1
                    good += is_net(pts[k * 2 ** m:(k + 1) * 2 ** m][:, dims], m)
            print(f"dims {dims}, m = {m}: aligned blocks that are (0, m, 2)-nets {good}/{total}")


if __name__ == "__main__":
    main()
