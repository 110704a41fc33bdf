"""``envfit sh``: real SH coefficients for engines, irradiance, windows, the ringing predictor.

Every expected value is independent of the code under test: scipy's ``sph_harm_y`` and the
published constants of Ramamoorthi & Hanrahan 2001 for the basis, a direct midpoint
quadrature of the basis on the pixel grid and closed-form coefficients of polynomial maps
for the conversion (every convention's world frame), a Gauss–Legendre quadrature of the
clamped cosine's Legendre projection for Â_l, the patch-by-patch quadrature ground truth
(``shading_integral(method="pixels")``) for the irradiance, and a direct per-pixel sum on
a lat-long grid for the negative fractions predicted on ducc0's Gauss–Legendre grid.
"""
from __future__ import annotations

import csv
import io
import json
import math
import re
import shutil
import subprocess

import numpy as np
import pytest
from scipy.special import sph_harm_y

from envfit import ParameterError, cli
from envfit.data_gen._sun_gp import sun_gp_map
from envfit.maps._conventions import convention
from envfit.maps._envmap import EnvMap
from envfit.maps._latlong import pixel_directions, pixel_solid_angles
from envfit.sh._ringing import (RingingRow, choose, dense_negative_fractions,
                                    negative_fraction, truncation_rmse)
from envfit.sh import SHReportOptions, sh_report
from envfit.shading._bilinear_sh import bilinear_sh_coefficients
from envfit.shading._ground_truth import funk_hecke_factors, shading_integral
from envfit.sh._sh_export import (RH_CONSTANTS, clamped_cosine_sh, real_sh_basis,
                                      rh_irradiance, sh_coefficients, sloan_lambda, sloan_window,
                                      window_weights)
from envfit.shading._spectra import map_degree_power
from envfit.theory._brdf import Diffuse
from envfit.theory._sphere_points import spherical_fibonacci_sphere

RNG_DIRS = np.random.default_rng(0).standard_normal((200, 3))
DIRS = RNG_DIRS / np.linalg.norm(RNG_DIRS, axis=1, keepdims=True)


def _scipy_real(d, lmax):
    """Real SH without the Condon–Shortley phase from scipy's complex ones (which have it)."""
    th, ph = np.arccos(np.clip(d[:, 2], -1, 1)), np.arctan2(d[:, 1], d[:, 0])
    out = np.zeros((d.shape[0], (lmax + 1) ** 2))
    for l in range(lmax + 1):
        for m in range(-l, l + 1):
            y = sph_harm_y(l, abs(m), th, ph)
            v = y.real if m == 0 else math.sqrt(2) * (-1) ** m * (y.real if m > 0 else y.imag)
            out[:, l * (l + 1) + m] = v
    return out


def _poly(d):
    """A smooth degree-3 polynomial field in world coordinates."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return 2.0 + 0.5 * x + 0.25 * y - 0.3 * z + 0.2 * x * y + 0.1 * x * y * z


# ------------------------------------------------------------------ basis and conversion
def test_real_basis_matches_scipy_and_published_constants():
    assert np.abs(real_sh_basis(DIRS, 12) - _scipy_real(DIRS, 12)).max() < 1e-12
    x, y, z = DIRS.T
    rh = np.stack([0.282095 + 0 * x, 0.488603 * y, 0.488603 * z, 0.488603 * x,
                   1.092548 * x * y, 1.092548 * y * z, 0.315392 * (3 * z * z - 1),
                   1.092548 * x * z, 0.546274 * (x * x - y * y)], axis=1)   # R&H 2001, Eq. 3
    assert np.abs(real_sh_basis(DIRS, 2) - rh).max() < 2e-6


@pytest.mark.parametrize("up", ["y", "z", "x"])
def test_complex_to_real_world_frame_vs_quadrature(up):
    d = pixel_directions(64, up=up)
    f = _poly(d)
    sh = sh_coefficients(EnvMap(f[..., None], up=up), 3)
    quad = np.einsum("ij,ijk->k", pixel_solid_angles(64) * f, _scipy_real(d.reshape(-1, 3), 3)
                     .reshape(64, 128, -1))
    assert np.abs(sh.coefficients[:, 0] - quad).max() < 2e-3         # O(h²) of both rules
    assert np.abs(sh.coefficients[:, 0]).max() > 1.0


@pytest.mark.parametrize("name", ["pbrt3", "blender", "mitsuba3", "openexr"])
def test_known_coefficients_in_each_convention(name):
    """L = a + b z + c (x² − y²) in the convention's axes: r00 = a√(4π), r(1,0) = b√(4π/3),
    r(2,2) = c/√(15/16π), all others 0 (closed form; the file laid out by the convention's
    own pixel formula)."""
    conv = convention(name)
    h = 128
    d = conv.pixel_directions(h, 2 * h)
    a, b, c = 2.0, 0.7, 0.4
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    env = conv.to_internal(EnvMap((a + b * z + c * (x * x - y * y))[..., None]))
    got = sh_coefficients(env, 2).coefficients[:, 0]
    want = np.zeros(9)
    want[0], want[2], want[8] = a * math.sqrt(4 * math.pi), b * math.sqrt(4 * math.pi / 3), \
        c / math.sqrt(15 / (16 * math.pi))
    assert np.abs(got - want).max() < 2e-3


def test_condon_shortley_signs_match_sloans_basis():
    """Written with ``condon_shortley``, the coefficients times the basis with the phase
    (Sloan 2008, D3DX: √2 Re/Im of scipy's complex Y) give the same function."""
    from envfit.sh._sh_format import signed_coefficients
    env = EnvMap(_poly(pixel_directions(32, up="z"))[..., None], up="z")
    sh = sh_coefficients(env, 2, condon_shortley=True)
    th, ph = np.arccos(DIRS[:, 2]), np.arctan2(DIRS[:, 1], DIRS[:, 0])
    basis = np.zeros((DIRS.shape[0], 9))
    for l in range(3):
        for m in range(-l, l + 1):
            y = sph_harm_y(l, abs(m), th, ph)
            basis[:, l * (l + 1) + m] = y.real if m == 0 else math.sqrt(2) * (
                y.real if m > 0 else y.imag)
    c = signed_coefficients(sh)
    assert np.allclose(basis @ c, sh.evaluate(DIRS), atol=1e-12)
    assert np.allclose(c[[1, 3, 5, 7]], -sh.coefficients[[1, 3, 5, 7]])


# ------------------------------------------------------------------ irradiance
def test_clamped_cosine_coefficients_vs_quadrature():
    """Â_l = 2π ∫_0^1 z P_l(z) dz (Gauss–Legendre, exact for the degree l + 1 integrand)."""
    x, w = np.polynomial.legendre.leggauss(40)
    z, wz = 0.5 * (x + 1), 0.5 * w
    quad = [2 * np.pi * np.sum(wz * z * np.polynomial.legendre.Legendre.basis(l)(z))
            for l in range(25)]
    assert np.allclose(clamped_cosine_sh(24), quad, atol=1e-13)
    assert np.allclose(clamped_cosine_sh(24), np.pi * funk_hecke_factors(Diffuse(), 24),
                       atol=1e-13)


def test_rh_constants_and_quadratic_form():
    published = {"c1": 0.429043, "c2": 0.511664, "c3": 0.743125, "c4": 0.886227, "c5": 0.247708}
    for k, v in published.items():                 # R&H rounded after rounding the Y's
        assert abs(RH_CONSTANTS[k] - v) < 2e-6, k
    env = EnvMap(_poly(pixel_directions(32, up="y"))[..., None] + 1.0, up="y")
    sh = sh_coefficients(env, 2, irradiance=True)
    assert np.allclose(rh_irradiance(sh.radiance, DIRS), sh.evaluate(DIRS), atol=1e-12)


def test_nine_coefficients_reproduce_ground_truth_irradiance():
    """Measured RMSE of the 9-coefficient irradiance against the patch quadrature ground
    truth (no SH inside) equals the predicted truncation error of the map's spectrum."""
    from envfit.data_gen._gp import gaussian_process_map
    env = EnvMap(gaussian_process_map(1.5, 16, seed=3, offset=4.0), up="y")
    A = spherical_fibonacci_sphere(400)
    truth = np.pi * shading_integral(env, A, "diffuse", method="pixels")
    sh = sh_coefficients(env, 2, irradiance=True)
    measured = float(np.sqrt(np.mean((sh.evaluate(A) - truth) ** 2)))
    P = map_degree_power(env, 31)
    predicted = truncation_rmse(P, clamped_cosine_sh(31), np.ones(3))
    assert 0.99 < measured / predicted < 1.01
    assert measured < 0.05 * np.pi * env.mean().mean()


# ------------------------------------------------------------------ windows and negativity
def test_window_values():
    L = 3
    l = np.arange(L + 1)
    assert np.allclose(window_weights("hanning", L), (1 + np.cos(np.pi * l / 4)) / 2)
    assert np.allclose(window_weights("lanczos", L)[1:],
                       np.sin(np.pi * l[1:] / 4) / (np.pi * l[1:] / 4))
    assert np.allclose(sloan_window(L, 0.1), 1 / (1 + 0.1 * (l * (l + 1)) ** 2))


@pytest.fixture(scope="module")
def sun_env():
    f, _ = sun_gp_map(32, seed=2, sun_theta=0.7, sun_phi=1.0, sun_radius=0.12,
                      sun_radiance=3000.0, offset=1.0, scale=0.2, channels=3)
    return EnvMap(np.maximum(f, 0.0), up="y", name="sun")


def test_negative_fraction_predicted_vs_dense_on_a_sun(sun_env):
    alm = bilinear_sh_coefficients(sun_env, 4)
    pred, exps = [], []
    for L in (1, 2, 4):
        for name in ("none", "hanning", "lanczos"):
            w = window_weights(name, L)
            pred.append(negative_fraction(alm, w * clamped_cosine_sh(L)))
            exps.append(sh_coefficients(sun_env, L, irradiance=True, window=name, alm=alm))
    dense = dense_negative_fractions(exps, 128)
    assert max(pred) > 0.05                           # the sun makes it go negative
    assert np.abs(np.array(pred) - dense).max() < 0.01


@pytest.mark.parametrize("L, window", [(1, "none"), (2, "none"), (2, "hanning"),
                                       (4, "lanczos")])
def test_negative_fraction_of_a_lone_sun_closed_form(L, window):
    """A disc of radius ρ alone: its irradiance is zonal about the sun, E(c) = Σ_l w_l Â_l
    (2l+1)/(4π) F_l P_l(c), F_l = 2π∫_{cos ρ}^1 P_l; the negative share of the sphere is the
    measure of {c : E(c) < 0} / 2 (c uniform on [−1, 1] for uniform directions)."""
    from numpy.polynomial import legendre as leg
    from envfit.data_gen._analytic import SunSkyMap
    rho = 0.15
    sun = SunSkyMap(sun_theta=1.0, sun_phi=2.0, sun_radius=rho, sun_radiance=1.0, sky=0.0,
                    subsamples=16)
    env = EnvMap(sun.render(64), up="z")
    w = window_weights(window, L)
    pred = negative_fraction(bilinear_sh_coefficients(env, L), w * clamped_cosine_sh(L))
    F = [2 * np.pi * leg.Legendre.basis(l).integ(lbnd=np.cos(rho))(1.0) for l in range(L + 1)]
    E = leg.Legendre([w[l] * clamped_cosine_sh(L)[l] * (2 * l + 1) / (4 * np.pi) * F[l]
                      for l in range(L + 1)])
    c = np.linspace(-1.0, 1.0, 400001)
    exact = float(np.mean(E(c) < 0))
    assert abs(pred - exact) < 0.003 and exact > 0.05


def test_sloan_lambda_is_minimal_and_non_negative(sun_env):
    alm = bilinear_sh_coefficients(sun_env, 2)
    g = clamped_cosine_sh(2)
    lam = sloan_lambda(alm, g, 2)
    assert lam > 0 and negative_fraction(alm, g) > 0.05
    assert negative_fraction(alm, g * sloan_window(2, lam)) == 0.0
    assert negative_fraction(alm, g * sloan_window(2, lam / 1.01)) > 0.0
    ex = sh_coefficients(sun_env, 2, irradiance=True, window="sloan", alm=alm)
    assert dense_negative_fractions([ex], 128)[0] < 1e-3


def test_windowed_prediction_matches_measurement(sun_env):
    r = sh_report(sun_env, 3, SHReportOptions(window="hanning", table_lmax=3, check_axes=1024,
                                              dense_height=64))
    assert 0.95 < r.measured_relative_rmse / r.predicted_relative_rmse < 1.05
    for row in r.rows:
        assert abs(row.dense_negative_fraction - row.negative_fraction) < 0.01
        assert 0.9 < row.measured_relative_rmse / row.predicted_relative_rmse < 1.1
    with pytest.raises(ParameterError, match="options must be an SHReportOptions, got dict"):
        sh_report(sun_env, 3, {"window": "hanning"})         # the options are a dataclass


def test_choice_sentences():
    def row(L, w, e, n):
        return RingingRow(L=L, window=w, window_lambda=None, predicted_relative_rmse=e,
                          negative_fraction=n)
    rows = [row(1, "none", 0.2, 0.1), row(2, "none", 0.008, 0.05),
            row(2, "hanning", 0.02, 0.0), row(3, "hanning", 0.009, 0.0)]
    r, s = choose(rows, 0.01)
    assert (r.L, r.window) == (3, "hanning") and "0.900%" in s and "no negative" in s
    r, s = choose(rows[:2], 0.01)
    assert (r.L, r.window) == (2, "none") and "5.00%" in s and "goes negative" in s
    r, s = choose(rows, 0.001)
    assert (r.L, r.window) == (2, "none") and "no degree up to 3" in s and "0.900%" in s


# ------------------------------------------------------------------ command line
@pytest.fixture(scope="module")
def sun_file(tmp_path_factory, sun_env):
    from envfit.maps._io import save_envmap
    return save_envmap(tmp_path_factory.mktemp("sh") / "sun.exr",
                       sun_env.data.astype(np.float32))


FAST = ["--table-lmax", "2", "--check-axes", "256", "--check-height", "32"]
QUICK = ["--table-lmax", "1", "--no-check"]


def _run(argv, capsys):
    rc = cli.main(argv)
    out, err = capsys.readouterr()
    return rc, out, err


@pytest.mark.parametrize("L", [1, 2])
def test_cli_formats_parse(L, sun_file, capsys):
    rc, out, _ = _run(["sh", str(sun_file), "--lmax", str(L), "--irradiance", *FAST], capsys)
    assert rc == 0
    d = json.loads(out)
    assert d["lmax"] == L and len(d["coefficients"]) == (L + 1) ** 2 and d["size"] == "64x32"
    assert "no Condon-Shortley" in d["normalisation"] and d["ordering"].startswith("flat")
    assert d["measured_relative_rmse"] == pytest.approx(d["predicted_relative_rmse"], rel=0.1)
    rc, out, _ = _run(["sh", str(sun_file), "--lmax", str(L), "--format", "csv", *QUICK], capsys)
    rows = list(csv.DictReader(io.StringIO(out)))
    assert rc == 0 and len(rows) == (L + 1) ** 2 and list(rows[0]) == ["l", "m", "index",
                                                                        "R", "G", "B"]
    _, out_cs, _ = _run(["sh", str(sun_file), "--lmax", str(L), "--format", "csv",
                         "--condon-shortley", *QUICK], capsys)
    for a, b in zip(rows, csv.DictReader(io.StringIO(out_cs))):
        assert float(b["R"]) == (-1) ** int(a["m"]) * float(a["R"])
    rc, out, _ = _run(["sh", str(sun_file), "--lmax", str(L), "--format", "glsl", *QUICK], capsys)
    n = (L + 1) ** 2
    body = re.search(rf"const vec3 shCoefficients\[{n}\] = vec3\[{n}\]\((.*?)\n\);", out, re.S)
    assert rc == 0 and body and body.group(1).count("vec3(") == n
    rc, out, _ = _run(["sh", str(sun_file), "--lmax", str(L), "--format", "glsl", "--irradiance",
                       *QUICK], capsys)
    body = re.search(rf"shCoefficients\[{n}\] = vec3\[{n}\]\((.*?)\n\);", out, re.S).group(1)
    vals = [[float(v) for v in t.split(",")] for t in re.findall(r"vec3\(([^)]*)\)", body)]
    assert np.allclose(vals, [c["values"] for c in d["coefficients"]], rtol=1e-8, atol=0)


@pytest.mark.skipif(shutil.which("glslangValidator") is None, reason="no glslangValidator")
def test_glsl_compiles(sun_file, capsys, tmp_path):
    _, out, _ = _run(["sh", str(sun_file), "--lmax", "2", "--irradiance", "--format", "glsl",
                      "--no-check", "--table-lmax", "2"], capsys)
    src = tmp_path / "sh.frag"
    src.write_text("#version 330\n" + out + "\nin vec3 nrm; out vec4 col;\nvoid main() { "
                   "col = vec4(shEval(nrm) + shIrradianceRH(nrm), 1.0); }\n")
    assert subprocess.run(["glslangValidator", str(src)], capture_output=True).returncode == 0


def test_cli_out_writes_png_and_files(sun_file, tmp_path, capsys):
    rc, out, _ = _run(["sh", str(sun_file), "--lmax", "2", "--irradiance", "--window",
                       "sloan", "--out", str(tmp_path / "o"), *FAST], capsys)
    assert rc == 0 and "choice:" in out
    for name in ("sh.png", "sh.json", "sh.csv", "sh.glsl", "ringing.csv"):
        assert (tmp_path / "o" / name).is_file(), name
    assert (tmp_path / "o" / "sh.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    d = json.loads((tmp_path / "o" / "sh.json").read_text())
    assert d["window"] == "sloan" and d["window_lambda"] > 0 and d["negative_fraction"] == 0.0


@pytest.mark.parametrize("argv, words", [
    (["--lmax", "32"], "band limit"),
    (["--lmax", "-1"], "--lmax"),
    (["--lmax", "2", "--format", "hlsl"], "--format"),
    (["--lmax", "2", "--window", "kaiser"], "--window"),
])
def test_cli_bad_input_exits_2(argv, words, sun_file, capsys):
    rc, out, err = _run(["sh", str(sun_file), *argv], capsys)
    assert rc == 2 and out == "" and words in err
    assert len([x for x in err.splitlines() if "error" in x]) == 1


def test_cli_unreadable_map_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.exr"
    bad.write_bytes(b"not an exr")
    for path in (bad, tmp_path / "missing.exr"):
        rc, out, err = _run(["sh", str(path), "--lmax", "2"], capsys)
        assert rc == 2 and out == "" and len(err.strip().splitlines()) == 1
