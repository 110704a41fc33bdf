"""``envfit synth``: every kind writes a readable map whose content matches its definition."""
from __future__ import annotations

import json

import numpy as np
import pytest

import envfit.cli as cli
from envfit.maps import load_envmap
from envfit.maps._latlong import local_to_world
from envfit.theory._sobolev import sobolev_coefficients


@pytest.fixture(autouse=True)
def _only_synth(monkeypatch):
    monkeypatch.setattr(cli, "COMMANDS", ("synth",))


def test_gp_map_written_positive_with_expected_variance(tmp_path):
    out = tmp_path / "gp.exr"
    js = tmp_path / "gp.json"
    assert cli.main(["synth", str(out), "--kind", "gp", "--s0", "1.5", "--height", "64",
                     "--seed", "3", "--channels", "1", "--json", str(js), "--quiet"]) == 0
    env = load_envmap(out)
    info = json.loads(js.read_text())
    assert env.data.shape == (64, 128, 1) and env.data.min() > 0
    # sphere variance of the zero-mean sample ≈ Σ_{l ≤ H-1} (2l+1) a_l / 4π minus the l = 0 term
    # (the sample's own mean is removed); one sample: allow a generous band
    a = sobolev_coefficients(1.5, 63)
    l = np.arange(64)
    expected = np.sum((2 * l[1:] + 1) * a[1:]) / (4 * np.pi)
    om = env.solid_angles()
    f = env.data[..., 0].astype(np.float64)
    mean = np.sum(om * f) / (4 * np.pi)
    var = np.sum(om * (f - mean) ** 2) / (4 * np.pi)
    assert 0.3 * expected < var < 3 * expected
    assert info["s0"] == 1.5 and info["offset"] > 0


def test_analytic_kinds(tmp_path):
    for kind, extra, check in [
        ("constant", ["--value", "2.5"], lambda d: np.allclose(d, 2.5)),
        ("step", ["--low", "0.1", "--high", "1", "--theta-edge", "1.5707963267948966"],
         lambda d: np.allclose(d[:8], 1.0) and np.allclose(d[8:], 0.1)),
        ("sky", [], lambda d: d.shape[-1] == 3 and np.all(d[0] < d[-1] + 10)),
    ]:
        out = tmp_path / f"{kind}.exr"
        assert cli.main(["synth", str(out), "--kind", kind, "--height", "16", "--quiet", *extra]) == 0
        assert check(load_envmap(out).data), kind


def test_sun_disk_energy(tmp_path):
    # the disk's pixels are cell averages: its solid-angle integral is radiance x 2π(1 - cos ρ)
    out = tmp_path / "sun.exr"
    assert cli.main(["synth", str(out), "--kind", "sun", "--height", "64", "--sun-radius", "0.1",
                     "--sun-radiance", "100", "--sky", "0.5", "--quiet"]) == 0
    env = load_envmap(out)
    energy = np.sum(env.solid_angles() * (env.data[..., 0] - 0.5))
    assert energy == pytest.approx(100 * 2 * np.pi * (1 - np.cos(0.1)), rel=5e-3)


def test_sun_gp_map_holds_the_recorded_sun_on_a_positive_background(tmp_path):
    """sun-gp: the map minus the same seed's GP background (offset as recorded) integrates to
    radiance × 2π(1 − cos ρ), and the brightest pixel is the recorded direction."""
    from envfit.data_gen._sun_gp import sun_gp_map

    out, js = tmp_path / "sg.exr", tmp_path / "sg.json"
    assert cli.main(["synth", str(out), "--kind", "sun-gp", "--height", "64", "--seed", "4",
                     "--s0", "1.3", "--sun-radius", "0.1", "--sun-radiance", "300",
                     "--channels", "1", "--json", str(js), "--quiet"]) == 0
    env, info = load_envmap(out), json.loads(js.read_text())
    assert env.data.min() > 0 and info["sun"]["radius"] == 0.1
    background, _ = sun_gp_map(64, seed=4, s0=1.3, sun_radius=0.1, sun_radiance=0.0,
                               channels=1, offset=info["offset"])
    energy = np.sum(env.solid_angles() * (env.data[..., 0] - background[..., 0]))
    assert energy == pytest.approx(300 * 2 * np.pi * (1 - np.cos(0.1)), rel=1e-2)
    i, j = np.unravel_index(np.argmax(env.data[..., 0]), env.data.shape[:2])
    world = local_to_world(env.up) @ np.array(info["sun"]["direction"])   # recorded: local, z up
    assert float(env.directions()[i, j] @ world) > np.cos(0.1)


def test_bad_parameters_exit_2(tmp_path, capsys):
    assert cli.main(["synth", str(tmp_path / "x.exr"), "--s0", "2.5", "--height", "8"]) == 2
    err = capsys.readouterr().err
    assert "1 < s < 2" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert cli.main(["synth", str(tmp_path / "x.exr"), "--kind", "sun", "--sun-radius", "-1",
                     "--height", "8"]) == 2
