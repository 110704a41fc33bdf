"""The randomisation predictions against the renderer's OWN generators: Mitsuba 3's samplers
(``scalar_rgb``), driven from Python one pixel at a time (``sampler.seed(seed)``; per sample
``next_2d()`` per dimension, then ``advance()``), over thousands of seeds:

* ``ldsampler`` (spp 16, 64, 256 kept) — its points are the (0, 2)-net XOR a per-pixel shift
  (checked point by point) and its MSE is the digital-shift prediction; its emitter and BSDF
  dimensions (two ``next_2d`` per sample) share the shift: the MIS cross term is predicted;
* ``multijitter`` (16 = 4 × 4, 32 → 35 = 7 × 5, 64) — the correlated multi-jittering
  prediction with Mitsuba's shape over the distribution of its permutations (Kensler's hashes,
  ported and checked against ``mi.permute_kensler``; not uniform: the uniform-permutation
  value is 5–7 % off at spp 16);
* ``stratified`` (16, 32 → 36, 64) — the jittered prediction.

Tolerance: |prediction − brute force| ≤ Z standard errors of the brute force (+1 %)."""
from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from oracles.randomisers import INTEGRANDS, mse_estimate, sobol_digits

from envfit.predict.renderer.randomisation import DyadicGrid, mis_mse, randomised_mse
from envfit.renderers.mitsuba3._kensler import (KENSLER_PERMUTATIONS, multijitter_shape,
                                               permute_kensler)
from envfit.renderers import get_renderer

_LD_POINTS = get_renderer("mitsuba3").sampler("ldsampler").film_points

mi = pytest.importorskip("mitsuba")

SEEDS, Z = 2000, 4.0


@pytest.fixture(scope="module", autouse=True)
def scalar_variant():
    mi.set_variant("scalar_rgb")


@pytest.fixture(scope="module")
def grids():
    return {name: DyadicGrid.from_callable(f.h, 9, nodes=3) for name, f in INTEGRANDS.items()}


@functools.lru_cache(maxsize=None)
def mitsuba_points(kind: str, spp: int, seeds: int, dims: int = 1) -> np.ndarray:
    """(seeds, N, dims, 2): the 2-D samples of ``dims`` consecutive dimensions of one pixel
    per seed (N = the sampler's rounded sample count); cached, shared by the integrands."""
    s = mi.load_dict({"type": kind, "sample_count": spp})
    n = s.sample_count()
    out = np.empty((seeds, n, dims, 2))
    for seed in range(seeds):
        s.seed(seed)
        for i in range(n):
            for d in range(dims):
                p = s.next_2d()
                out[seed, i, d] = p[0], p[1]
            s.advance()
    out.flags.writeable = False
    return out


def _agree(pred: float, points: np.ndarray, name: str) -> None:
    bf, se = mse_estimate(INTEGRANDS[name], points)
    assert abs(pred - bf) <= Z * se + 0.01 * pred, \
        f"{name}: predicted {pred:.4e}, brute force {bf:.4e} ± {se:.1e} (z = {(pred - bf) / se:+.2f})"


def _shift_of(points: np.ndarray, net: np.ndarray) -> tuple[int, int]:
    """The Δ (23-bit digits per coordinate) with points = net ⊕ Δ, as far as single precision
    keeps it: u1 (``radical_inverse_2``: the mantissa of the XOR, truncated) exactly; u2
    (``sobol_2``: the XOR rounded to float) to 4 ulps of 2^-23; None where no Δ fits."""
    x = np.floor(points * 2.0 ** 23).astype(np.int64)              # (N, 2)
    d1 = int(x[0, 0] ^ net[0, 0])
    order = {int(v): j for j, v in enumerate(net[:, 0])}
    idx = [order.get(int(v) ^ d1) for v in x[:, 0]]
    if None in idx or len(set(idx)) != len(idx):
        return None
    d2 = int(x[0, 1] ^ net[idx[0], 1])
    expect = (net[idx, 1] ^ d2) / 2.0 ** 23
    return (d1, d2) if np.all(np.abs(points[:, 1] - expect) <= 4 * 2.0 ** -23) else None


def test_ldsampler_is_the_net_xor_one_shift_per_pixel():
    """Each pixel's points are the net XOR one Δ, and its second 2-D dimension is the very
    same point set in another order (Δ is defined modulo the net, a group under ⊕, so the set
    is what is compared); the set changes from pixel to pixel."""
    for spp in (16, 64, 256):
        pts = mitsuba_points("ldsampler", spp, 4, dims=2)
        assert pts.shape[1] == spp                                     # 16, 64, 256 kept
        net = (sobol_digits(spp) >> np.uint64(9)).astype(np.int64)
        sets = []
        for seed in range(4):
            assert _shift_of(pts[seed, :, 0], net) is not None, (spp, seed)
            first, second = (pts[seed, np.lexsort(pts[seed, :, d].T[::-1]), d] for d in range(2))
            np.testing.assert_array_equal(first, second)
            assert not np.array_equal(pts[seed, :, 0], pts[seed, :, 1])    # another order
            sets.append(first.tobytes())
        assert len(set(sets)) == 4


@pytest.mark.parametrize("name", sorted(INTEGRANDS))
@pytest.mark.parametrize("spp", [16, 64, 256])
def test_ldsampler_is_a_digital_shift(grids, name, spp):
    pts = mitsuba_points("ldsampler", spp, SEEDS if spp < 256 else SEEDS // 2)[:, :, 0]
    res = randomised_mse("digital_shift", grids[name], spp)
    _agree(res.mse[0], pts, name)


@pytest.mark.parametrize("spp", [16, 64])
def test_ldsampler_mis_cross_term(grids, spp):
    one, two = INTEGRANDS["edge"], INTEGRANDS["peak"]
    pts = mitsuba_points("ldsampler", spp, SEEDS, dims=2)
    both = DyadicGrid.from_callable(lambda u: one.h(u) + two.h(u), 9, nodes=3)
    pred = mis_mse("digital_shift", grids["edge"], grids["peak"], spp, shared=True, total=both)
    e1 = one.h(pts[:, :, 0]).mean(axis=1) - one.integral
    e2 = two.h(pts[:, :, 1]).mean(axis=1) - two.integral
    se = np.std(e1 * e2, ddof=1) / math.sqrt(SEEDS)
    assert abs(pred.cross[0] - np.mean(e1 * e2)) <= Z * se + 0.01 * abs(pred.cross[0])
    tot = (e1 + e2) ** 2
    assert abs(pred.mse[0] - tot.mean()) <= Z * tot.std(ddof=1) / math.sqrt(SEEDS) \
        + 0.01 * pred.mse[0]


def test_permute_kensler_port_is_mitsubas():
    rng = np.random.default_rng(3)
    for length in (1, 2, 3, 4, 5, 7, 8, 16, 35):
        for seed in rng.integers(0, 1 << 32, size=20, dtype=np.uint64).tolist():
            mine = permute_kensler(np.arange(length), length, seed)
            assert mine.tolist() == [mi.permute_kensler(i, length, seed) for i in range(length)]


@pytest.mark.parametrize("name", sorted(INTEGRANDS))
@pytest.mark.parametrize("spp", [16, 32, 64])
def test_multijitter_is_correlated_multi_jittering(grids, name, spp):
    """Over Mitsuba's hashed permutations (``permutations=KENSLER_PERMUTATIONS``)."""
    pts = mitsuba_points("multijitter", spp, SEEDS)[:, :, 0]
    nx, ny = multijitter_shape(spp)
    assert pts.shape[1] == nx * ny                                     # 32 → 35
    res = randomised_mse("cmj", grids[name], nx * ny, permutations=KENSLER_PERMUTATIONS)
    _agree(res.mse[0], pts, name)


@pytest.mark.parametrize("name", ["smooth", "edge"])
def test_multijitter_permutations_are_not_uniform(grids, name):
    """At spp 16 (4 × 4) Kensler's hash is far from a uniform permutation of 4: with 30000
    pixels the uniform-permutation value is off by > 4 standard errors (5–7 %), the value over
    Mitsuba's permutation distribution is not."""
    pts = mitsuba_points("multijitter", 16, 15 * SEEDS)[:, :, 0]
    bf, se = mse_estimate(INTEGRANDS[name], pts)
    uniform = randomised_mse("cmj", grids[name], 16).mse[0]
    hashed = randomised_mse("cmj", grids[name], 16, permutations=KENSLER_PERMUTATIONS).mse[0]
    assert abs(uniform - bf) > Z * se
    assert abs(hashed - bf) <= Z * se + 0.01 * hashed


@pytest.mark.parametrize("name", sorted(INTEGRANDS))
@pytest.mark.parametrize("spp", [16, 32, 64])
def test_stratified_is_jittered(grids, name, spp):
    pts = mitsuba_points("stratified", spp, SEEDS)[:, :, 0]
    r = math.isqrt(pts.shape[1])
    assert r * r == pts.shape[1] and r == math.ceil(math.sqrt(spp))    # 32 → 36
    _agree(randomised_mse("jittered", grids[name], r * r).mse[0], pts, name)


def test_multijitter_streams_are_independent():
    """Two dimensions of multijitter: other permutations and fresh jitter, so C12 ≈ 0."""
    one, two = INTEGRANDS["edge"], INTEGRANDS["peak"]
    pts = mitsuba_points("multijitter", 16, SEEDS, dims=2)
    prod = (one.h(pts[:, :, 0]).mean(axis=1) - one.integral) \
        * (two.h(pts[:, :, 1]).mean(axis=1) - two.integral)
    assert abs(prod.mean()) <= Z * prod.std(ddof=1) / math.sqrt(SEEDS)


def test_ldsampler_pairs_consecutive_dimensions_by_their_van_der_corput_digits():
    """A known limit of the model (issue 25, ``ldsampler`` at 1024 spp): Mitsuba orders each
    dimension's points by ``permute(index, N, seed + dimension)`` (``random.h``: a shuffling
    network of 2-round TEA hashes), and consecutive dimensions' orders are correlated. The
    product of the first binary digits of u1 in two dimensions, (−1)^(d + d'), has a pixel
    mean of variance exactly 1/(N − 1) under a uniform pairing of the two nets (each holds
    N/2 points of either digit: hypergeometric); Mitsuba's measures 3× that at 64 spp and
    8.6× at 256 (15× at 1024 with 500 seeds), while u2's digit pairs as a uniform pairing
    does. The film position is such a dimension, so the film × direction interaction of a
    pixel's footprint (``_footprint``: Var c/(N − 1) for randomly paired nets) is
    underpredicted where it varies with u1."""
    for spp, seeds, low in ((64, SEEDS, 2.2), (256, 400, 4.0)):
        pts = mitsuba_points("ldsampler", spp, seeds, dims=2)
        n = pts.shape[1]
        ratio = []
        for c in (0, 1):
            sign = np.where(pts[..., c] < 0.5, 1.0, -1.0)
            ratio.append(float((sign[:, :, 0] * sign[:, :, 1]).mean(axis=1).var(ddof=1)
                               * (n - 1)))
        assert ratio[0] > low, (spp, ratio)
        assert 0.8 < ratio[1] < 1.3, (spp, ratio)


def test_ldsampler_port_repeats_mitsubas_points():
    """The numpy port of ``ldsampler`` (``randomisation._ldsampler``: TEA, the shuffling
    network at 2 rounds, the per-sequence seed) gives Mitsuba's points exactly, so the
    pairing of the test above can be computed without Mitsuba (and reproduces it: (N − 1) ×
    the variance 2.8–3.0 at 64 spp, 8.2 at 256)."""
    from envfit.renderers.mitsuba3._ldsampler import (ldsampler_points, permute,
                                                                  sample_tea_32)
    pts = mitsuba_points("ldsampler", 64, SEEDS, dims=2)
    port = ldsampler_points(sample_tea_32(0, np.arange(SEEDS), 4)[0], 64, 2)
    np.testing.assert_array_equal(port, pts)
    for value, seed in ((5, 123), (200, 2 ** 31 + 7), (77, 0)):
        assert int(permute(value, 256, seed)) == mi.permute(value, 256, seed)
        assert tuple(int(w) for w in sample_tea_32(value, seed)) == mi.sample_tea_32(value, seed)


def test_ldsampler_lobe_numbers_are_mitsubas_next_1d():
    """``ldsampler_numbers`` (``next_1d`` at a dimension index, in the sampler's order) is
    Mitsuba's own third call after two ``next_2d`` — where ``path`` draws a BSDF's lobe
    number — for the same per-pixel seeds as the port's 2-D points."""
    from envfit.renderers.mitsuba3._ldsampler import ldsampler_numbers, sample_tea_32
    s = mi.load_dict({"type": "ldsampler", "sample_count": 64})
    got = np.empty((8, 64))
    for seed in range(8):
        s.seed(seed)
        for i in range(64):
            s.next_2d()
            s.next_2d()
            got[seed, i] = s.next_1d()
            s.advance()
    port = ldsampler_numbers(sample_tea_32(0, np.arange(8), 4)[0], 64, 2)
    np.testing.assert_array_equal(port, got)


def test_paired_footprint_is_mitsubas_film_by_direction_interaction():
    """The model of that pairing (``_footprint.PairedFootprint``: the port's points over
    2^20/N pixels of random scramble seeds, the film's weights bilinear across the pixel)
    against Mitsuba's own points: a film × direction interaction c = (p_x − ½)(u_x − ½), the
    footprint's two columns of normals at x = ¼ and ¾, has the pixel MSE of Mitsuba's
    ``ldsampler`` (dimension 0 the film's, 1 the emitter's; 400 seeds) at 256 spp within Z
    standard errors — 4–6× the (1/144)/(N − 1) of a uniform pairing."""
    from envfit.predict.renderer._footprint import PairedFootprint
    n, level = 256, 10
    pts = mitsuba_points("ldsampler", n, 400, dims=2)
    c = ((pts[:, :, 0, 0] - 0.5) * (pts[:, :, 1, 0] - 0.5)).mean(axis=1) ** 2
    direct, se = c.mean(), c.std(ddof=1) / math.sqrt(len(c))
    m = 1 << level
    u0 = np.repeat((np.arange(m) + 0.5) / m, m) - 0.5                # u0 the slow index
    tables = np.stack([(x - 0.5) * u0 for _ in (0, 1) for x in (0.25, 0.75)])[..., None]
    model, model_se = PairedFootprint(n, (1 << 20) // n, 0, _LD_POINTS).extra({"map": tables}, "map")
    assert abs(model[0] - direct) <= Z * math.hypot(se, model_se[0]), (model, direct, se)
    assert 4.0 < direct * 144 * (n - 1) < 6.5
