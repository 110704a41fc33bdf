"""Drawn correlated multi-jittered and orthogonal-array point sets
(``randomisation._strata_samples``) and the renderer model's drawn cells above the exact
models' reach (``DiffuseModel._strata_cell``):

* every drawn set has the construction's strata (one point per coarse cell and per fine row
  and column; an orthogonal array's p × p strata of every 2-D projection once each);
* the variance over the draws equals the exact models (``cmj`` with uniform and with
  Mitsuba's Kensler permutations, ``orthogonal`` at an even and an odd dimension) on a
  piecewise-constant integrand, within 4 standard errors;
* in the renderer model, a drawn cell equals the exact cell at the same N (a coarser grid
  forces the drawing) within its own reported error, and a cell between two drawn anchors is
  their local power law.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from envfit.maps import EnvMap
from envfit.predict.renderer import DiffuseModel, RendererModelOptions
from envfit.predict.renderer.randomisation import (DyadicGrid, randomised_mse,
                                                   sampled_strata_mse, strata_points)
from envfit.renderers import get_renderer

Z = 4.0


def _grid_function(level: int, channels: int = 1, seed: int = 3):
    """A piecewise-constant integrand on the 2^level grid (a ramp, a step and noise) and its
    exact grid (no power above it)."""
    m = 1 << level
    x = (np.arange(m) + 0.5) / m
    rng = np.random.default_rng(seed)
    a = (x[:, None] + 2.0 * (x[None, :] > 0.37) + 0.5 * rng.random((m, m)))
    a = np.stack([a * (1.0 + 0.3 * c) for c in range(channels)])           # (C, M, M)
    return a, DyadicGrid.from_arrays(a, a * a)


def _drawn_mse(a: np.ndarray, name: str, n: int, draws: int, seed: int = 0, **opts):
    """The drawn estimate (mse (C,), standard error (C,)) of the integrand ``a`` (C, M, M)."""
    m = a.shape[-1]
    u = strata_points(name, n, draws, seed, **opts)
    cells = np.minimum((u * m).astype(np.int64), m - 1)
    vals = np.moveaxis(a[:, cells[..., 0], cells[..., 1]], 0, -1)          # (Q, N, C)
    mse, _ = sampled_strata_mse(vals)
    f = vals.mean(axis=1)
    fourth = ((f - f.mean(axis=0)) ** 2).var(axis=0, ddof=1)
    return mse, np.sqrt(fourth / draws)


@pytest.mark.parametrize("n", [12, 16, 35])
def test_cmj_sets_have_the_construction_strata(n):
    from envfit.predict.renderer.randomisation._cmj import cmj_shape
    nx, ny = cmj_shape(n)
    u = strata_points("cmj", nx * ny, 5, 1)
    for s in u:
        assert sorted(np.floor(s[:, 0] * nx * ny).astype(int)) == list(range(nx * ny))
        assert sorted(np.floor(s[:, 1] * nx * ny).astype(int)) == list(range(nx * ny))
        coarse = np.floor(s[:, 0] * nx).astype(int) * ny + np.floor(s[:, 1] * ny).astype(int)
        assert sorted(coarse) == list(range(nx * ny))


@pytest.mark.parametrize("dimension", [2, 5])
def test_orthogonal_sets_are_arrays_of_strength_two(dimension):
    p = 5
    for s in strata_points("orthogonal", p * p, 4, 2, dimension=dimension):
        cells = np.floor(s * p).astype(int)
        assert len({(int(a), int(b)) for a, b in cells}) == p * p    # every p x p stratum once
        for axis in range(2):
            assert sorted(np.floor(s[:, axis] * p * p).astype(int)) == list(range(p * p))


@pytest.mark.parametrize("n, opts", [(16, {}), (12, {"nx": 4, "ny": 3}), (25, {})])
def test_drawn_cmj_equals_the_exact_model(n, opts):
    a, grid = _grid_function(5)
    exact = randomised_mse("cmj", grid, n, **opts).mse
    mse, se = _drawn_mse(a, "cmj", n, 20000, **opts)
    assert np.all(np.abs(mse - exact) <= Z * se), (mse, exact, se)


def test_drawn_cmj_with_kensler_permutations_equals_its_pair_table_model():
    from envfit.renderers.mitsuba3._kensler import KENSLER_PERMUTATIONS
    a, grid = _grid_function(4, seed=5)
    n, opts = 12, {"nx": 4, "ny": 3, "permutations": KENSLER_PERMUTATIONS}
    exact = randomised_mse("cmj", grid, n, **opts).mse
    uniform = randomised_mse("cmj", grid, n, nx=4, ny=3).mse
    mse, se = _drawn_mse(a, "cmj", n, 40000, seed=4, **opts)
    assert np.all(np.abs(mse - exact) <= Z * se), (mse, exact, se)
    assert abs(exact[0] / uniform[0] - 1.0) > 0.01          # the laws differ: a real check


@pytest.mark.parametrize("dimension", [2, 5])
def test_drawn_orthogonal_array_equals_the_exact_model(dimension):
    a, grid = _grid_function(5, channels=2, seed=7)
    exact = randomised_mse("orthogonal", grid, 25, dimension=dimension).mse
    mse, se = _drawn_mse(a, "orthogonal", 25, 20000, seed=dimension, dimension=dimension)
    assert np.all(np.abs(mse - exact) <= Z * se), (mse, exact, se)


def test_drawn_sets_refuse_what_they_cannot_draw():
    from envfit.base import ParameterError
    with pytest.raises(ParameterError, match="no drawn point sets"):
        strata_points("owen", 16, 4, 0)
    with pytest.raises(ParameterError, match="at least 2"):
        strata_points("cmj", 16, 1, 0)
    with pytest.raises(ParameterError, match="p prime"):
        strata_points("orthogonal", 16, 4, 0)


def _map() -> EnvMap:
    """A small map with a bright patch (a sun of sorts) on a gradient."""
    h, w = 16, 32
    y, x = np.mgrid[0:h, 0:w]
    px = 1.0 + 0.5 * np.sin(x / 5.0)[..., None] * np.ones(3) + 0.2 * (y / h)[..., None]
    px[3:5, 20:23] = 40.0
    return EnvMap(px)


def _diffuse(env, r, level):
    return DiffuseModel(env, r, options=RendererModelOptions(normals=6, pool=64, max_level=level))


def _ggx(env, r, level, bsdf=("ggx", 0.3)):
    from envfit.predict.renderer import MicrofacetModel, band_frames
    return MicrofacetModel(env, r, r.bsdf(*bsdf), band_frames(6, seed=1),
                           options=RendererModelOptions(max_level=level))


@pytest.mark.parametrize("make", [_diffuse, _ggx])
@pytest.mark.parametrize("sampler, n", [("multijitter", 16), ("orthogonal", 25)])
def test_a_drawn_model_cell_equals_the_exact_cell(sampler, n, make):
    """At N above a coarse grid's reach the model draws (the diffuse surface's normals, a
    one-lobe microfacet BSDF's frames: ``MicrofacetModel._drawn_parts``); a fine grid takes
    the same N exactly: the two agree within the drawn cell's reported error (its draws'
    part) over the same normals or frames."""
    r, env = get_renderer("mitsuba3"), _map()
    exact, drawn = make(env, r, 6), make(env, r, 3)
    for strategy in ("mis", "map", "brdf"):
        e, d = exact.predict(strategy, sampler, n), drawn.predict(strategy, sampler, n)
        assert drawn._drawn_strata(drawn.request(strategy, sampler, n))
        assert not exact._drawn_strata(exact.request(strategy, sampler, n))
        err = d.model_se_parts[1]
        assert err > 0
        assert abs(d.rmse / e.rmse - 1.0) <= Z * err + 0.02, (strategy, d.rmse, e.rmse, err)


def test_a_two_lobe_bsdfs_cells_are_never_drawn():
    """A rough plastic's lobe choice is modelled on the grid: its cells are not drawn."""
    r = get_renderer("mitsuba3")
    plastic = _ggx(_map(), r, 3, ("roughplastic", 0.3))
    for sampler, n in (("multijitter", 16), ("orthogonal", 25)):
        assert not plastic._drawn_strata(plastic.request("map", sampler, n))


def test_a_cell_between_drawn_anchors_is_their_local_power_law():
    r = get_renderer("mitsuba3")
    m = DiffuseModel(_map(), r, options=RendererModelOptions(normals=4, pool=32, max_level=3))
    mid = m.predict("mis", "orthogonal", 361)         # 19²: between 17² (256's) and 23² (512's)
    assert m._strata_anchors(m.request("mis", "orthogonal", 361)) == (289, 529)
    lo, hi = m.predict("mis", "orthogonal", 289), m.predict("mis", "orthogonal", 529)
    t = math.log(361 / 289) / math.log(529 / 289)
    want = lo.mse * (hi.mse / lo.mse) ** t
    assert np.allclose(mid.mse, want, rtol=1e-12)
    assert mid.model_se == max(lo.model_se, hi.model_se)
