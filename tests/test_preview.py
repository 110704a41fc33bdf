"""The map preview (``envfit info --out``, ``envfit synth --out``): its axes against each
renderer's own formula, its image against the file's pixels, its sources against a sun of
known size and power and against the marker map's axes, and the CLI's files.

Independent references: :meth:`LatLongConvention.angles` of
:meth:`LatLongConvention.pixel_to_direction` (each renderer's formula, cited in
:mod:`envfit.maps._conventions`) for the axis maps; the display scale written out here
(exposure 0.18 / solid-angle mean luminance, sRGB OETF of IEC 61966-2-1) for the image; the
disc's closed-form solid angle 2π(1 − cos ρ) and power share LΩ/(4π + LΩ) for the sources;
the argmax of the marker's channel in the file for the source positions.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

import envfit.cli as cli
from envfit.data_gen import SunSkyMap
from envfit.data_gen._marker import marker_map
from envfit.maps._conventions import convention, convention_names
from envfit.maps._envmap import EnvMap
from envfit.maps._io import save_envmap
from envfit.maps._latlong import local_to_world, row_solid_angles
from envfit.maps._preview import envfit_layout, list_sources, map_preview

LAYOUTS = [n for n in convention_names() if n != "pbrt4"] + ["up-x", "up-z"]


def _layout(name):
    return envfit_layout(name[-1]) if name.startswith("up-") else convention(name)


@pytest.mark.parametrize("name", LAYOUTS)
def test_axis_maps_are_the_renderers_angles(name):
    conv = _layout(name)
    h, w = 8, 16
    env = EnvMap(np.random.default_rng(1).random((h, w, 3)) + 0.1, up=conv.up)
    p = map_preview(env, None if name.startswith("up-") else conv)
    rows, cols = np.meshgrid(np.arange(1, h - 1), np.arange(w), indexing="ij")
    theta, phi = conv.angles(conv.pixel_to_direction(rows, cols, h, w))
    a, b = p.theta_of_row
    np.testing.assert_allclose(a * rows + b, np.degrees(theta), atol=1e-9)
    a, b = p.phi_of_col
    d = np.mod(a * cols + b - np.degrees(phi) + 180.0, 360.0) - 180.0
    np.testing.assert_allclose(d, 0.0, atol=1e-9)
    assert np.all((np.degrees(phi) >= p.phi_low - 1e-9) & (np.degrees(phi) < p.phi_low + 360))


def _srgb(x):
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.maximum(x, 1e-12) ** (1 / 2.4) - 0.055)


@pytest.mark.parametrize("name", ["blender", "pbrt3", "envfit"])
def test_image_is_the_files_pixels_tone_mapped(name):
    conv = convention(name)
    h = 8
    f = np.random.default_rng(2).random((h, 2 * h, 3)) * 3.0      # the file's pixels
    p = map_preview(conv.to_internal(f), conv)
    y = f @ [0.2126, 0.7152, 0.0722]
    om = row_solid_angles(h, 2 * h)
    k = 0.18 / (om @ y.sum(axis=1) / (om.sum() * 2 * h))
    np.testing.assert_allclose(p.image, _srgb(np.clip(k * f, 0, 1)), atol=1e-12)
    assert p.exposure == pytest.approx(k, rel=1e-12)


def test_sun_source_direction_size_and_share():
    h, rho, L, theta, phi = 64, 0.12, 200.0, 0.9, 2.0
    env = EnvMap(SunSkyMap(sun_theta=theta, sun_phi=phi, sun_radius=rho, sun_radiance=L,
                           sky=1.0).render(h), up="y")
    [src] = list_sources(env)
    local = [np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)]
    centre = local_to_world("y") @ local
    assert np.degrees(np.arccos(np.clip(np.dot(src.direction, centre), -1, 1))) < 0.2 * 180 / h
    omega = 2 * np.pi * (1 - np.cos(rho))
    assert src.solid_angle == pytest.approx(omega, rel=0.01)
    assert src.radius_deg == pytest.approx(np.degrees(rho), rel=0.01)
    assert src.excess_share == pytest.approx(L * omega / (4 * np.pi + L * omega), rel=0.01)
    assert src.position["theta_deg"] == pytest.approx(np.degrees(theta), abs=0.2 * 180 / h)
    assert src.position["phi_deg"] == pytest.approx(np.degrees(phi), abs=0.2 * 180 / h)
    assert "1: theta 51.6, phi 114.6 deg" in src.label()


@pytest.mark.parametrize("name", ["mitsuba3", "openexr", "blender", "pbrt3"])
def test_marker_sources_sit_on_the_files_markers(name):
    conv = convention(name)
    h = 32
    f = marker_map(conv.pixel_directions(h), 3 * np.pi / h)       # the file, in conv's layout
    sources = list_sources(conv.to_internal(f), conv)
    red = sources[0]                                             # +x: ten times the others
    assert np.dot(red.direction, [1.0, 0.0, 0.0]) > np.cos(np.pi / h)
    r, c = np.unravel_index(np.argmax(f[..., 0] - f[..., 1]), f.shape[:2])
    assert abs(red.position["row"] - r) <= 1.0 and abs(red.position["col"] - c) <= 1.0
    p = map_preview(conv.to_internal(f), conv, sources=sources)
    assert abs(p.brightest[0] - c) <= 1.0 and abs(p.brightest[1] - r) <= 1.0


def _png_size(path):
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def test_info_out_writes_the_preview_and_the_json(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(cli, "COMMANDS", ("info",))
    env = SunSkyMap(sun_theta=0.6, sun_phi=1.0, sun_radius=0.15, sun_radiance=300.0,
                    sky=(0.4, 0.5, 0.9)).render(16)
    path = save_envmap(tmp_path / "sun.exr", env.astype(np.float32))
    out = tmp_path / "out"
    assert cli.main(["info", str(path), "--out", str(out), "--json", str(tmp_path / "i.json")]) == 0
    text = capsys.readouterr().out
    assert f"wrote {out / 'sun_preview.png'}" in text and "bright sources" in text
    w, h = _png_size(out / "sun_preview.png")
    assert 600 < w < 2000 and 300 < h < 1500
    saved = json.loads((out / "sun_info.json").read_text())
    assert saved == json.loads((tmp_path / "i.json").read_text())
    [s] = saved["sources"]
    assert s["rank"] == 1 and 0 < s["share"] <= 1 and s["position"]["name"] == "envfit"


def test_info_out_unwritable_is_one_line_exit_2(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(cli, "COMMANDS", ("info",))
    path = save_envmap(tmp_path / "m.exr", np.ones((8, 16, 3), np.float32))
    (tmp_path / "f").write_text("x")
    assert cli.main(["info", str(path), "--out", str(tmp_path / "f")]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err.count("\n") == 1 and "cannot write --out" in cap.err


def test_info_out_disk_full_prints_the_results_and_exits_2(tmp_path, monkeypatch, capsys):
    import errno
    import os
    from pathlib import Path

    import envfit.base._atomic as atomic
    import envfit.plots._save as plot_save
    monkeypatch.setattr(cli, "COMMANDS", ("info",))
    orig = atomic.atomic_write_bytes

    def full(path, data):                 # the preview's write fails, the JSON's goes through
        if Path(path).name == "m_preview.png":
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return orig(path, data)
    monkeypatch.setattr(plot_save, "atomic_write_bytes", full)
    path = save_envmap(tmp_path / "m.exr", np.ones((8, 16, 3), np.float32))
    out = tmp_path / "out"
    assert cli.main(["info", str(path), "--out", str(out)]) == 2
    cap = capsys.readouterr()
    assert "16x8 lat-long" in cap.out and "bright sources (>= 5 % of the power): none" in cap.out
    assert cap.err == (f"envfit info: error: could not write {out / 'm_preview.png'}: No space "
                       "left on device (the results above are complete)\n")
    assert json.loads((out / "m_info.json").read_text())["files"]["preview"] is None
    assert sorted(p.name for p in out.iterdir()) == ["m_info.json"]      # no temporary left
