"""The two-lobe renderer model's fast paths (issue 40) equal the plain computations they replace:
the order excess's three-channel kernel, the lobes' BSDF parts without the full accumulator,
the Walsh coefficients of a coarser level read off the top level's transform, the pairing's
points shared across strategies and models."""
from __future__ import annotations

import numpy as np
import pytest

from envfit.renderers import get_renderer


@pytest.mark.parametrize("n", [2, 12, 16])
@pytest.mark.parametrize("with_e", [False, True])
def test_order_sums_rgb_is_the_plain_kernel_bit_for_bit(n, with_e):
    """``_order_sums_rgb`` (one read of a cell for the three channels, ×1/N for N a power of
    two) gives ``_order_sums``' numbers exactly, with and without the emitter's table."""
    from envfit.predict.renderer._lobe_parts import _order_sums, _order_sums_rgb
    rng = np.random.default_rng(n)
    size, r, q = 256, 64 * 8, 8
    lobes = rng.standard_normal((2, size, 3)) ** 2
    e = rng.random((64, 3)) if with_e else np.zeros((1, 3))
    cells = rng.integers(0, size, (r, n))
    cells_e = rng.integers(0, len(e), (r, n)) if with_e else np.zeros((0, 0), np.int64)
    lobe = rng.random((r, n))
    numbers = np.ascontiguousarray(np.stack([lobe, rng.permuted(lobe, axis=1)]))
    total = lobes.mean(axis=1).mean(axis=0) + (e.mean(axis=0) if with_e else 0.0)
    for p in (0.0, 0.3, 0.93):
        want = np.zeros((q, 3))
        _order_sums(lobes, e, cells, cells_e, numbers, p, total, want)
        got = np.zeros((q, 3))
        ab = np.ascontiguousarray(np.concatenate([lobes[0], lobes[1]], axis=1))
        inv = 1.0 / n if n & (n - 1) == 0 else 0.0
        _order_sums_rgb(ab, e, cells.astype(np.int32), cells_e.astype(np.int32), numbers,
                        np.array([p, inv, *total]), got)
        np.testing.assert_array_equal(got, want)


def test_bsdf_parts_are_the_accumulators_parts():
    """``bsdf_parts`` writes what ``accumulate_parts`` adds to a zeroed accumulator's
    ``brdf`` and ``mis_b`` from the BSDF side alone, exactly."""
    from envfit.predict.renderer._microfacet_kernels import PARTS, accumulate_parts, bsdf_parts
    rng = np.random.default_rng(1)
    p = 1000
    side = (rng.random((p, 3)), rng.random(p) * (rng.random(p) > 0.1), rng.random(p),
            rng.random(p) * (rng.random(p) > 0.2))
    for heuristic in ("power", "balance"):
        acc = np.zeros((len(PARTS), p, 3))
        accumulate_parts(acc, None, side, (0.5, 0.5), heuristic)
        brdf, mis_b = np.empty((p, 3)), np.empty((p, 3))
        bsdf_parts(side, (0.5, 0.5), heuristic, brdf, mis_b)
        np.testing.assert_array_equal(brdf, acc[PARTS.index("brdf")])
        np.testing.assert_array_equal(mis_b, acc[PARTS.index("mis_b")])


def test_coarse_walsh_coefficients_are_the_top_levels_first():
    """``_moments`` at a coarse level with a finer ``top``: its Walsh coefficients are the
    top level's first 2^L × 2^L, which a transform of the coarse cell means gives to
    rounding."""
    from envfit.predict.renderer._lobe_parts import _moments
    rng = np.random.default_rng(2)
    fine = 6
    vals = {k: rng.standard_normal((4 ** fine, 3)) ** 2 for k in ("brdf_a", "brdf_b")}
    names = ("brdf_a", "brdf_b")
    top = _moments(dict(vals), fine, fine - 1, names)[2]
    for level in range(fine):
        own = _moments(dict(vals), fine, level, names)
        read = _moments(dict(vals), fine, level, names, fine - 1)
        for k in names:
            np.testing.assert_array_equal(read[0][k], own[0][k])
            m = 1 << level
            np.testing.assert_array_equal(read[2][k], top[k][:, :m, :m])
            np.testing.assert_allclose(read[2][k], own[2][k], rtol=0,
                                       atol=1e-13 * np.abs(top[k]).max())


def _prefix_samplers():
    for name in ("mitsuba3", "cycles", "pbrt4"):
        r = get_renderer(name)
        for s in r.modelled_samplers if hasattr(r, "modelled_samplers") else r.samplers:
            try:
                spec = r.sampler(s)
            except Exception:                               # refused: not modelled
                continue
            if spec.film_points is not None:
                yield name, s


@pytest.mark.parametrize("renderer,sampler", list(_prefix_samplers()))
def test_film_points_of_fewer_dimensions_are_the_first_ones(renderer, sampler):
    """A sampler's ``film_points`` of d dimensions are the first d of more: what lets one
    pairing (``DiffuseModel._pairing``, at ``_pairing_dims``) serve every strategy."""
    fp = get_renderer(renderer).sampler(sampler).film_points
    for n in (4, 16):
        many = fp(64, n, 6 if renderer == "mitsuba3" else 4, 3)
        for d in range(1, many.shape[2]):
            np.testing.assert_array_equal(fp(64, n, d, 3), many[:, :, :d])


def test_a_pairing_is_shared_by_strategies_and_models():
    """One ``PairedFootprint`` per (sampler, N) for every strategy of a model, and the same
    one for a second model alive beside the first (a sized search's final model after its
    pilot)."""
    from envfit.maps import EnvMap
    from envfit.predict.renderer import MicrofacetModel, RendererModelOptions, band_frames
    r = get_renderer("mitsuba3")
    env = EnvMap(np.full((8, 16, 3), 2.0, np.float32))
    frames = band_frames(4, (0.0, 90.0), seed=0)
    opts = RendererModelOptions(max_level=4, shifts=16)
    a = MicrofacetModel(env, r, r.bsdf("roughplastic", 0.3), frames, options=opts)
    b = MicrofacetModel(env, r, r.bsdf("roughplastic", 0.3), frames, options=opts)
    pa = {s: a._pairing(a.request(s, "ldsampler", 16)) for s in ("brdf", "mis")}
    assert pa["brdf"] is pa["mis"]
    assert b._pairing(b.request("mis", "ldsampler", 16)) is pa["mis"]


@pytest.mark.parametrize("n", [2, 12, 16])
def test_order_sums_pair_is_each_streams_kernel_bit_for_bit(n):
    """``_order_sums_pair`` (two streams sharing cells and lobe numbers, one read of a cell)
    gives each stream's ``_order_sums_rgb`` numbers exactly."""
    from envfit.predict.renderer._lobe_parts import _order_sums_pair, _order_sums_rgb
    rng = np.random.default_rng(n + 7)
    size, r, q = 256, 64 * 8, 8
    ab = [rng.standard_normal((size, 6)) ** 2 for _ in range(2)]
    cells = rng.integers(0, size, (r, n)).astype(np.int32)
    lobe = rng.random((r, n))
    numbers = np.ascontiguousarray(np.stack([lobe, rng.permuted(lobe, axis=1)]))
    totals = [t[:, :3].mean(axis=0) * 0.4 + t[:, 3:].mean(axis=0) * 0.6 for t in ab]
    inv = 1.0 / n if n & (n - 1) == 0 else 0.0
    for p in (0.0, 0.4, 0.9):
        both = np.zeros((2, q, 3))
        _order_sums_pair(np.ascontiguousarray(np.concatenate(ab, axis=1)), cells, numbers,
                         np.array([p, inv, *totals[0], *totals[1]]), both)
        for k in range(2):
            one = np.zeros((q, 3))
            _order_sums_rgb(np.ascontiguousarray(ab[k]), np.zeros((1, 3)), cells,
                            np.zeros((0, 0), np.int32), numbers, np.array([p, inv, *totals[k]]),
                            one)
            np.testing.assert_array_equal(both[k], one)
