"""The Cycles preset (Cycles' kernels are not callable from Python here): the importance-map
resolution rule, the cell values of tiny maps worked out by hand (including the periodic
``EXTENSION_REPEAT`` wrap across the poles), the pdf against a sampling histogram and a
quadrature, the orientation of the map in envfit's frame, the frame; and the registry of
all four presets."""
from __future__ import annotations

import numpy as np
import pytest

from envfit.base import ParameterError
from envfit.maps import EnvMap
from envfit.renderers import (PAIRINGS, RENDERERS, RANDOMISATIONS, STRATEGY_NAMES,
                                     CyclesBackground, cycles_frame, cycles_map_resolution,
                                     get_renderer)


def test_resolution_rule():
    assert cycles_map_resolution((1024, 512)) == (4096, 2048)
    assert cycles_map_resolution((8192, 4096)) == (8192, 4096)
    assert cycles_map_resolution((6000, 1000)) == (6000, 2048)
    assert cycles_map_resolution(None) == (4096, 2048)
    assert cycles_map_resolution((64, 32), single_sun=True) == (512, 256)
    assert cycles_map_resolution((64, 32), sampling="manual", map_resolution=256) == (256, 128)
    with pytest.raises(ParameterError):
        cycles_map_resolution((64, 32), sampling="sometimes")


def test_cells_closest_by_hand():
    """Grid = image size, closest: cell (x, y) is file pixel (row H − 1 − y, column x), its
    RGB mean of |L| times sin(π(y + ½)/H)."""
    rgb = np.arange(2 * 4 * 3, dtype=float).reshape(2, 4, 3) - 5.0          # signed values
    t = CyclesBackground(EnvMap(rgb), sampling="manual", map_resolution=4,
                         interpolation="closest")
    assert (t.res_x, t.res_y) == (4, 2)
    want = np.abs(rgb[::-1]).mean(axis=2) * np.sin(np.pi * (np.arange(2) + 0.5) / 2)[:, None]
    np.testing.assert_allclose(t.func, want, rtol=1e-6)


def test_cells_linear_wrap_across_the_poles_by_hand():
    """Linear, H = 2 rows (file top A, bottom B), a 4 × 8 grid: the cell centres v = ⅛, ⅜,
    ⅝, ⅞ read texture rows at y = vH − ½ = −¼, ¼, ¾, 1¼ with both axes periodic, so the
    cells next to the poles blend the opposite pole's row: ¼A + ¾B, ¼A + ¾B, ¾A + ¼B,
    ¾A + ¼B (bottom to top), each times sin θ of its centre."""
    a, b = 3.0, 1.0
    rgb = np.empty((2, 4, 3))
    rgb[0], rgb[1] = a, b
    t = CyclesBackground(EnvMap(rgb), sampling="manual", map_resolution=8)
    sin_t = np.sin(np.pi * (np.arange(4) + 0.5) / 4)
    want = np.array([0.25 * a + 0.75 * b, 0.25 * a + 0.75 * b, 0.75 * a + 0.25 * b,
                     0.75 * a + 0.25 * b]) * sin_t
    np.testing.assert_allclose(t.func, np.repeat(want[:, None], 8, axis=1), rtol=1e-6)
    # the radiance lookup wraps the same way: straight up (+z, v = 1) is ½A + ½B
    np.testing.assert_allclose(t._eval_native(np.array([[0.0, 0.0, 1.0]])), [[2.0] * 3], rtol=1e-6)


def test_compiled_cells_equal_the_separable_numpy_form_bit_for_bit():
    """The compiled importance grid (one cell at a time, read beside the lookup's texels)
    equals the separable numpy form — bilinear along the rows, then across them, float32,
    |·| summed over RGB — bit for bit, on a signed random map with a sun, at the automatic
    4× resolution and a manual one; and so do its rows' compiled CDFs."""
    rng = np.random.default_rng(3)
    rgb = rng.standard_normal((24, 48, 3)) * 0.3 + 0.5
    rgb[5, 40] = 3e4
    for kw in ({}, {"sampling": "manual", "map_resolution": 100}):
        t = CyclesBackground(EnvMap(rgb), **kw, strength=1.7)
        rx, ry = t.res_x, t.res_y
        tex = t.texture
        h, w = tex.shape[:2]

        def axis(coord, n):
            x = coord * n - 0.5
            i = np.floor(x).astype(np.int64)
            return i % n, (i + 1) % n, (x - i).astype(np.float32)
        y0, y1, ty = axis((np.arange(ry) + 0.5) / ry, h)
        x0, x1, tx = axis((np.arange(rx) + 0.5) / rx, w)
        ty = ty[:, None]
        acc = np.zeros((ry, rx), dtype=np.float32)
        for c in range(3):
            rows = tex[y0, :, c] * (1 - ty) + tex[y1, :, c] * ty
            acc += np.abs(rows[:, x0] * (1 - tx) + rows[:, x1] * tx)
        want = (acc / 3.0 * t.strength).astype(np.float64) * np.sin(
            np.pi * (np.arange(ry) + 0.5) / ry)[:, None]
        assert np.array_equal(t.func, want)
        cdf = np.concatenate([np.zeros((ry, 1)), np.cumsum(want, axis=1) / rx], axis=1)
        total = want.sum(axis=1) / rx                      # the rows' CDFs, numpy's form
        cdf = np.where(total[:, None] > 0, cdf / np.where(total > 0, total, 1.0)[:, None], cdf)
        cdf[:, -1] = 1.0
        assert np.array_equal(t._flat, (cdf + 2.0 * np.arange(ry)[:, None]).ravel())


def _sun_map(h=16, seed=8):
    rng = np.random.default_rng(seed)
    a = 0.1 + rng.random((h, 2 * h, 3))
    a[3, 21] *= 5000.0
    return EnvMap(a)


def _sphere_grid(n_z=1000, n_phi=2000):
    z = -1 + (np.arange(n_z) + 0.5) * 2 / n_z
    phi = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    Z, P = np.meshgrid(z, phi, indexing="ij")
    r = np.sqrt(1 - Z ** 2)
    return np.stack([r * np.cos(P), r * np.sin(P), Z], axis=-1).reshape(-1, 3), 4 * np.pi / Z.size


def test_pdf_integrates_to_one_and_matches_samples():
    t = CyclesBackground(_sun_map(), sampling="manual", map_resolution=64)
    g, dw = _sphere_grid()
    assert abs(t.pdf(g).sum() * dw - 1) < 3e-3
    n = 200_000
    d, p = t.sample(np.random.default_rng(9).random((n, 2)))
    np.testing.assert_allclose(t.pdf(d), p, rtol=1e-9)
    nz, nphi = 8, 16                                    # equal-solid-angle cells about +y

    def cell(v):
        iz = np.minimum(((v[:, 1] + 1) / 2 * nz).astype(int), nz - 1)
        ip = np.minimum(((np.arctan2(v[:, 2], v[:, 0]) % (2 * np.pi)) / (2 * np.pi) * nphi)
                        .astype(int), nphi - 1)
        return iz * nphi + ip

    counts = np.bincount(cell(d), minlength=nz * nphi)
    expected = np.bincount(cell(g), weights=t.pdf(g) * dw, minlength=nz * nphi) * n
    assert np.all(np.abs(counts - expected) < 5 * np.sqrt(expected) + 0.01 * expected + 3)


def test_orientation_in_envfit_frame():
    """The same file in Blender: the sun pixel's samples point at envfit's direction of that
    pixel (Blender's frame mirrored in x and rotated into envfit's world)."""
    m = _sun_map()
    t = CyclesBackground(m, sampling="manual", map_resolution=32, interpolation="closest")
    d, _ = t.sample(np.random.default_rng(10).random((20000, 2)))
    want = m.directions()[3, 21]
    near = d @ want > np.cos(0.25)              # the pixel: 0.2 rad in θ, 0.16 in φ sin θ
    assert near.mean() > 0.5
    assert np.dot(d[near].mean(axis=0), want) > 0.99
    np.testing.assert_allclose(t.eval(want[None]), m.data[3, 21][None], rtol=1e-6)


def test_frame_by_hand():
    fr = cycles_frame([[0.0, 0.0, 1.0]])[0]
    np.testing.assert_allclose(fr[0], [S, -S, 0], atol=1e-12)      # (1, 1, 1) × N
    np.testing.assert_allclose(fr[1], [S, S, 0], atol=1e-12)       # N × T
    n = np.array([[1.0, 1.0, 1.0]]) / np.sqrt(3)                   # the other branch
    fr = cycles_frame(n)[0]
    np.testing.assert_allclose(fr @ fr.T, np.eye(3), atol=1e-12)


S = np.sqrt(0.5)


# ----------------------------------------------------------------------------- the registry

@pytest.mark.parametrize("name", ["mitsuba3", "pbrt4", "cycles", "envfit"])
def test_every_preset_is_complete(name):
    p = get_renderer(name)
    assert p is RENDERERS[name] and p.name == name and p.renderer and p.source
    assert set(p.strategies) == set(STRATEGY_NAMES) and p.heuristic in ("power", "balance")
    for spec in p.samplers.values():
        assert spec.randomisation in RANDOMISATIONS and spec.pairing in PAIRINGS
        assert spec.description and spec.spp(16) >= 16
    tech = p.technique(_sun_map())                    # Cycles: the Auto grid, 4096 × 2048
    U = np.random.default_rng(11).random((500, 2))
    d, pdf = tech.sample(U)
    assert d.shape == (500, 3) and np.allclose(np.linalg.norm(d, axis=1), 1)
    assert np.mean(np.isclose(tech.pdf(d), pdf, rtol=1e-6)) > 0.99
    assert tech.eval(d).shape == (500, 3) and tech.source
    c = p.cosine(U)
    np.testing.assert_allclose(c.pdf, c.directions[:, 2] / np.pi, atol=1e-12)
    fr = p.tangent_frame(d)
    np.testing.assert_allclose(np.einsum("kij,klj->kil", fr, fr), np.repeat(np.eye(3)[None], 500, 0),
                               atol=1e-9)
    np.testing.assert_allclose(fr[:, 2], d, atol=1e-12)
    wm, wb = p.mis_weights(pdf, c.pdf[:500])
    np.testing.assert_allclose(wm + wb, 1.0)
    for s in STRATEGY_NAMES:
        if p.strategy(s).renderable:
            assert isinstance(p.snippet(s, spp=16), str)
        else:
            with pytest.raises(ParameterError):
                p.snippet(s)


def test_registry_refuses_unknown_names():
    with pytest.raises(ParameterError):
        get_renderer("maya")
    with pytest.raises(ParameterError):
        get_renderer("mitsuba3").sampler("halton")
    with pytest.raises(ParameterError):
        get_renderer("cycles").snippet("map")                 # light-only: debug builds only
    with pytest.raises(ParameterError):
        get_renderer("mitsuba3").sampler().spp(0)
    assert get_renderer("cycles").default_sampler == "tabulated_sobol"
    assert get_renderer("mitsuba3").default_sampler == "independent"


@pytest.mark.parametrize("interpolation", ["linear", "closest"])
@pytest.mark.parametrize("fractions", [(0.5, 0.5), (0.0, 1.0)])
def test_compiled_bsdf_lookup_is_eval_and_the_power_heuristic(interpolation, fractions):
    """The renderer model's compiled lookup (radiance and the BSDF sample's MIS weight at
    ``local @ frame``) equals the technique's numpy eval, pdf and power_heuristic, poles and
    the seam included."""
    from oracles.numpy_kernels import bsdf_lookup_numpy, hemisphere_directions
    rng = np.random.default_rng(3)
    env = EnvMap(rng.random((16, 32, 3)) * 4 + 0.1)
    t = CyclesBackground(env, sampling="manual", map_resolution=64, interpolation=interpolation)
    loc = hemisphere_directions(rng, 5000)
    frame = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    rad, w = t.bsdf_lookup(loc, frame, *fractions)
    want_rad, want_w = bsdf_lookup_numpy(t, loc, frame, *fractions)
    np.testing.assert_allclose(rad, want_rad, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(w, want_w, rtol=1e-9, atol=1e-12)
