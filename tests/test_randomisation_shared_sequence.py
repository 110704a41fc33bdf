"""Cycles' blue noise: its Sobol–Burley transcription against scipy's Sobol' sequence, its
scrambles' nesting, the runs' nets, and the drawn shared-sequence MSE against Owen's exact one
(a per-pixel seed) — and apart from it (the fixed seed)."""
import numpy as np
import pytest
from scipy.stats import qmc

from envfit.base import ParameterError
from envfit.predict.renderer.randomisation import (DyadicGrid, randomised_mse,
                                                   shared_sequence_mse)
from envfit.renderers.cycles._patterns import (BLUE_NOISE, blue_noise_indices, pattern_points,
                                               reversed_bit_owen, sobol_digits)

U32 = np.uint32


def _reverse(x):
    return np.array([int(f"{int(v):032b}"[::-1], 2) for v in np.ravel(x)], dtype=U32)


def test_sobol_digits_are_scipys_sobol_in_gray_code_order():
    i = np.arange(2048, dtype=U32)
    g = i ^ (i >> U32(1))                       # scipy draws Sobol' in Gray-code order
    ours = np.stack([_reverse(sobol_digits(g, d)).astype(np.float64) / 2.0 ** 32
                     for d in (0, 1)], axis=-1)
    assert np.array_equal(ours, qmc.Sobol(2, scramble=False).random(2048))


def test_reversed_bit_owen_is_nested():
    """Output bit j (reversed form: the j-th digit) depends only on input bits 0 … j."""
    rng = np.random.default_rng(3)
    n = rng.integers(0, 1 << 32, 2000, dtype=np.uint64).astype(U32)
    seed = U32(0x9E3779B9)
    base = reversed_bit_owen(n, seed)
    for j in (3, 11, 20):
        flipped = reversed_bit_owen(n ^ U32(1 << j), seed)
        low = U32((1 << j) - 1)
        assert np.array_equal(base & low, flipped & low)
        assert np.all((base ^ flipped) & U32(1 << j))        # a bijection at each node


@pytest.mark.parametrize("m", [2, 4, 6])
def test_aligned_runs_are_nets(m):
    """At N = 2^m every pixel's run is a (0, m, 2)-net in the light's (x, y)."""
    n = 1 << m
    u = BLUE_NOISE.points(n, 8, np.random.default_rng(m), "light")
    for a in range(m + 1):
        cells = (np.floor(u[..., 0] * (1 << a)) * (1 << (m - a))
                 + np.floor(u[..., 1] * (1 << (m - a))))
        for q in range(8):
            assert len(np.unique(cells[q])) == n


def test_run_indices_wrap_as_uint32():
    idx = blue_noise_indices(3, np.array([0, (1 << 32) - 1], dtype=np.uint64), 5)
    assert idx.dtype == U32
    assert idx.tolist() == [[0, 1, 2], [(2 ** 32 - 5) % 2 ** 32, 2 ** 32 - 4, 2 ** 32 - 3]]


def test_film_sample_zero_is_the_pixel_centre():
    u = BLUE_NOISE.points(8, 4, np.random.default_rng(0), "film")
    assert np.all(u[:, 0] == 0.5) and not np.all(u[:, 1] == 0.5)


class _PerPixel:
    """Cycles' Sobol–Burley debug pattern: the same code with a random seed per pixel."""

    @staticmethod
    def step(n):
        return 1

    def runs(self, step, length, draws, rng, stream="light"):
        return pattern_points("sobol_burley", length, draws, rng)[0]


_PER_PIXEL = _PerPixel()


def _disk(u):
    return (((u[:, 0] - 0.3) ** 2 + (u[:, 1] - 0.6) ** 2 < 0.01) * 10.0 + u[:, 0])


@pytest.mark.parametrize("n", [16, 64])
def test_per_pixel_seed_is_owen_fixed_seed_is_not(n):
    grid = DyadicGrid.from_callable(_disk, 8, nodes=2)
    owen = randomised_mse("owen", grid, n).mse[0]
    q = 4096
    per = randomised_mse("shared_sequence", grid, n, points=_PER_PIXEL, draws=q, seed=1).mse[0]
    se = owen * np.sqrt(2.0 / (q - 1)) * 2.0       # heavy-tailed errors: twice the normal SE
    assert abs(per - owen) < 4 * se, (per, owen)
    fixed = randomised_mse("shared_sequence", grid, n, points=BLUE_NOISE, draws=q,
                           seed=1).mse[0]
    assert abs(fixed - owen) > 4 * se, (fixed, owen)


def test_shared_sequence_refuses_a_law_without_points():
    grid = DyadicGrid.from_callable(_disk, 4)
    with pytest.raises(ParameterError, match="points"):
        shared_sequence_mse(grid, 16, points=object())
    with pytest.raises(ParameterError, match="stream"):
        shared_sequence_mse(grid, 16, points=BLUE_NOISE, stream="camera")


# ------------------------------------------------- the renderer model's drawn runs
def _sunny(h: int = 16):
    from envfit.maps import EnvMap
    th = (np.arange(h) + 0.5) / h * np.pi
    ph = (np.arange(2 * h) + 0.5) / (2 * h) * 2 * np.pi
    data = 0.3 + 0.2 * np.cos(th)[:, None, None] * np.sin(ph)[None, :, None] * np.ones(3)
    data[h // 3, h // 2] = [60.0, 50.0, 40.0]
    return EnvMap(data.astype(np.float32), up="y")


def _cycles_with(law):
    """Cycles' record with its blue-noise sampler drawing ``law``'s runs."""
    from dataclasses import replace

    from envfit.renderers import get_renderer
    cyc = get_renderer("cycles")
    spec = replace(cyc.samplers["blue_noise"], options=lambda n: (("points", law),))
    return replace(cyc, samplers={**cyc.samplers, "blue_noise": spec})


@pytest.mark.parametrize("strategy", ["mis", "brdf"])
def test_model_runs_of_a_per_pixel_seed_are_the_exact_owen_model(strategy):
    """The model's drawn runs (class runs, prefix sums, a bracket's every N, both streams of
    one pixel) with each pixel's scramble seeded at random equal Tabulated Sobol's exact
    Owen model, at powers of two and between them (its prefix model)."""
    from envfit.predict.renderer import DiffuseModel, RendererModelOptions
    opts = RendererModelOptions(normals=8, pool=64, max_level=7)
    env = _sunny()
    drawn = DiffuseModel(env, _cycles_with(_PER_PIXEL), options=opts)
    exact = DiffuseModel(env, _cycles_with(BLUE_NOISE), options=opts)
    for n in (16, 64, 48, 100):
        d = drawn.predict(strategy, "blue_noise", n)
        e = exact.predict(strategy, "tabulated_sobol", n)
        assert d.rmse == pytest.approx(e.rmse, rel=0.12), (n, d.rmse, e.rmse)
    assert len(drawn._cache) > 64                         # 48 and 100 brought their brackets


def test_model_blue_noise_off_the_powers_of_two_is_a_run_not_an_interpolation():
    """Between powers of two each N is its own runs (not the anchors' power law), and the
    cross term of the two streams (the same pixels' runs) is measured, not assumed 0."""
    from envfit.predict.renderer import DiffuseModel, RendererModelOptions
    from envfit.renderers import get_renderer
    m = DiffuseModel(_sunny(), get_renderer("cycles"),
                     options=RendererModelOptions(normals=8, pool=64, max_level=7))
    p = {n: m.predict("mis", "blue_noise", n) for n in (64, 100, 127, 128)}
    assert all(not m._is_between(m.request("mis", "blue_noise", n)) for n in p)
    law = np.sqrt(p[64].mse.mean() * p[128].mse.mean())       # the anchors' midpoint
    assert abs(p[100].mse.mean() / law - 1) > 0.05 or abs(p[127].mse.mean() / law - 1) > 0.05
    assert p[100].parts["cross"] != 0.0
