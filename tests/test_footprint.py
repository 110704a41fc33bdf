"""The pixel footprint of the diffuse renderer model (envfit.predict.renderer._footprint with
DiffuseModel): a sphere R pixels across, each normal in its nearest view."""
from __future__ import annotations

import numpy as np
import pytest

from envfit.base import ParameterError
from envfit.maps import EnvMap
from envfit.predict.renderer import DiffuseModel, RendererModelOptions, pixel_footprints
from envfit.renderers import get_renderer


def _sun_map(h: int = 16) -> EnvMap:
    """A dim sky with a small sun: the footprint of a big pixel matters where the sun grazes."""
    rng = np.random.default_rng(5)
    data = 0.2 + 0.05 * rng.random((h, 2 * h, 3))
    data[h // 4, h // 2] = 400.0
    return EnvMap(data.astype(np.float32), up="y", name="sun")


def test_nearest_views_are_the_cube_layouts():
    """Each normal's view is the VIEWS axis of its largest component (the view that keeps it
    in the renders' cube layout)."""
    from envfit.predict.renderer._footprint import nearest_views
    rng = np.random.default_rng(0)
    n = rng.standard_normal((500, 3))
    v = nearest_views(n)
    k = np.argmax(np.abs(n), axis=1)
    want = np.zeros_like(n)
    want[np.arange(len(n)), k] = np.sign(n[np.arange(len(n)), k])
    np.testing.assert_array_equal(v, want)


@pytest.mark.parametrize("name", ["mitsuba3", "pbrt4"])
def test_diffuse_footprint_independent_is_the_pixels_variance(name):
    """Independent points, a sphere 6 pixels across: N × MSE per normal is
    E_p Var_u g + Var_p E_u g over the footprint's tables (summed here directly; the model
    keeps running sums), the part over the pixel (all but the footprint mean's Var_u ḡ)
    scaled by J/(J − 1) from the J midpoints to the pixel; the points-only model (no
    footprint) differs from it."""
    p = get_renderer(name)
    opts = dict(normals=3, pool=32, max_level=4)
    env = _sun_map()
    m = DiffuseModel(env, p, None, RendererModelOptions(**opts, sphere_pixels=6, footprint_side=3))
    plain = DiffuseModel(env, p, None, RendererModelOptions(**opts))
    fine = 5
    strategies = ("map", "brdf", "mis")
    for strategy in strategies:
        streams = {"map": ("map",), "brdf": ("brdf",), "mis": ("mis_e", "mis_b")}[strategy]
        truth = []
        for normal, foot in m.normals:
            vals = [m._point_parts({strategy}, x, fine) for x in foot]
            g = {t: np.stack([v[t] for v in vals]) for t in streams}
            total = sum(x.mean(axis=1) for x in g.values())
            every = sum(np.mean(x.var(axis=1), axis=0) for x in g.values()) + total.var(axis=0)
            main = sum(x.mean(axis=0).var(axis=0) for x in g.values())      # Var_u ḡ
            k = len(foot) / (len(foot) - 1)
            truth.append(main + k * (every - main))
        want = m.weights @ np.array(truth)
        got = m.predict(strategy, "independent", 16).mse * 16
        np.testing.assert_allclose(got, want, rtol=1e-6, err_msg=strategy)
        assert not np.allclose(plain.predict(strategy, "independent", 16).mse * 16, want,
                               rtol=1e-3)


def test_diffuse_footprint_options():
    """sphere_pixels must be an integer >= 4 and footprint_side 1..8; the model's normals
    carry footprint_side² footprint normals each, about the normal."""
    with pytest.raises(ParameterError):
        RendererModelOptions(sphere_pixels=3)
    with pytest.raises(ParameterError):
        RendererModelOptions(sphere_pixels=16, footprint_side=0)
    m = DiffuseModel(_sun_map(), get_renderer("mitsuba3"), None,
                    RendererModelOptions(normals=4, pool=32, max_level=3, sphere_pixels=64))
    for normal, foot in m.normals:
        assert foot.shape == (4, 3)
        assert np.allclose(foot.mean(axis=0), normal, atol=0.05)
    n = np.array([normal for normal, _ in m.normals])
    from envfit.predict.renderer._footprint import nearest_views
    np.testing.assert_allclose(pixel_footprints(n, nearest_views(n), 64, 2),
                               np.stack([f for _, f in m.normals]))


def test_diffuse_footprint_ldsampler_is_the_pairing_simulated():
    """Mitsuba's ``ldsampler`` on a diffuse sphere 6 pixels across: per normal, the
    footprint mean's randomised MSE plus the pairing's share over Mitsuba's own order
    (``PairedFootprint``: the film's dimension 0 with the emitter's 1 and the BSDF's 3, as
    ``path`` draws them) on the footprint normals' own tables, not Var c/(N − 1)."""
    from envfit.predict.renderer._footprint import footprint_term
    m = DiffuseModel(_sun_map(), get_renderer("mitsuba3"), None,
                    RendererModelOptions(normals=3, pool=32, max_level=4, sphere_pixels=6))
    fine, n = 5, 16
    got = m.predict("mis", "ldsampler", n).mse
    r = m.request("mis", "ldsampler", n)
    want, before = [], []
    for normal in m.normals:
        vals = m._part_values({"mis"}, normal, fine)
        base = m._randomised_cell(r, vals, {"normal": normal, "strategies": {"mis"}}, fine,
                                  {r.level})[0]
        tables = {t: np.stack([m._point_parts({"mis"}, x, fine)[t] for x in normal[1]])
                  for t in ("mis_e", "mis_b")}
        want.append(base + m._pairing(r).extra(tables, "mis", (1, 3))[0])
        before.append(base + footprint_term("mis", "digital_shift", n, vals))
    np.testing.assert_allclose(got, m.weights @ np.array(want), rtol=1e-10)
    assert not np.allclose(got, m.weights @ np.array(before), rtol=1e-3)


def test_paired_lobe_choice_is_the_one_table_pairing_where_the_lobes_agree():
    """A two-lobe BSDF's paired footprint (``LobeChoice._lobe_extra``: each sample's lobe from
    its stratified 1-D number, the two tables side by side) is the one-table pairing
    (``PairedFootprint.extra``) where both lobes' tables are that table, whatever p; with
    lobes apart it differs. The lobe numbers put one point in each of N strata per pixel."""
    from types import SimpleNamespace

    from envfit.predict.renderer._footprint import PairedFootprint
    from envfit.predict.renderer._lobe_parts import LobeChoice
    points = get_renderer("mitsuba3").sampler("ldsampler").film_points
    n, size = 16, 64
    pf = PairedFootprint(n, 2048, 3, points, dims=6)
    u = pf.lobe_numbers()
    np.testing.assert_array_equal(np.sort(np.floor(u * n), axis=1),
                                  np.broadcast_to(np.arange(n), u.shape))
    rng = np.random.default_rng(0)
    e, g, h = (rng.random((4, size, 3)) for _ in range(3))
    g[1] += 3.0                                   # a bright normal: the film's pairing matters
    stub = SimpleNamespace(_pairing=lambda r: pf, _calls=lambda r: (1, 3),
                           renderer=get_renderer("mitsuba3"))
    for strategy, tables in (("mis", {"mis_e": e, "mis_b": g}), ("brdf", {"brdf": g})):
        prefix = "brdf_" if strategy == "brdf" else "mis_b"
        kept = {"mis_e": e, f"{prefix}a": g, f"{prefix}b": g}
        r = SimpleNamespace(strategy=strategy)
        one = pf.extra(tables, strategy, (1, 3))[0]
        for p in (0.1, 0.5, 0.93):
            got = LobeChoice._lobe_extra(stub, r, {"_normals": kept, "_p": p})
            np.testing.assert_allclose(got, one, rtol=1e-12)
        kept[f"{prefix}b"] = h
        apart = LobeChoice._lobe_extra(stub, r, {"_normals": kept, "_p": 0.5})
        assert not np.allclose(apart, one, rtol=1e-3)
