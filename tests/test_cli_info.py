"""Tests of ``envfit info`` through ``envfit.cli.main``."""
from __future__ import annotations

import json

import numpy as np
import pytest

import envfit.cli as cli
from envfit.maps import EnvMap
from envfit.maps import save_envmap
from envfit.maps import pixel_directions, pixel_solid_angles


@pytest.fixture(autouse=True)
def _only_info(monkeypatch):
    # test this subcommand in isolation from the others (which may be work in progress)
    monkeypatch.setattr(cli, "COMMANDS", ("info",))


def _map(h=8, seed=0):
    a = np.random.default_rng(seed).random((h, 2 * h, 3)).astype(np.float32)
    a[5, 11] = [40.0, 50.0, 30.0]            # the brightest pixel
    return a


def test_info_json_values(tmp_path, capsys):
    a = _map()
    p = save_envmap(tmp_path / "sky.exr", a)
    out = tmp_path / "info.json"
    assert cli.main(["info", str(p), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "16x8" in text and "3 channel" in text and "row 5, col 11" in text
    info = json.loads(out.read_text())
    assert (info["width"], info["height"], info["channels"], info["up"]) == (16, 8, 3, "y")
    np.testing.assert_allclose(info["min"], a.min(axis=(0, 1)), rtol=1e-7)
    np.testing.assert_allclose(info["max"], [40.0, 50.0, 30.0])
    om = pixel_solid_angles(8)
    np.testing.assert_allclose(info["mean"], np.einsum("ij,ijc->c", om, a) / (4 * np.pi),
                               rtol=1e-6)
    b = info["brightest"]
    assert (b["row"], b["col"]) == (5, 11)
    np.testing.assert_allclose(b["direction"], pixel_directions(8)[5, 11], atol=1e-12)
    assert b["theta_deg"] == pytest.approx(180 * 5.5 / 8)
    assert b["phi_deg"] == pytest.approx(360 * 11.5 / 16)
    y = a @ np.array([0.2126, 0.7152, 0.0722])
    assert info["dynamic_range"] == pytest.approx(y.max() / y.min(), rel=1e-6)
    assert info["notes"] == []


def test_info_json_stdout_and_options(tmp_path, capsys):
    a = _map(16)
    a[0, 0, 0] = -1.0
    a[1, 1, 1] = np.nan
    p = save_envmap(tmp_path / "m.exr", EnvMap(a, up="z"))
    assert cli.main(["info", str(p), "--up", "z", "--json", "-"]) == 2
    err = capsys.readouterr().err
    assert "--fix-nonfinite" in err
    assert cli.main(["info", str(p), "--up", "z", "--fix-nonfinite", "--max-height", "8",
                     "--json", "-"]) == 0
    info = json.loads(capsys.readouterr().out)      # stdout holds only the JSON
    assert (info["height"], info["up"]) == (8, "z")
    notes = " | ".join(info["notes"])
    assert "replaced 1 non-finite" in notes and "clamped 1 negative" in notes
    assert "resized from 32x16 to 16x8" in notes
    assert cli.main(["info", str(p), "--up", "z", "--fix-nonfinite", "--allow-negative",
                     "--quiet"]) == 0
    assert capsys.readouterr().out == ""


def test_info_missing_file_exit_2(tmp_path, capsys):
    rc = cli.main(["info", str(tmp_path / "nope.exr")])
    assert rc == 2
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1 and "no such file" in lines[0] and lines[0].startswith("envfit info")
    assert "Traceback" not in cap.err and cap.out == ""


def test_info_corrupt_file_exit_2(tmp_path, capsys):
    p = tmp_path / "bad.exr"
    p.write_bytes(b"garbage" * 50)
    assert cli.main(["info", str(p)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bad.exr" in err[0]
