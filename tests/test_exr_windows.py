"""EXR data and display windows (issue 22, item 5), as OpenImageIO defines them.

ImageSpec ``x, y, width, height`` is the data window (the pixels stored), ``full_x, full_y,
full_width, full_height`` the display window (the image: here the whole sphere). The files
are written on the fly with OpenImageIO directly (no envfit code); the oracle is a bright
pixel's display coordinates computed by hand (data row/col + data origin − display origin)
and its direction from the lat-long formula written out here (latlong's docstring, up="y":
d = (sinθ sinφ, cosθ, −sinθ cosφ), θ = π(i+½)/H, φ = 2π(j+½)/W).
"""
from __future__ import annotations

import json

import numpy as np
import OpenImageIO as oiio
import pytest

import envfit.cli as cli
from envfit.base._errors import EnvMapFormatError
from envfit.maps import load_envmap

H, W = 64, 128


def write_windows(path, data, *, x, y, full=(0, 0, W, H), fmt="float", tile=0):
    """``data`` (h, w, c) as the data window at (x, y) of the display window ``full`` =
    (full_x, full_y, full_width, full_height)."""
    h, w, c = data.shape
    spec = oiio.ImageSpec(w, h, c, fmt)
    spec.channelnames = ("R", "G", "B")[:c] if c == 3 else ("Y",)
    spec.x, spec.y = x, y
    spec.full_x, spec.full_y, spec.full_width, spec.full_height = full
    if tile:
        spec.tile_width = spec.tile_height = tile
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec), out.geterror()
    assert out.write_image(np.ascontiguousarray(data, dtype=np.float32)), out.geterror()
    assert out.close()
    back = oiio.ImageInput.open(str(path))          # the windows really are in the file
    s = back.spec()
    assert (s.x, s.y, s.width, s.height) == (x, y, w, h)
    assert (s.full_x, s.full_y, s.full_width, s.full_height) == tuple(full)
    assert s.tile_width == tile
    back.close()
    return path


def hand_direction(i, j, h=H, w=W):
    """World direction (up="y") of the centre of display pixel (i, j), written out."""
    theta, phi = np.pi * (i + 0.5) / h, 2 * np.pi * (j + 0.5) / w
    return np.array([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)])


def brightest(m):
    i, j = divmod(int(np.argmax(m.luminance())), m.width)
    return (i, j), m.directions()[i, j]


def background(shape, seed):
    """Dim positive noise, so that 'padded with 0' is visible against stored pixels."""
    return (0.01 + 0.09 * np.random.default_rng(seed).random(shape)).astype(np.float32)


@pytest.mark.parametrize("fmt,channels,tile", [("float", 3, 0), ("half", 3, 16),
                                               ("float", 1, 32)])
def test_offset_data_window(tmp_path, fmt, channels, tile):
    x0, y0, dh, dw = 10, 5, 54, 108                  # 108x54 of data at (10, 5) in 128x64
    data = background((dh, dw, channels), 1)
    data[20, 30] = 50.0
    path = write_windows(tmp_path / "off.exr", data, x=x0, y=y0, fmt=fmt, tile=tile)
    m = load_envmap(path)
    assert m.data.shape == (H, W, channels)
    (i, j), d = brightest(m)
    assert (i, j) == (20 + y0, 30 + x0) == (25, 40)
    np.testing.assert_allclose(d, hand_direction(25, 40), atol=1e-12)
    # read as a whole sphere (the old behaviour) it would be ~3 degrees elsewhere
    assert np.degrees(np.arccos(np.clip(d @ hand_direction(20, 30, dh, dw), -1, 1))) > 3
    stored = np.asarray(data, np.float16 if fmt == "half" else np.float32).astype(np.float32)
    np.testing.assert_array_equal(m.data[y0:y0 + dh, x0:x0 + dw], stored)
    pad = np.ones((H, W), bool)
    pad[y0:y0 + dh, x0:x0 + dw] = False
    assert np.all(m.data[pad] == 0) and pad.sum() == W * H - dw * dh == 2360
    note = " ".join(m.notes)
    assert "data window (108x54 at (10, 5))" in note and "5832 of the 8192 pixels" in note
    assert "other 2360 pixels" in note and "padded with 0" in note


def test_autocropped_sky(tmp_path):
    sky = background((32, W, 3), 2)                  # only the upper hemisphere stored
    sky[3, 77] = 80.0
    m = load_envmap(write_windows(tmp_path / "sky.exr", sky, x=0, y=0))
    assert m.data.shape == (H, W, 3)
    np.testing.assert_array_equal(m.data[:32], sky)
    assert np.all(m.data[32:] == 0)
    (i, j), d = brightest(m)
    assert (i, j) == (3, 77)
    np.testing.assert_allclose(d, hand_direction(3, 77), atol=1e-12)
    assert d[1] > 0.9                                # near the up pole (+y), as stored
    assert any("covers 4096 of the 8192 pixels" in n and "50%" in n and "padded with 0" in n
               for n in m.notes)


def test_data_window_larger_than_display_tiled(tmp_path):
    x0, y0 = -10, -8                                 # 150x80 of data around 128x64
    data = background((80, 150, 3), 3)
    data[30, 40] = 60.0                              # display pixel (22, 30)
    data[2, 2] = 500.0                               # display (-6, -8): outside, dropped
    data[79, 149] = 400.0                            # display (71, 139): outside, dropped
    m = load_envmap(write_windows(tmp_path / "big.exr", data, x=x0, y=y0, tile=16))
    assert m.data.shape == (H, W, 3)
    np.testing.assert_array_equal(m.data, data[8:8 + H, 10:10 + W])
    (i, j), d = brightest(m)
    assert (i, j) == (30 + y0, 40 + x0) == (22, 30)
    np.testing.assert_allclose(d, hand_direction(22, 30), atol=1e-12)
    assert any(f"dropped {150 * 80 - W * H} pixels" in n for n in m.notes)
    assert not any("padded" in n for n in m.notes)


def test_display_window_not_at_the_origin(tmp_path):
    data = background((54, 108, 3), 4)
    data[20, 30] = 50.0
    m = load_envmap(write_windows(tmp_path / "o.exr", data, x=15, y=12, full=(5, 7, W, H)))
    (i, j), d = brightest(m)
    assert (i, j) == (20 + 12 - 7, 30 + 15 - 5) == (25, 40)
    np.testing.assert_allclose(d, hand_direction(25, 40), atol=1e-12)
    assert np.all(m.data[:5] == 0) and np.all(m.data[:, :10] == 0)


def test_same_windows_have_no_note(tmp_path):
    data = background((H, W, 3), 5)
    m = load_envmap(write_windows(tmp_path / "s.exr", data, x=3, y=-2, full=(3, -2, W, H)))
    np.testing.assert_array_equal(m.data, data)
    assert m.notes == []


def test_refusals(tmp_path):
    data = background((54, 108, 3), 6)
    for x, y in [(200, 5), (10, 64), (-108, 0)]:    # beside, below, left: no overlap
        with pytest.raises(EnvMapFormatError, match="does not overlap its display window") as e:
            load_envmap(write_windows(tmp_path / "n.exr", data, x=x, y=y))
        assert "stores no pixel of the sphere" in str(e.value) and "\n" not in str(e.value)
    # a 2:1 data window does not make a sphere of a display window that is not 2:1
    sq = background((32, 64, 3), 7)
    with pytest.raises(EnvMapFormatError, match=r"got 64x64 \(width x height\) \(its display "
                                                r"window, the sphere; the data window is 64x32"):
        load_envmap(write_windows(tmp_path / "sq.exr", sq, x=0, y=0, full=(0, 0, 64, 64)))


def test_cli_info_brightest_direction(tmp_path, capsys):
    data = background((54, 108, 3), 8)
    data[20, 30] = 50.0
    path = write_windows(tmp_path / "off.exr", data, x=10, y=5)
    js = tmp_path / "info.json"
    assert cli.main(["info", str(path), "--json", str(js)]) == 0
    d = json.loads(js.read_text())
    assert (d["width"], d["height"]) == (W, H)
    assert (d["brightest"]["row"], d["brightest"]["col"]) == (25, 40)
    np.testing.assert_allclose(d["brightest"]["direction"], hand_direction(25, 40), atol=1e-6)
    assert any("padded with 0" in n for n in d["notes"])
