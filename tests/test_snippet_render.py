"""``envfit advise MAP --renderer mitsuba3 --snippet``: the printed scene is the scene that was
predicted, and Mitsuba 3 renders it (issue 38).

The map is linear in the direction, L_c(d) = a_c + b d_y, written in Mitsuba's own lat-long
layout (row i at theta = pi i/(H - 1) about +y: ``src/emitters/envmap.cpp``,
``uv_to_direction``), so the shading of a white diffuse sphere is known in closed form:
E(n)/pi = a_c + (2/3) b n_y (the cosine lobe's first moment). The snippet printed by the CLI
is executed as it is, each of its six views rendered, and the mean over the pixels wholly on
the sphere compared with that formula averaged over the same pixels (and the six views'
1/(n.v)-weighted mean with the map's mean radiance a_c): within 2 %. A black render (the old
camera inside the sphere), a grey sphere (reflectance 0.5) or a swapped view fails it.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from envfit.maps import EnvMap, save_envmap
from envfit.renderers._sphere import VIEWS
from envfit.renderers import get_renderer
from envfit.renderers._base import SNIPPET_PIXELS, SPHERE_VIEWS

A = np.array([1.0, 0.8, 0.6])           # the map's mean radiance per channel
B = 0.5                                 # its gradient along +y
MODEL = ["--renderer-level", "4", "--renderer-normals", "6"]


def linear_map(height: int = 32, *, pole: str = "mitsuba3") -> np.ndarray:
    """The (H, 2H, 3) map a_c + b d_up read as ``pole`` reads a file: Mitsuba's rows on the
    poles (theta = pi i/(H-1)) or Cycles' texel-centred rows (theta = pi (i + 1/2)/H)."""
    i = np.arange(height, dtype=np.float64)
    theta = np.pi * i / (height - 1) if pole == "mitsuba3" else np.pi * (i + 0.5) / height
    col = A[None, :] + B * np.cos(theta)[:, None]                   # (H, 3)
    return np.repeat(col[:, None, :], 2 * height, axis=1).astype(np.float32)


def expected_views(resolution: int, up=(0.0, 1.0, 0.0), sub: int = 4):
    """Per view (6, 3): the mean of a_c + (2/3) b n.up over the pixels wholly on the sphere
    (each pixel averaged over sub x sub points), their mask (R, R), and the pixel centres'
    normals (6, R, R, 3) (NaN off the sphere)."""
    r = resolution
    h = 1.0 / r
    c = 2.0 * (np.arange(r) + 0.5) / r - 1.0
    X, Y = np.meshgrid(c, -c)                       # row 0 on top (image up)
    inside = (np.abs(X) + h) ** 2 + (np.abs(Y) + h) ** 2 < 1.0
    off = (2.0 * (np.arange(sub) + 0.5) / sub - 1.0) * h
    means, normals = [], []
    for v, u in SPHERE_VIEWS:
        v, u = np.asarray(v, float), np.asarray(u, float)
        right = np.cross(u, v)
        acc = np.zeros((r, r))
        for dx in off:
            for dy in off:
                x, y = X + dx, Y + dy
                z = np.sqrt(np.clip(1.0 - x * x - y * y, 0.0, None))
                n = x[..., None] * right + y[..., None] * u + z[..., None] * v
                acc += n @ np.asarray(up, float)
        ny = acc[inside] / sub ** 2
        means.append(A[None, :] + (2.0 / 3.0) * B * ny.mean())
        z0 = np.sqrt(np.clip(1.0 - X * X - Y * Y, 0.0, None))
        normals.append(X[..., None] * right + Y[..., None] * u + z0[..., None] * v)
    return np.concatenate(means), inside, np.stack(normals)


def run_advise(capsys, tmp_path, args):
    """``envfit advise`` in-process: (exit code, stdout lines, stderr, JSON or None)."""
    from envfit.cli import main
    out = tmp_path / "a.json"
    rc = main(["advise", *map(str, args), "--cache-dir", str(tmp_path / "cache"),
               "--json", str(out)])
    cap = capsys.readouterr()
    d = json.loads(out.read_text()) if rc == 0 and out.exists() else None
    return rc, cap.out.splitlines(), cap.err, d


def printed_snippet(lines: list[str], head: str, d: dict) -> str:
    """The snippet as printed: the lines after the ``scene (`` header up to the model line
    (equal to the JSON's)."""
    start = next(i for i, ln in enumerate(lines) if ln.startswith(f"scene ({head}"))
    stop = next(i for i, ln in enumerate(lines) if ln.startswith("renderer model:"))
    code = "\n".join(lines[start + 1:stop])
    assert code == d["renderer"]["snippet"].rstrip("\n")
    return code


def test_snippet_views_are_the_measurements_views():
    assert SPHERE_VIEWS == tuple((tuple(int(c) for c in v.axis), tuple(int(c) for c in v.up))
                                 for v in VIEWS)
    assert all(np.allclose(np.asarray(v.axis), a) and np.allclose(np.asarray(v.up), u)
               for v, (a, u) in zip(VIEWS, SPHERE_VIEWS))


@pytest.fixture(scope="module")
def linear_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("maps") / "linear32.exr"
    save_envmap(path, EnvMap(linear_map(32), name="linear32"))
    return path


def test_printed_mitsuba_snippet_renders_the_predicted_shading(linear_file, tmp_path, capsys):
    """The --snippet text, executed as printed: six views of a white sphere whose mean per
    view is the closed-form diffuse shading within 2 %, at the recommended spp and with the
    film of --sphere-pixels."""
    mi = pytest.importorskip("mitsuba")
    res = 24
    rc, lines, _, d = run_advise(capsys, tmp_path, [
        linear_file, "--renderer", "mitsuba3", "--sampler", "independent",
        "--target-relative", "0.1", "--sphere-pixels", str(res), "--snippet", *MODEL])
    assert rc == 0
    code = printed_snippet(lines, "Mitsuba 3", d)
    assert str(linear_file) in code and d["renderer"]["snippet_map"] == str(linear_file)
    scope: dict = {}
    exec(code, scope)                                           # noqa: S102 - as printed
    scene = scope["scene"]
    spp = d["renderer"]["recommendation"]["spp"]
    assert len(scene.sensors()) == 6
    assert all(s.sampler().sample_count() == spp for s in scene.sensors())
    assert all(list(s.film().size()) == [res, res] for s in scene.sensors())
    want, inside, _ = expected_views(res)
    imgs = np.stack([np.array(mi.render(scene, sensor=k, seed=k + 1), dtype=np.float64)
                     for k in range(6)])
    got = imgs[:, inside].mean(axis=1)                           # (6, 3)
    assert np.all(got > 0.5 * want)                              # not black, not grey
    assert got == pytest.approx(want, rel=0.02)
    # the +y view sees the bright pole, the -y view the dark one: the map's orientation
    assert got[2].mean() > A.mean() + 0.1 > A.mean() - 0.1 > got[3].mean()


def test_six_views_weighted_give_the_maps_mean_radiance(linear_file):
    """The prediction's average over uniform normals: the six views' kept pixels weighted
    1/(n.v) (:mod:`envfit.renderers._sphere`) average the shading to a_c; the
    snippet's default film (no --sphere-pixels) is the measurements' 64."""
    mi = pytest.importorskip("mitsuba")
    from envfit.renderers._sphere import sphere_geometry
    text = get_renderer("mitsuba3").snippet("brdf", "independent", 16, filename=str(linear_file))
    assert f'"width": {SNIPPET_PIXELS}, "height": {SNIPPET_PIXELS}' in text
    small = text.replace(f'"width": {SNIPPET_PIXELS}, "height": {SNIPPET_PIXELS}',
                         '"width": 32, "height": 32')
    scope: dict = {}
    exec(small, scope)                                          # noqa: S102
    g = sphere_geometry(32)
    imgs = np.stack([np.array(mi.render(scope["scene"], sensor=k, seed=k), dtype=np.float64)
                     for k in range(6)])
    w = g.weight[None, :, :, None]
    mean = (imgs * w).sum(axis=(0, 1, 2)) / (6 * g.weight.sum())
    assert mean == pytest.approx(A, rel=0.02)


def test_xml_snippet_is_the_same_scene(linear_file):
    """The XML form: the same six sensors, film, sampler and white BSDF."""
    mi = pytest.importorskip("mitsuba")
    text = get_renderer("mitsuba3").snippet("mis", "stratified", 16, filename=str(linear_file),
                                      form="xml", sphere_pixels=8)
    scene = mi.load_string(text)
    assert len(scene.sensors()) == 6 and list(scene.sensors()[0].film().size()) == [8, 8]
    img = np.array(mi.render(scene, sensor=4, seed=3), dtype=np.float64)
    want, inside, _ = expected_views(8)
    assert img[inside].mean(axis=0) == pytest.approx(want[4], rel=0.05)


def test_microfacet_snippet_names_the_view_dependent_average():
    text = get_renderer("mitsuba3").snippet("mis", "independent", 4, microfacet=("ggx", 0.2))
    assert "averaged over uniform" in text and "uniform normals" not in text
    assert '"material": "none"' in text
    diffuse = get_renderer("mitsuba3").snippet("mis", "independent", 4)
    assert '"reflectance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}' in diffuse
    assert "uniform normals" in diffuse


# ----------------------------------------------------------------------------- pbrt-v4

@pytest.mark.parametrize("pixels", [None, 40])
def test_pbrt4_snippet_has_the_camera_film_and_white_material(pixels):
    """pbrt-v4 cannot run here: the text names the orthographic camera of the views (LookAt
    from 3v, screen window [-1, 1]^2), the film the model assumed, the box filter of one
    pixel, the white diffuse material (its default is 0.5), the sphere of radius 1."""
    text = get_renderer("pbrt4").snippet("mis", "zsobol", 64, filename="m.exr", sphere_pixels=pixels)
    n = SNIPPET_PIXELS if pixels is None else pixels
    lines = text.splitlines()
    look = [ln for ln in lines if ln.startswith("LookAt")]
    assert look == ["LookAt 0 0 3  0 0 0  0 1 0"]                  # the +z view
    others = [ln.strip("# ") for ln in lines if ln.startswith("#   LookAt")]
    assert len(others) == 5
    eyes = {tuple(float(c) for c in ln.split()[1:4]) for ln in [*look, *others]}
    assert eyes == {tuple(3.0 * c for c in v) for v, _ in SPHERE_VIEWS}
    assert 'Camera "orthographic" "float screenwindow" [ -1 1 -1 1 ]' in lines
    assert f'Film "rgb" "integer xresolution" [ {n} ] "integer yresolution" [ {n} ]' in lines
    assert 'PixelFilter "box" "float xradius" [ 0.5 ] "float yradius" [ 0.5 ]' in lines
    assert 'Material "diffuse" "rgb reflectance" [ 1 1 1 ]' in lines
    assert 'Sampler "zsobol" "integer pixelsamples" [ 64 ]' in lines
    assert lines.index(look[0]) < lines.index("WorldBegin")      # camera before the world
    assert lines[-1] == 'Shape "sphere" "float radius" [ 1 ]'
