"""Renderer lat-long conventions (envfit.maps._conventions, --convention, synth --kind marker).

Each renderer's formula is re-written here from its source, independently of the module
(which uses one canonical table); the tests compare the two, pixel by pixel.
"""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import envfit.cli as cli
from envfit.base._errors import ParameterError
from envfit.data_gen import MARKERS, marker_for_colour
from envfit.maps import _latlong as latlong
from envfit.maps import CONVENTIONS, convention
from envfit.maps import EnvMap
from envfit.maps import load_envmap, save_envmap

H, W = 32, 64
LATLONG = [n for n in CONVENTIONS if n != "pbrt4"]
TAU = 2.0 * np.pi


# ----------------------------------------------------------- the renderers' own formulas
# Each returns continuous (row, col) = the renderer's (y, x) lookup position in the file
# (row 0 = the file's top row), and its inverse.

def exr_pixel(d, w, h):
    """OpenEXR src/lib/OpenEXR/ImfEnvmap.cpp, LatLongMap::latLong(dir) and
    pixelPosition(dataWindow, latLong), data window [0, w-1] x [0, h-1]."""
    x, y, z = d
    n = np.linalg.norm(d)
    r = np.sqrt(z * z + x * x)
    lat = np.arccos(r / n) * np.sign(y) if r < abs(y) else np.arcsin(y / n)
    lon = 0.0 if (z == 0 and x == 0) else np.arctan2(x, z)
    px = lon / (-TAU) + 0.5
    py = lat / (-np.pi) + 0.5
    return py * (h - 1), px * (w - 1)


def exr_direction(row, col, w, h):
    """ImfEnvmap.cpp, LatLongMap::latLong(dataWindow, pixelPosition) and direction()."""
    lat = -np.pi * (row / (h - 1) - 0.5)
    lon = -TAU * (col / (w - 1) - 0.5)
    return np.array([np.sin(lon) * np.cos(lat), np.sin(lat), np.cos(lon) * np.cos(lat)])


def mitsuba_pixel(d, w, h):
    """mitsuba3 src/emitters/envmap.cpp: direction_to_uv, then eval_spectrum's
    uv.x -= .5/(res.x-1); uv -= floor(uv); uv *= res - 1, with res = (w + 1, h)."""
    u = np.arctan2(d[0], -d[2]) / TAU
    v = np.arccos(np.clip(d[1] / np.linalg.norm(d), -1, 1)) / np.pi
    u -= 0.5 / w
    u -= np.floor(u)
    return v * (h - 1), u * w


def mitsuba_direction(row, col, w, h):
    """envmap.cpp uv_to_direction, at the uv whose eval_spectrum position is (col, row)."""
    u, v = (col + 0.5) / w, row / (h - 1)
    theta, phi = v * np.pi, u * TAU
    return np.array([np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)])


def pbrt3_pixel(d, w, h):
    """pbrt-v3 src/lights/infinite.cpp InfiniteAreaLight::Le: st = (SphericalPhi/2pi,
    SphericalTheta/pi); src/core/mipmap.h MIPMap::triangle: s = st[0]*w - .5, t = st[1]*h - .5."""
    v = d / np.linalg.norm(d)
    phi = np.arctan2(v[1], v[0])
    phi = phi + TAU if phi < 0 else phi                     # SphericalPhi in [0, 2pi)
    theta = np.arccos(np.clip(v[2], -1, 1))                 # SphericalTheta
    return theta / np.pi * h - 0.5, phi / TAU * w - 0.5


def pbrt3_direction(row, col, w, h):
    """infinite.cpp Sample_Li: theta = v pi, phi = u 2pi, (sin cos, sin sin, cos)."""
    u, v = (col + 0.5) / w, (row + 0.5) / h
    theta, phi = v * np.pi, u * TAU
    return np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])


def blender_pixel(d, w, h):
    """Cycles kernel/camera/projection.h direction_to_equirectangular_range with range
    (-2pi, pi, -pi, pi); kernel/device/cpu/image.h interp_linear: x*width - .5; the file is
    loaded flipped (scene/image_oiio.cpp), so memory row m is file row h - 1 - m."""
    u = (np.arctan2(d[1], d[0]) - np.pi) / (-TAU)
    v = (np.arccos(d[2] / np.linalg.norm(d)) - np.pi) / (-np.pi)
    mem_row = v * h - 0.5
    return (h - 1) - mem_row, u * w - 0.5


def blender_direction(row, col, w, h):
    """projection.h equirectangular_range_to_direction: phi = -2pi u + pi, theta = -pi v + pi."""
    u = (col + 0.5) / w
    v = ((h - 1 - row) + 0.5) / h
    phi, theta = -TAU * u + np.pi, -np.pi * v + np.pi
    return np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])


def envfit_pixel(d, w, h):
    """envfit's own (latlong.py), up = y."""
    r, c = latlong.direction_to_pixel(d, h, w, up="y")
    return float(r), float(c)


def envfit_direction(row, col, w, h):
    return latlong.pixel_to_direction(row, col, h, w, up="y")


RENDERER = {"openexr": (exr_pixel, exr_direction), "usd": (exr_pixel, exr_direction),
            "mitsuba3": (mitsuba_pixel, mitsuba_direction), "pbrt3": (pbrt3_pixel, pbrt3_direction),
            "blender": (blender_pixel, blender_direction),
            "envfit": (envfit_pixel, envfit_direction)}
#: columns repeat with this period (OpenEXR's first and last columns are one meridian)
PERIOD = {"openexr": W - 1, "usd": W - 1}


def _directions(n=200, seed=1):
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


# ----------------------------------------------------------------- direction <-> pixel
@pytest.mark.parametrize("name", LATLONG)
def test_direction_to_pixel_is_the_renderers_formula(name):
    conv = convention(name)
    pixel, _ = RENDERER[name]
    period = PERIOD.get(name, W)
    dirs = _directions()
    row, col = conv.direction_to_pixel(dirs, H, W)
    for d, r, c in zip(dirs, row, col):
        r0, c0 = pixel(d, W, H)
        assert r == pytest.approx(r0, abs=1e-10)
        dc = (c - c0 + period / 2) % period - period / 2     # the seam: same meridian
        assert abs(dc) < 1e-10


def test_known_directions_land_on_the_documented_pixels():
    # OpenEXR/USD (ImfEnvmap.h): lat 0, lon 0 is +z: the image centre ((W-1)/2, (H-1)/2);
    # lon pi/2 (+x) a quarter of the way from the centre to the left, +y the top row.
    for name in ("openexr", "usd"):
        c = convention(name)
        assert np.allclose(c.direction_to_pixel([0, 0, 1.0], H, W), [(H - 1) / 2, (W - 1) / 2])
        assert np.allclose(c.direction_to_pixel([1.0, 0, 0], H, W), [(H - 1) / 2, (W - 1) / 4])
        assert float(c.direction_to_pixel([0, 1.0, 0], H, W)[0]) == 0.0
    # Mitsuba 3: -z is u = 0 (column -1/2, the left edge), -y the LAST row exactly
    m = convention("mitsuba3")
    assert np.allclose(m.direction_to_pixel([0, 0, -1.0], H, W), [(H - 1) / 2, -0.5])
    assert float(m.direction_to_pixel([0, -1.0, 0], H, W)[0]) == pytest.approx(H - 1)
    # Blender: +x is u = v = 1/2, +y is u = 1/4 (atan2 = pi/2); pbrt-v3: +y is s = 1/4 too
    b, p = convention("blender"), convention("pbrt3")
    assert np.allclose(b.direction_to_pixel([1.0, 0, 0], H, W), [H / 2 - 0.5, W / 2 - 0.5])
    assert np.allclose(b.direction_to_pixel([0, 1.0, 0], H, W), [H / 2 - 0.5, W / 4 - 0.5])
    assert np.allclose(p.direction_to_pixel([0, 1.0, 0], H, W), [H / 2 - 0.5, W / 4 - 0.5])
    assert np.allclose(p.direction_to_pixel([1.0, 0, 1e-300], H, W)[1], -0.5)


@pytest.mark.parametrize("name", LATLONG)
def test_pixel_to_direction_is_the_renderers_inverse_and_round_trips(name):
    conv = convention(name)
    _, direction = RENDERER[name]
    rng = np.random.default_rng(2)
    rows = rng.uniform(0.1, H - 1.1, 50)
    cols = rng.uniform(0.1, W - 1.1, 50)
    got = conv.pixel_to_direction(rows, cols, H, W)
    for g, r, c in zip(got, rows, cols):
        assert np.allclose(g, direction(r, c, W, H), atol=1e-12)
    dirs = _directions(seed=3)
    back = conv.pixel_to_direction(*conv.direction_to_pixel(dirs, H, W), H, W)
    assert np.max(np.abs(back - dirs)) < 1e-12
    r2, c2 = conv.direction_to_pixel(got, H, W)
    assert np.max(np.abs(r2 - rows)) < 1e-12 and np.max(np.abs(c2 - cols)) < 1e-12


def test_renderer_angles():
    d = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    t, p = convention("blender").angles(d)          # Cycles: acos(z), atan2(y, x)
    assert (t, p) == pytest.approx((np.arccos(d[2]), np.arctan2(d[1], d[0])), abs=1e-12)
    t, p = convention("openexr").angles(d)          # colatitude from +y, longitude atan2(x, z)
    assert (t, p) == pytest.approx((np.arccos(d[1]), np.arctan2(d[0], d[2])), abs=1e-12)
    t, p = convention("mitsuba3").angles(d)         # 2 pi u, u = atan2(x, -z)/2pi in [0, 1)
    assert (t, p) == pytest.approx((np.arccos(d[1]), np.arctan2(d[0], -d[2]) % TAU), abs=1e-12)
    t, p = convention("pbrt3").angles(d)
    assert (t, p) == pytest.approx((np.arccos(d[2]), np.arctan2(d[1], d[0]) % TAU), abs=1e-12)


# ------------------------------------------------------------------------ conversion
def test_exact_conversions_are_the_expected_permutations():
    rng = np.random.default_rng(4)
    img = rng.random((H, W, 3))
    b = convention("blender").to_internal(img)
    j = np.arange(W)
    assert b.up == "z" and np.array_equal(b.data, img[:, (W // 2 - 1 - j) % W])
    # the permuted map, read as envfit's --up z, gives every pixel Cycles' direction
    d = b.directions()
    mem = [blender_pixel(x, W, H) for x in d[5, :7]]
    assert [round(c) for _, c in mem] == [int((W // 2 - 1 - k) % W) for k in range(7)]
    p = convention("pbrt3").to_internal(img)
    assert p.up == "z" and np.array_equal(p.data, img)
    e = convention("envfit").to_internal(img)
    assert e.up == "y" and np.array_equal(e.data, img) and e.notes == []
    assert "permuted exactly" in b.notes[-1]


@pytest.mark.parametrize("name", ["blender", "pbrt3", "envfit"])
def test_exact_path_equals_resampling_path(name):
    img = np.random.default_rng(5).random((H, W, 2))
    conv = convention(name)
    exact = conv.to_internal(img, exact=True)
    resampled = conv.to_internal(img, exact=False)
    assert "resampled" in " ".join(resampled.notes) or name == "envfit"
    assert np.max(np.abs(exact.data - resampled.data)) < 1e-9
    assert np.array_equal(conv.to_internal(conv.from_internal(exact)).data, exact.data)


@pytest.mark.parametrize("name", ["openexr", "usd", "mitsuba3"])
def test_resampled_conventions_are_bilinear_accurate(name):
    conv = convention(name)
    _, direction = RENDERER[name]
    with pytest.raises(ParameterError, match="resampled"):
        conv.to_internal(np.ones((H, W)), exact=True)

    def g(d):                                             # smooth, not symmetric
        return 1.0 + d[..., 0] + 0.5 * d[..., 1] - 0.3 * d[..., 2] + 0.4 * d[..., 0] * d[..., 2]

    rows, cols = np.meshgrid(np.arange(H), np.arange(W), indexing="ij")
    file_dirs = np.array([direction(r, c, W, H) for r, c in zip(rows.ravel(), cols.ravel())])
    img = g(file_dirs).reshape(H, W)                      # the file as the renderer sees it
    env = conv.to_internal(img)
    truth = g(env.directions())[:, :, None]
    err = np.max(np.abs(env.data - truth))
    naive = np.max(np.abs(EnvMap(img, up=conv.up).data - truth))   # read as if envfit's
    assert err < 4e-3 < 0.02 < naive


def test_pbrt4_and_unknown_names_refused():
    with pytest.raises(ParameterError, match="equal-area"):
        convention("pbrt4").to_internal(np.ones((4, 8)))
    with pytest.raises(ParameterError, match="unknown --convention 'maya'; use one of envfit"):
        convention("maya")


# ------------------------------------------------------------------- the marker map
def _raw_centroids(img, name):
    """Marker directions found in a raw file with the renderer's OWN formula (weights:
    value x sin(theta) from the same formula, the lat-long area element)."""
    _, direction = RENDERER[name]
    period = PERIOD.get(name, W)
    found = {}
    for r in range(H):
        for c in range(period):
            m = marker_for_colour(img[r, c], tol=1e-3)
            if m is None:
                continue
            d = direction(r, c, W, H)
            up = {"openexr": 1, "usd": 1, "mitsuba3": 1, "envfit": 1}.get(name, 2)
            w = img[r, c].max() * max(np.sqrt(max(0.0, 1 - d[up] ** 2)), 1e-3)
            found[m[0]] = found.get(m[0], 0.0) + w * d
    return {k: v / np.linalg.norm(v) for k, v in found.items()}


def _internal_centroids(env):
    d, om = env.directions(), env.solid_angles()
    found = {}
    for (r, c), v in np.ndenumerate(env.data[:, :, 0]):
        m = marker_for_colour(env.data[r, c], tol=1e-3)
        if m is not None:
            found[m[0]] = found.get(m[0], 0.0) + om[r, c] * env.data[r, c].max() * d[r, c]
    return {k: v / np.linalg.norm(v) for k, v in found.items()}


def _angle(a, b):
    return float(np.arccos(np.clip(np.dot(a, b), -1, 1)))


@pytest.fixture(autouse=True)
def _only_synth_info(monkeypatch):
    monkeypatch.setattr(cli, "COMMANDS", ("synth", "info"))


@pytest.mark.parametrize("name", LATLONG)
def test_marker_map_round_trip(name, tmp_path, capsys):
    path = tmp_path / f"marker_{name}.exr"
    assert cli.main(["synth", str(path), "--kind", "marker", "--convention", name,
                     "--height", str(H), "--quiet"]) == 0
    raw = load_envmap(path).data.astype(np.float64)
    axes = {label: np.array(axis) for label, axis, _, _ in MARKERS}
    by_renderer = _raw_centroids(raw, name)             # the renderer's formula on the file
    internal = _internal_centroids(convention(name).to_internal(load_envmap(path)))
    assert sorted(by_renderer) == sorted(internal) == sorted(axes)
    pixel = np.pi / H
    for label, axis in axes.items():
        assert _angle(by_renderer[label], axis) < 0.05 * pixel, (label, by_renderer[label])
        assert _angle(internal[label], axis) < 0.1 * pixel, (label, internal[label])
    # info --convention: the brightest marker (+x) and the renderer's pixel for it
    assert cli.main(["info", str(path), "--convention", name, "--json", "-"]) == 0
    info = json.loads(capsys.readouterr().out)
    b = info["brightest"]
    assert not any("envfit:up" in n for n in info["notes"])     # the file is tagged +up axis
    assert _angle(np.asarray(b["direction"]), axes["+x"]) < 1.0 * pixel
    r0, c0 = RENDERER[name][0](np.asarray(b["direction"]), W, H)
    assert (b["convention"]["row"], b["convention"]["col"]) == pytest.approx((r0, c0), abs=1e-9)


def test_marker_read_in_the_wrong_convention_is_misplaced(tmp_path):
    path = tmp_path / "m.exr"
    assert cli.main(["synth", str(path), "--kind", "marker", "--convention", "blender",
                     "--height", str(H), "--quiet"]) == 0
    found = _internal_centroids(convention("pbrt3").to_internal(load_envmap(path)))
    assert _angle(found["+x"], [-1, 0, 0]) < 0.05 and _angle(found["+y"], [0, 1, 0]) < 0.05
    found = _internal_centroids(convention("openexr").to_internal(load_envmap(path)))
    assert _angle(found["+z"], [0, 0, 1]) > 1.0               # z up read as y up


def test_synth_other_kinds_in_a_convention(tmp_path):
    a, b = tmp_path / "a.exr", tmp_path / "b.exr"
    assert cli.main(["synth", str(a), "--kind", "sky", "--height", "8", "--up", "z", "-q"]) == 0
    assert cli.main(["synth", str(b), "--kind", "sky", "--height", "8", "--convention",
                     "blender", "-q"]) == 0
    env_b = convention("blender").to_internal(load_envmap(b))
    assert env_b.up == "z" and np.array_equal(env_b.data, load_envmap(a, up="z").data)


# ----------------------------------------------------------------------- command line
def _envfit(tmp_path, *argv):
    p = subprocess.run([sys.executable, "-m", "envfit.cli", *argv], cwd=tmp_path,
                       capture_output=True, text=True, timeout=120)
    return p.returncode, p.stdout, p.stderr


def test_cli_bad_convention_one_line_exit_2(tmp_path):
    path = save_envmap(tmp_path / "m.exr", np.ones((4, 8, 3), np.float32))
    cases = [(["info", str(path), "--convention", "maya"], "unknown --convention 'maya'"),
             (["info", str(path), "--convention", "pbrt4"], "equal-area"),
             (["info", str(path), "--convention", "blender", "--up", "z"], "exclude each other"),
             (["synth", "x.exr", "--kind", "marker", "--convention", "nope"], "unknown")]
    for argv, text in cases:
        rc, out, err = _envfit(tmp_path, *argv)
        lines = err.strip().splitlines()
        assert rc == 2 and len(lines) == 1 and text in lines[0], (argv, err)
        assert lines[0].startswith(f"envfit {argv[0]}: error:") and out == ""
    assert not (tmp_path / "x.exr").exists()


def test_cli_info_prints_the_convention_line(tmp_path):
    path = tmp_path / "m.exr"
    rc, out, err = _envfit(tmp_path, "synth", str(path), "--kind", "marker", "--convention",
                           "mitsuba3", "--height", "16")
    assert rc == 0 and "mitsuba3 layout" in out, err
    rc, out, err = _envfit(tmp_path, "info", str(path), "--convention", "mitsuba3")
    assert rc == 0, err
    line = next(x for x in out.splitlines() if x.strip().startswith("in mitsuba3"))
    assert "of the 32x16 file" in line and "theta" in line and "pixel (col, row)" in line
    rc, out, err = _envfit(tmp_path, "info", "--help")
    assert "--convention" in out and "mitsuba3" in out and "pbrt4" in out
