"""Tests of envfit.maps._envmap (the EnvMap container) and envfit.maps._io (load_envmap /
save_envmap and their errors)."""
from __future__ import annotations

import os

import numpy as np
import OpenImageIO as oiio
import pytest

from envfit.maps import EnvMap
from envfit.maps import load_envmap, save_envmap
from envfit.base._errors import (EnvMapFileError, EnvMapFormatError, MemoryBudgetError,
                                 NonFiniteError, ParameterError)
from envfit.maps._latlong import pixel_angles, pixel_directions


def _write_raw(path, array, fmt="float", names=None):
    """Write an image with OIIO directly (no envfit code), for independent fixtures."""
    a = np.asarray(array)
    if a.ndim == 2:
        a = a[:, :, None]
    h, w, c = a.shape
    spec = oiio.ImageSpec(w, h, c, fmt)
    if names:
        spec.channelnames = tuple(names)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec)
    assert out.write_image(np.ascontiguousarray(a))
    out.close()
    return path


def _rand(h=8, c=3, seed=0):
    return np.random.default_rng(seed).random((h, 2 * h, c)).astype(np.float32)


# -- the container -----------------------------------------------------------------------
def test_envmap_validation():
    m = EnvMap(np.zeros((3, 6)))
    assert m.data.shape == (3, 6, 1) and (m.height, m.width, m.channels) == (3, 6, 1)
    assert EnvMap(np.zeros((2, 4, 3), np.float16)).data.dtype == np.float32
    assert EnvMap(np.zeros((2, 4, 3), np.uint8)).data.dtype == np.float64
    with pytest.raises(EnvMapFormatError, match="empty"):
        EnvMap(np.zeros((0, 0, 3)))
    with pytest.raises(EnvMapFormatError, match="5x3"):
        EnvMap(np.zeros((3, 5, 3)))
    with pytest.raises(EnvMapFormatError):
        EnvMap(np.zeros(4))
    with pytest.raises(ParameterError):
        EnvMap(np.zeros((2, 4, 3)), up="q")


def test_geometry_delegates_to_latlong():
    m = EnvMap(_rand(), up="z")
    np.testing.assert_array_equal(m.directions(), pixel_directions(8, up="z"))
    assert abs(m.solid_angles().sum() - 4 * np.pi) < 1e-12
    np.testing.assert_array_equal(m.lookup(m.directions()), m.data.astype(np.float64))


def test_luminance_and_mean():
    rng = np.random.default_rng(1)
    rgb = rng.random((4, 8, 3))
    m = EnvMap(rgb)
    np.testing.assert_allclose(m.luminance(), 0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1]
                               + 0.0722 * rgb[..., 2], rtol=1e-15)
    np.testing.assert_array_equal(EnvMap(rgb[..., :2]).luminance(), rgb[..., 0])
    # solid-angle weighted mean vs a direct weighted sum with the definition's solid angles
    h = 4
    edges = np.pi * np.arange(h + 1) / h
    om = (np.cos(edges[:-1]) - np.cos(edges[1:])) * (2 * np.pi / 8)
    direct = np.einsum("i,ijc->c", om, rgb) / (4 * np.pi)
    np.testing.assert_allclose(m.mean(), direct, rtol=1e-13)
    # mean of cos²θ over the sphere is 1/3 (midpoint rule error O(h²))
    theta, _ = pixel_angles(64)
    c2 = EnvMap(np.repeat((np.cos(theta) ** 2)[:, None], 128, axis=1))
    assert abs(c2.mean()[0] - 1 / 3) < 1e-3


def test_with_data_astype():
    m = EnvMap(_rand(), up="x", name="n", notes=["a"])
    m2 = m.with_data(np.ones((2, 4, 1)))
    assert (m2.up, m2.name, m2.notes, m2.channels) == ("x", "n", ["a"], 1)
    m2.notes.append("b")
    assert m.notes == ["a"]
    assert m.astype(np.float64).data.dtype == np.float64
    with pytest.raises(ParameterError):
        m.astype(np.int32)


def test_resized_integer_factor_preserves_mean():
    m = EnvMap(np.random.default_rng(2).random((32, 64, 3)))
    r = m.resized(8)
    assert r.data.shape == (8, 16, 3)
    np.testing.assert_allclose(r.mean(), m.mean(), rtol=1e-13)
    # one output pixel = solid-angle weighted mean of its 4x4 block
    om = m.solid_angles()[:4, :4]
    np.testing.assert_allclose(r.data[0, 0], np.einsum("ij,ijc->c", om, m.data[:4, :4]) / om.sum(),
                               rtol=1e-13)
    assert m.resized(32) is m and m.resized(100) is m
    assert "resized from 64x32 to 16x8" in r.notes[-1]
    with pytest.raises(ParameterError):
        m.resized(0)


def test_resized_non_integer_factor_smooth_and_constant():
    c = EnvMap(np.full((30, 60, 3), 2.5, np.float32))
    r = c.resized(7)
    assert r.data.shape == (7, 14, 3) and r.data.dtype == np.float32
    np.testing.assert_allclose(r.data, 2.5, rtol=1e-6)
    # a smooth function resampled ≈ the function sampled on the coarse grid
    f = lambda d: 1.0 + 0.5 * d[..., 0] + 0.3 * d[..., 1] * d[..., 2]   # noqa: E731
    fine = EnvMap(f(pixel_directions(60))[..., None])
    coarse = fine.resized(25)
    assert np.abs(coarse.data[..., 0] - f(pixel_directions(25))).max() < 0.02


# -- save / load round trips -------------------------------------------------------------
def test_exr_round_trip_float32_exact(tmp_path):
    a = _rand(16)
    p = save_envmap(tmp_path / "m.exr", a)
    m = load_envmap(p)
    assert m.data.dtype == np.float32 and m.name == "m.exr" and m.notes == []
    np.testing.assert_array_equal(m.data, a)
    m64 = load_envmap(p, dtype=np.float64)
    assert m64.data.dtype == np.float64
    np.testing.assert_array_equal(m64.data, a.astype(np.float64))
    # only the final file is left (atomic write through a temp name)
    assert sorted(os.listdir(tmp_path)) == ["m.exr"]
    # the file holds float32 pixels, zip-compressed, with the up attribute
    inp = oiio.ImageInput.open(str(p))
    spec = inp.spec()
    inp.close()
    assert spec.format == oiio.TypeDesc("float")
    assert "zip" in spec.get_string_attribute("compression")
    assert spec.get_string_attribute("envfit:up") == "y"


def test_exr_round_trip_half(tmp_path):
    a = _rand(16) * 100
    save_envmap(tmp_path / "h.exr", EnvMap(a), half=True)
    m = load_envmap(tmp_path / "h.exr")
    np.testing.assert_allclose(m.data, a, rtol=2.0 ** -11, atol=2.0 ** -24)
    np.testing.assert_array_equal(m.data, a.astype(np.float16).astype(np.float32))


def test_up_attribute_mismatch_noted(tmp_path):
    save_envmap(tmp_path / "z.exr", EnvMap(_rand(), up="z"))
    assert load_envmap(tmp_path / "z.exr", up="z").notes == []
    notes = load_envmap(tmp_path / "z.exr").notes
    assert any("up='z'" in n for n in notes)


def test_overwrite_and_nested_folder(tmp_path):
    p = tmp_path / "a" / "b" / "m.exr"
    save_envmap(p, _rand(seed=1))
    save_envmap(p, _rand(seed=2))
    np.testing.assert_array_equal(load_envmap(p).data, _rand(seed=2))
    assert os.listdir(p.parent) == ["m.exr"]


def test_png_preview_round_trip_and_refusal(tmp_path):
    a = _rand(8)
    save_envmap(tmp_path / "p.png", a)
    m = load_envmap(tmp_path / "p.png", linearize=False)      # the encoded 8-bit values
    np.testing.assert_allclose(m.data, np.rint(a * 255) / 255, atol=1e-6)
    # by default a display-referred file is decoded to linear (tests/test_faults_inputs.py)
    assert any("decoded 8-bit sRGB" in n for n in load_envmap(tmp_path / "p.png").notes)
    with pytest.raises(ParameterError, match=r"\[0, 1\]"):
        save_envmap(tmp_path / "q.png", a * 3)
    assert not (tmp_path / "q.png").exists()
    with pytest.raises(ParameterError):
        save_envmap(tmp_path / "noext", a)
    with pytest.raises(ParameterError, match="pfm"):
        save_envmap(tmp_path / "m.pfm", a)


def test_multipart_uses_first_part(tmp_path):
    a = _rand(8)
    p = str(tmp_path / "mp.exr")
    s1, s2 = oiio.ImageSpec(16, 8, 3, "float"), oiio.ImageSpec(16, 8, 3, "float")
    out = oiio.ImageOutput.create(p)
    assert out.open(p, (s1, s2)) and out.write_image(a)
    assert out.open(p, s2, "AppendSubimage") and out.write_image(2 * a)
    out.close()
    m = load_envmap(p)
    np.testing.assert_array_equal(m.data, a)
    assert any("subimages" in n for n in m.notes)


def test_channels_rgba_gray_two(tmp_path):
    a = _rand(8, 4)
    _write_raw(tmp_path / "rgba.exr", a, names=("R", "G", "B", "A"))
    m = load_envmap(tmp_path / "rgba.exr")
    assert m.channels == 3 and any("alpha" in n for n in m.notes)
    np.testing.assert_array_equal(m.data, a[..., :3])
    _write_raw(tmp_path / "y.exr", a[..., 0], names=("Y",))
    g = load_envmap(tmp_path / "y.exr")
    assert g.channels == 1 and g.notes == []
    np.testing.assert_array_equal(g.data[..., 0], a[..., 0])
    _write_raw(tmp_path / "ya.exr", a[..., :2], names=("Y", "A"))
    ya = load_envmap(tmp_path / "ya.exr")
    assert ya.channels == 1 and "2-channel" in ya.notes[0]
    np.testing.assert_array_equal(ya.data[..., 0], a[..., 0])


def test_max_height_on_load(tmp_path):
    a = _rand(16)
    save_envmap(tmp_path / "m.exr", a)
    m = load_envmap(tmp_path / "m.exr", max_height=4)
    assert m.data.shape == (4, 8, 3)
    np.testing.assert_allclose(m.mean(), EnvMap(a).mean(), rtol=1e-6)


# -- errors ------------------------------------------------------------------------------
def test_missing_file_and_folder(tmp_path):
    with pytest.raises(EnvMapFileError, match="no such file"):
        load_envmap(tmp_path / "nope.exr")
    with pytest.raises(EnvMapFileError, match="folder"):
        load_envmap(tmp_path)


def test_corrupt_bytes(tmp_path):
    p = tmp_path / "junk.exr"
    p.write_bytes(b"this is not an image" * 20)
    with pytest.raises(EnvMapFileError) as ei:
        load_envmap(p)
    assert "\n" not in str(ei.value) and "junk.exr" in str(ei.value)
    q = tmp_path / "junk.png"
    q.write_bytes(b"\x89PNG\r\n\x1a\n" + b"x" * 64)
    with pytest.raises(EnvMapFileError):
        load_envmap(q)


@pytest.mark.parametrize("frac", [0.3, 0.9])
def test_truncated_exr(tmp_path, frac):
    p = save_envmap(tmp_path / "m.exr", _rand(32))
    data = p.read_bytes()
    t = tmp_path / "t.exr"
    t.write_bytes(data[:int(len(data) * frac)])
    with pytest.raises(EnvMapFileError, match="corrupt or truncated") as ei:
        load_envmap(t)
    assert "\n" not in str(ei.value)


def test_wrong_aspect(tmp_path):
    _write_raw(tmp_path / "sq.exr", np.ones((8, 8, 3), np.float32))
    with pytest.raises(EnvMapFormatError, match="8x8"):
        load_envmap(tmp_path / "sq.exr")


def test_nonfinite_error_and_fix(tmp_path):
    a = _rand(8, seed=3)
    a[2, 5, 1] = np.nan
    a[4, 0, :] = np.inf                     # on the seam: neighbours wrap around
    a[6, 9, 2] = -np.inf
    p = _write_raw(tmp_path / "nan.exr", a)
    with pytest.raises(NonFiniteError) as ei:
        load_envmap(p)
    msg = str(ei.value)
    assert "5 non-finite" in msg and "1 NaN" in msg and "3 pixel" in msg
    assert "fix_nonfinite" in msg and "--fix-nonfinite" in msg
    m = load_envmap(p, fix_nonfinite=True)
    assert np.all(np.isfinite(m.data))
    assert any("replaced 5 non-finite" in n for n in m.notes)
    # expected: mean of the finite 8-neighbours, longitude wrapping, computed by hand
    h, w = a.shape[:2]

    def neigh_mean(i, j, c):
        vals = [a[i + di, (j + dj) % w, c] for di in (-1, 0, 1) for dj in (-1, 0, 1)
                if (di or dj) and 0 <= i + di < h and np.isfinite(a[i + di, (j + dj) % w, c])]
        return np.mean(vals)

    for (i, j, c) in [(2, 5, 1), (4, 0, 0), (4, 0, 1), (4, 0, 2), (6, 9, 2)]:
        assert abs(m.data[i, j, c] - neigh_mean(i, j, c)) < 1e-6
    mask = np.isfinite(a)
    np.testing.assert_array_equal(m.data[mask], a[mask])


def test_negative_clamp_vs_allow(tmp_path):
    a = _rand(8, seed=4) - 0.25
    nneg = int((a < 0).sum())
    p = _write_raw(tmp_path / "neg.exr", a)
    m = load_envmap(p)
    np.testing.assert_array_equal(m.data, np.maximum(a, 0))
    assert any(f"clamped {nneg} negative" in n for n in m.notes)
    k = load_envmap(p, allow_negative=True)
    np.testing.assert_array_equal(k.data, a)
    assert k.notes == []


def test_memory_guard(tmp_path, monkeypatch):
    p = save_envmap(tmp_path / "m.exr", _rand(32))
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", "10K")
    with pytest.raises(MemoryBudgetError, match="m.exr"):
        load_envmap(p)
    # the guard runs on the header before any pixel is read: a truncated file (whose pixels
    # cannot be read) still reports the memory problem, not the truncation
    t = tmp_path / "t.exr"
    t.write_bytes(p.read_bytes()[:2000])
    with pytest.raises(MemoryBudgetError):
        load_envmap(t)
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", "1G")
    assert load_envmap(p).height == 32


def test_bad_parameters(tmp_path):
    p = save_envmap(tmp_path / "m.exr", _rand())
    with pytest.raises(ParameterError):
        load_envmap(p, up="w")
    with pytest.raises(ParameterError):
        load_envmap(p, dtype=np.int16)
