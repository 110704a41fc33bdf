"""``envfit advise MAP --renderer cycles --snippet``: the printed bpy script builds the scene
that was predicted, and Cycles renders it (issue 38; needs ``bpy``).

The map is linear in the direction, L_c(d) = a_c + b d_z in Blender's world (its pole +z; the
file's row i at theta = pi (i + 1/2)/H: ``kernel/camera/projection.h``,
``direction_to_equirectangular_range``, envfit's ``blender`` convention), so a white diffuse
sphere's shading is a_c + (2/3) b n_z. The script printed by the CLI is executed as it is,
views rendered with ``bpy.ops.render.render``, and the mean over the pixels wholly on the
sphere compared with that formula over the same pixels: within 2 %.
"""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("bpy")

from envfit.maps import EnvMap, save_envmap  # noqa: E402
from envfit.renderers.cycles._render import _quiet_blender, _read_exr, import_bpy  # noqa: E402
from envfit.renderers import get_renderer  # noqa: E402

from test_snippet_render import (A, expected_views, linear_map,  # noqa: E402
                                 printed_snippet, run_advise)

MODEL = ["--renderer-level", "4", "--renderer-normals", "6"]


def _render(bpy, view, k: int, path) -> np.ndarray:
    view(k)
    bpy.context.scene.render.filepath = str(path)
    with _quiet_blender():
        bpy.ops.render.render(write_still=True)
    return _read_exr(path)


@pytest.fixture(scope="module")
def cycles_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("maps") / "linear32.exr"
    save_envmap(path, EnvMap(linear_map(32, pole="cycles"), name="linear32"))
    return path


def test_printed_cycles_snippet_renders_the_predicted_shading(cycles_file, tmp_path, capsys):
    bpy = import_bpy()
    res = 24
    rc, lines, _, d = run_advise(capsys, tmp_path, [
        cycles_file, "--renderer", "cycles", "--target-relative", "0.1",
        "--sphere-pixels", str(res), "--snippet", *MODEL])
    assert rc == 0
    code = printed_snippet(lines, "Cycles", d)
    scope: dict = {}
    exec(code, scope)                                           # noqa: S102 - as printed
    scene = bpy.context.scene
    spp = d["renderer"]["recommendation"]["spp"]
    assert scene.cycles.samples == spp and scene.render.resolution_x == res
    assert scene.world.cycles.sampling_method == "AUTOMATIC"
    want, inside, _ = expected_views(res, up=(0.0, 0.0, 1.0))
    got = {k: _render(bpy, scope["view"], k, tmp_path / f"v{k}.exr")[inside].mean(axis=0)
           for k in (0, 4, 5)}                                   # +x, +z (bright), -z (dark)
    for k, g in got.items():
        assert np.all(g > 0.5 * want[k])                         # not black, not grey
        assert g == pytest.approx(want[k], rel=0.02), k
    assert got[4].mean() > A.mean() + 0.1 > A.mean() - 0.1 > got[5].mean()


def test_brdf_only_snippet_on_a_constant_map_is_exact(tmp_path):
    """World sampling None (BSDF sampling only) of a constant map: every pixel on the sphere
    is the map's value (white, Lambertian: the sample's weight is 1), at 1 spp."""
    bpy = import_bpy()
    path = save_envmap(tmp_path / "c.exr", EnvMap(np.full((8, 16, 3), 0.7, np.float32)))
    text = get_renderer("cycles").snippet("brdf", "tabulated_sobol", 1, filename=str(path),
                                    sphere_pixels=8)
    scope: dict = {}
    exec(text, scope)                                           # noqa: S102
    assert bpy.context.scene.world.cycles.sampling_method == "NONE"
    img = _render(bpy, scope["view"], 2, tmp_path / "v.exr")
    _, inside, _ = expected_views(8)
    assert np.allclose(img[inside], 0.7, rtol=1e-3)


def test_sobol_burley_snippet_sets_it(tmp_path):
    """Sobol-Burley is in Cycles' debug UI only: the script turns it on and sets it."""
    bpy = import_bpy()
    path = save_envmap(tmp_path / "c.exr", EnvMap(np.full((8, 16, 3), 0.7, np.float32)))
    scope: dict = {}
    exec(get_renderer("cycles").snippet("mis", "sobol_burley", 4, filename=str(path)), scope)  # noqa: S102
    assert bpy.context.scene.cycles.sampling_pattern == "SOBOL_BURLEY"


@pytest.mark.parametrize("name, params", [("principled", {}), ("multiggx", {})])
def test_microfacet_snippet_renders_the_harness_material(name, params, tmp_path):
    """The snippet of a microfacet BSDF (the Principled BSDF at Blender's defaults, a white
    Multiscatter GGX Glossy BSDF) under a constant map L renders the node the measurements
    render: the disk's mean is L × the record's BSDF's directional albedo near normal
    incidence within 10 % (the disk spans every view angle; ``tests/test_render_cycles.py``
    checks the albedo per band through the harness)."""
    from scipy.stats import qmc
    bpy = import_bpy()
    rec = get_renderer("cycles")
    alpha = 0.25
    path = save_envmap(tmp_path / "c.exr", EnvMap(np.full((8, 16, 3), 0.5, np.float32)))
    text = rec.snippet("brdf", "tabulated_sobol", 256, filename=str(path), sphere_pixels=16,
                       microfacet=(name, alpha, params))
    assert ("Principled BSDF" if name == "principled" else "Glossy BSDF") in text
    scope: dict = {}
    exec(text, scope)                                           # noqa: S102
    img = _render(bpy, scope["view"], 4, tmp_path / "v.exr")
    _, inside, _ = expected_views(16)
    b = rec.bsdf(name, alpha, **params)
    u = qmc.Sobol(2, seed=0).random_base2(14)
    mean = np.mean([b.sample_square(np.broadcast_to([np.sqrt(1 - z * z), 0, z], (len(u), 3)),
                                    u).weight.mean() if hasattr(b, "sample_square") else
                    b.sample(np.broadcast_to([np.sqrt(1 - z * z), 0, z], (len(u), 3)),
                             u).weight.mean() for z in (0.9, 0.97)])
    got = img[inside].mean()
    assert 0.5 * 0.9 * mean < got < 0.5 * 1.1 * mean                # the right node, lit
