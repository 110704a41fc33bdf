"""How Mitsuba 3's ``ldsampler`` pairs a BSDF's lobe number with the 2-D samples around it:
the MSE of a two-lobe estimator under the sampler's own orders against a random lobe order.

``ldsampler`` orders each dimension's points by a shuffling network seeded with the pixel's
scramble seed + the dimension (``include/mitsuba/core/random.h``: ``permute``, two rounds of
TEA; ``src/samplers/ldsampler.cpp``: ``next_1d``, ``next_2d``), ported in
:mod:`envfit.renderers.mitsuba3._ldsampler`. The model of a two-lobe BSDF
(``randomisation.lobe_choice_mse``) takes the lobe numbers as paired at random with the 2-D
points. This script draws R pixels of N samples in ``path``'s layout (film call 0, emitter
2-D call 1, lobe number call 2, BSDF 2-D call 3) and in ``direct``'s BSDF-only layout (BSDF
2-D call 1, lobe number call 2), evaluates a test estimator — an emitter bump plus lobe a (a
bump) or lobe b (a cosine) picked when the lobe number is below p — and prints the variance
of the pixel mean under the exact orders over that under a random permutation of each
pixel's lobe numbers, and the same for the lobe term (s_j − q)·d(x_j) alone.

    python bench/ldsampler_lobe_pairing.py --pixels 4000
"""
from __future__ import annotations

import argparse

import numpy as np

from envfit.renderers.mitsuba3._ldsampler import (  # internal: the sampler's port, its own orders
    LD_ROUNDS, M32, _float, _reverse32, ldsampler_points, permute, pixel_scramble_seeds,
    sample_tea_32)


def _bump(x, y, cx, cy, k, h):
    return h * np.exp(-k * ((x - cx) ** 2 + (y - cy) ** 2))


def lobe_numbers(seeds, n: int, call: int) -> np.ndarray:
    """``next_1d`` at dimension ``call`` for N samples of each pixel (R, N)."""
    j = np.arange(n, dtype=np.uint64)[None, :]
    i = permute(j, n, (seeds + np.uint64(call)) & M32, LD_ROUNDS)
    return _float(_reverse32(i) ^ sample_tea_32(seeds, np.uint64(0x48BC48EB))[0])


def ratios(n: int, pixels: int, layout: tuple, p: float = 0.37, seed: int = 3) -> tuple:
    """(MSE ratio of the estimator, variance ratio of the lobe term) at N spp."""
    rng = np.random.default_rng(seed)
    emitter, lobe, bsdf = layout
    seeds = pixel_scramble_seeds(pixels, seed).reshape(-1, 1)
    s = (lobe_numbers(seeds, n, lobe) < p).astype(float)
    pts = ldsampler_points(seeds, n, 4)
    xb, yb = pts[:, :, bsdf, 0], pts[:, :, bsdf, 1]
    fe = 0.0 if emitter is None else (_bump(pts[:, :, emitter, 0], pts[:, :, emitter, 1],
                                            0.7, 0.2, 40, 6) + pts[:, :, emitter, 0])
    a, b = _bump(xb, yb, 0.3, 0.6, 30, 5), np.cos(2 * np.pi * yb) + 1
    su = rng.permuted(s, axis=1)

    def total(sel):
        return (fe + sel * a + (1 - sel) * b).mean(axis=1)

    def term(sel):
        return ((sel - sel.mean(axis=1, keepdims=True)) * (a - b)).mean(axis=1)

    return (float(np.var(total(s)) / np.var(total(su))),
            float(np.var(term(s)) / np.var(term(su))))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pixels", type=int, default=4000)
    ap.add_argument("--spp", type=int, nargs="+", default=[16, 64, 256, 1024])
    a = ap.parse_args(argv)
    for name, layout in (("path: emitter call 1, lobe 2, BSDF 3", (1, 2, 3)),
                         ("direct, BSDF only: BSDF call 1, lobe 2", (None, 2, 1))):
        for n in a.spp:
            total, term = ratios(n, a.pixels, layout)
            print(f"{name}: {n:5d} spp  MSE exact/random order {total:.3f}, lobe term "
                  f"{term:.3f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
