"""Hostile inputs (issue 12): a huge N, display-referred 8/16-bit files, more samples than
pixels, maps with nothing to fit. Each is one line (exit 2 in the CLI) before any work.

Maps are at most 32 rows, so every test runs in well under a second of work.
"""
from __future__ import annotations

import re
import time

import numpy as np
import pytest

import envfit.advisor._advise
import envfit.advisor._prediction
import envfit.fit._sigma
import envfit.fit._smoothness
import envfit.batch._library
import envfit.batch._library_fit
from envfit.batch import LibraryOptions
import envfit.fit._table2
import envfit.validate._pipeline
from envfit.data_gen import gaussian_process_map
from envfit import cli
from envfit.maps._envmap import EnvMap, check_sample_count
from envfit.maps import load_envmap, save_envmap
from envfit.base._errors import EnvfitError, MemoryBudgetError, ParameterError
from envfit.base._resources import memory_budget_bytes, plan_memory

HUGE = 1_000_000_000
INLINE = LibraryOptions(workers=1)  # every task in this process


def srgb_eotf(c):
    """The oracle: IEC 61966-2-1 sRGB decoding, independent of OpenImageIO."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def srgb_oetf(x):
    x = np.asarray(x, dtype=np.float64)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(np.maximum(x, 0.0031308), 1 / 2.4) - 0.055)


@pytest.fixture(scope="module")
def gp16():
    return EnvMap(gaussian_process_map(1.5, 16, seed=0, channels=3) + 3.0, name="gp16.exr")


@pytest.fixture
def gp16_file(tmp_path, gp16):
    return str(save_envmap(tmp_path / "gp16.exr", gp16))


@pytest.fixture(autouse=True)
def _isolated(monkeypatch, tmp_path):
    monkeypatch.setenv("ENVFIT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("ENVFIT_MEMORY_LIMIT", raising=False)


def _one_error_line(capsys, command: str) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"envfit {command}: error: "), lines[0]
    return lines[0]


def _forbid(monkeypatch, module, name):
    """Make ``module.name`` fail if called: the guard must run before it."""
    def boom(*a, **k):
        raise AssertionError(f"{module.__name__}.{name} was called before the memory guard")
    monkeypatch.setattr(module, name, boom)


# ------------------------------------------------------------------------- a huge N

@pytest.mark.parametrize("argv, n_name", [
    (["table2", "{map}", "--n", str(HUGE)], "N"),
    (["table2", "{map}", "--n", f"100,{HUGE}", "--s", "1.5"], "N"),
    (["fit", "{map}", "--n", str(HUGE)], "n"),
    (["fit", "{map}", "--n", str(HUGE), "--method", "holdout"], "n"),
    (["validate", "{map}", "--n", str(HUGE)], "N"),
    (["validate", "{map}", "--fit-n", str(HUGE)], "fit_n"),
    (["advise", "{map}", "--target-rmse", "0.01", "--nmax", str(HUGE)], "nmax"),
    (["advise", "{map}", "--target-rmse", "0.01", "--nmax", str(HUGE), "--osw-nmax", str(HUGE),
      "--weights", "osw"], "osw_nmax"),
])
def test_huge_n_is_one_line_at_once(argv, n_name, gp16_file, capsys):
    """``--n 1000000000`` used to make the sample points first (23 GB RSS after 82 s): now
    the guard runs first and names the largest N that fits. The timing is of the command
    itself (the modules are imported above; a fresh process adds ~1 s of imports)."""
    argv = [a.format(map=gp16_file) for a in argv]
    t0 = time.perf_counter()
    rc = cli.main(argv)
    elapsed = time.perf_counter() - t0
    assert rc == 2
    line = _one_error_line(capsys, argv[0])
    assert elapsed < 1.0, f"{elapsed:.2f} s"
    if argv[0] != "advise":     # beyond the stated range (issue 38): the flag and its range
        flag = argv[next(i for i, a in enumerate(argv) if str(HUGE) in a) - 1]
        assert f"{flag}" in line and f"{HUGE} is outside" in line, line
        assert "that fits" not in line              # not a memory limit beyond the pixels
        return
    m = re.search(rf"the largest {n_name} that fits is (\d+)$", line)
    assert m, line
    assert 0 < int(m.group(1)) < HUGE
    assert f"{n_name} = {HUGE}" in line and "can be used" in line


def test_huge_n_library_commands(tmp_path, gp16, capsys):
    a = save_envmap(tmp_path / "a.exr", gp16)
    b = save_envmap(tmp_path / "b.exr", gp16.with_data(gp16.data * 2))
    for argv in (["table2", str(a), str(b), "--n", str(HUGE)],
                 ["fit", str(a), str(b), "--n", str(HUGE)]):
        t0 = time.perf_counter()
        assert cli.main(argv) == 2
        assert time.perf_counter() - t0 < 1.0
        line = _one_error_line(capsys, argv[0])     # the pixels first (issue 38), not memory
        assert "W x H = 512 for map a.exr, the library's smallest" in line


def test_guard_runs_before_any_sample_point(monkeypatch, gp16):
    """The API entry points refuse a huge N before making sample points or point sets."""
    _forbid(monkeypatch, envfit.fit._table2, "sample_directions")
    _forbid(monkeypatch, envfit.fit._smoothness, "sample_directions")
    _forbid(monkeypatch, envfit.fit._sigma, "sphere_points")
    _forbid(monkeypatch, envfit.validate._pipeline, "generate")
    _forbid(monkeypatch, envfit.advisor._prediction, "generate")
    _forbid(monkeypatch, envfit.batch._library_fit, "fit_sample_task")
    _forbid(monkeypatch, envfit.batch._library, "sample_task")
    calls = [
        lambda: envfit.fit._table2.run_table2(gp16, [1.5], [HUGE]),
        lambda: envfit.fit._smoothness.fit_smoothness(gp16, n=HUGE),
        lambda: envfit.fit._smoothness.fit_smoothness(gp16, n=HUGE, method="loo"),
        lambda: envfit.validate._pipeline.run_validation(
            gp16, envfit.validate._pipeline.ValidateConfig(n_values=[16, HUGE], truncation=False)),
        lambda: envfit.validate._pipeline.run_validation(
            gp16, envfit.validate._pipeline.ValidateConfig(n_values=[16], fit_n=HUGE, truncation=False)),
        lambda: envfit.fit._sigma.profiled_sigma(gp16, 1.5, n=HUGE),
        lambda: envfit.advisor._advise.advise(gp16, "diffuse", 0.01, nmax=HUGE, weights=("equal",)),
        lambda: envfit.batch._library.run_table2_library([gp16, gp16], [1.5], [HUGE], options=INLINE),
        lambda: envfit.batch._library_fit.fit_smoothness_library([gp16, gp16], n=HUGE, options=INLINE),
    ]
    for call in calls:
        t0 = time.perf_counter()
        with pytest.raises(MemoryBudgetError, match="that fits is [0-9]+"):
            call()
        assert time.perf_counter() - t0 < 1.0


def test_small_budget_gives_the_guard_message(monkeypatch, tmp_path, capsys):
    """Under ENVFIT_MEMORY_LIMIT=200M a moderate N (5000: a 200 MB kernel matrix) is refused,
    and the N it names is exactly the largest that passes the same guard."""
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", "200M")
    env = EnvMap(gaussian_process_map(1.5, 64, seed=1, channels=3) + 3.0, name="gp64.exr")
    path = save_envmap(tmp_path / "gp64.exr", env)     # 8192 pixels: N = 5000 within them
    assert cli.main(["table2", str(path), "--n", "5000", "--s", "1.5", "--solver", "cholesky"]) == 2
    line = _one_error_line(capsys, "table2")
    assert "200.0 MB" not in line and "167.8 MB can be used" in line   # 80 % of 200 MiB
    fits = int(re.search(r"the largest N that fits is (\d+)$", line).group(1))
    assert 1000 < fits < 5000
    px = env.width * env.height
    envfit.fit._table2.plan_table2_memory(fits, env.width, env.height, 3)        # passes
    with pytest.raises(MemoryBudgetError):
        envfit.fit._table2.plan_table2_memory(fits + 1, env.width, env.height, 3)
    assert 5000 <= px                # within the pixels (beyond them --n's range is named first)
    with pytest.raises(MemoryBudgetError, match="fit at n = 5000"):
        envfit.fit._smoothness.fit_smoothness(env, n=5000)
    # a budget too small for anything says so
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", "1M")
    with pytest.raises(MemoryBudgetError, match="not even N = 2 fits"):
        plan_memory(100, "a test")
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", "lots")
    with pytest.raises(ParameterError, match="ENVFIT_MEMORY_LIMIT"):
        memory_budget_bytes()


def test_plan_memory_counts_the_kernel_matrix_and_says_exabytes():
    with pytest.raises(MemoryBudgetError) as e:
        plan_memory(HUGE, "table2", channels=3)
    msg = str(e.value)
    assert f"the {HUGE}x{HUGE} float64 kernel matrix" in msg and "8.0 EB" in msg
    assert plan_memory(1000, "small", channels=3) >= 8 * 1000 ** 2


# ------------------------------------------------------------------------- 8/16-bit files

def _write(path, data, fmt):
    import OpenImageIO as oiio
    h, w, c = data.shape
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), oiio.ImageSpec(w, h, c, fmt))
    assert out.write_image(np.ascontiguousarray(data, dtype=np.float32))
    assert out.close()


@pytest.mark.parametrize("ext, fmt, levels", [("png", "uint8", 255), ("png", "uint16", 65535),
                                              ("tif", "uint8", 255)])
def test_display_referred_files_are_decoded_to_linear(tmp_path, ext, fmt, levels):
    """Known linear radiance, sRGB-encoded and written as an integer file with OpenImageIO,
    reads back as the sRGB EOTF (the oracle formula) of the stored code values, with a note."""
    rng = np.random.default_rng(3)
    linear = rng.random((16, 32, 3)) ** 3 + 1e-4          # many dark values: both branches
    linear[0, :4, 0] = [0.0, 0.001, 0.003, 1.0]
    encoded = srgb_oetf(linear)
    path = tmp_path / f"m_{fmt}.{ext}"
    _write(path, encoded, fmt)
    m = load_envmap(path)
    raw = load_envmap(path, linearize=False)              # the code values in the file
    np.testing.assert_allclose(raw.data, np.rint(encoded * levels) / levels, atol=1.01 / levels)
    assert not any("decoded" in n for n in raw.notes)
    expected = srgb_eotf(raw.data)
    np.testing.assert_allclose(m.data, expected, rtol=1e-3, atol=2e-6)
    # and that is the original radiance to within the file's quantisation
    np.testing.assert_allclose(m.data, linear, rtol=0.03 if levels == 255 else 1e-3, atol=2e-4)
    bits = 8 if fmt == "uint8" else 16
    assert any(n.startswith(f"decoded {bits}-bit sRGB to linear radiance (display-referred "
                            "file: its dynamic range is clipped)") for n in m.notes), m.notes
    if ext == "tif":                                       # untagged: sRGB by convention
        assert any("sRGB assumed" in n for n in m.notes)


def test_jpeg_decoded_and_float_files_untouched(tmp_path):
    rng = np.random.default_rng(4)
    enc = rng.random((16, 32, 3)) * 0.8 + 0.1
    _write(tmp_path / "m.jpg", enc, "uint8")
    m = load_envmap(tmp_path / "m.jpg")
    assert any(n.startswith("decoded 8-bit sRGB") for n in m.notes)
    assert float(m.data.mean()) < float(enc.mean()) - 0.1     # decoded: darker than the codes
    lin = rng.random((16, 32, 3)).astype(np.float32) * 5
    for name in ("m.exr", "m.hdr"):
        save_envmap(tmp_path / name, lin)
        f = load_envmap(tmp_path / name)
        assert not any("decoded" in n for n in f.notes)
        np.testing.assert_allclose(f.data, lin, atol=0.04 if name.endswith("hdr") else 0)  # RGBE


def test_decoded_png_through_the_cli_is_noted(tmp_path, capsys):
    rng = np.random.default_rng(5)
    _write(tmp_path / "m.png", srgb_oetf(rng.random((16, 32, 3)) + 0.05), "uint8")
    assert cli.main(["fit", str(tmp_path / "m.png"), "--n", "100", "--scale", "linear"]) == 0
    assert "note: decoded 8-bit sRGB to linear radiance" in capsys.readouterr().out


# ------------------------------------------------------------------------- N vs pixels

@pytest.mark.parametrize("h", [4, 1])
def test_more_samples_than_pixels_is_an_error(h, tmp_path, capsys):
    """8x4 and 2x1 maps with N = 5000: one line with the pixel count and the largest
    sensible N (an error rather than a cap: see envmap.check_sample_count)."""
    w = 2 * h
    env = EnvMap(np.random.default_rng(0).random((h, w, 3)) + 1.0, name=f"m{w}x{h}.exr")
    px = w * h
    with pytest.raises(ParameterError, match=rf"the largest sensible N is {px}$"):
        envfit.fit._table2.run_table2(env, [1.5], [5000])
    with pytest.raises(ParameterError, match=rf"\({w}x{h}\).*largest sensible n is {px}$"):
        envfit.fit._smoothness.fit_smoothness(env, n=5000, scale="linear")
    with pytest.raises(ParameterError, match="pixels"):
        envfit.batch._library.run_table2_library([env], [1.5], [5000], options=INLINE)
    path = save_envmap(tmp_path / env.name, env)
    for argv in (["table2", str(path), "--n", "5000"], ["fit", str(path), "--n", "5000"]):
        assert cli.main(argv) == 2
        line = _one_error_line(capsys, argv[0])
        assert f"W x H = {px} for map {env.name} ({w}x{h})" in line, line


def test_sample_count_limits_and_validate_fit_n():
    assert check_sample_count(32, 8, 4) == 32
    env = EnvMap(gaussian_process_map(1.5, 8, seed=2, channels=1) + 2.0, name="g8")
    with pytest.raises(ParameterError, match="fit_n = 500 samples is more than the 128 pixels"):
        envfit.validate._pipeline.run_validation(env, envfit.validate._pipeline.ValidateConfig(
            n_values=[16], fit_n=500, truncation=False))
    # the band-limited fit keeps its stricter cap (half of H^2) with a note, not an error
    env16 = EnvMap(gaussian_process_map(1.5, 16, seed=2, channels=1) + 2.0)
    r = envfit.fit._smoothness.fit_smoothness(env16, n=5000, scale="linear", kernel="bandlimited")
    assert r.n <= 128 and any("capped at 128" in n for n in r.notes)


@pytest.mark.parametrize("bad", [3.5, "x", None, 0, -5, True])
def test_n_must_be_a_positive_integer_in_the_api(bad, gp16):
    with pytest.raises(ParameterError, match="must be an integer"):
        envfit.fit._smoothness.fit_smoothness(gp16, n=bad)
    with pytest.raises(ParameterError, match="must be an integer"):
        envfit.fit._table2.run_table2(gp16, [1.5], [100, bad])
    with pytest.raises(ParameterError, match="must be an integer"):
        envfit.validate._pipeline.ValidateConfig(n_values=[16, bad])
    with pytest.raises(ParameterError, match="must be an integer"):
        envfit.batch._library_fit.fit_smoothness_library([gp16], n=bad, options=INLINE)
    with pytest.raises(ParameterError):
        envfit.advisor._advise.advise(gp16, "diffuse", 0.01, nmax=bad)


# ------------------------------------------------------------------------- nothing to fit

def test_all_zero_map_is_one_line(tmp_path, capsys):
    """All zero: on the linear scale nothing to fit (the fit's root search used to meet NaN:
    "The function value at x=1.000001 is NaN"); on log/display the scale is undefined."""
    zero = EnvMap(np.zeros((16, 32, 3), np.float32), name="forest.exr")
    path = save_envmap(tmp_path / "forest.exr", zero)
    assert cli.main(["fit", str(path), "--scale", "linear", "--n", "100"]) == 2
    assert _one_error_line(capsys, "fit") == (
        "envfit fit: error: map forest.exr is all zero on the linear scale: there is nothing to fit")
    for scale in ("log", "display"):
        assert cli.main(["fit", str(path), "--scale", scale, "--n", "100"]) == 2
        line = _one_error_line(capsys, "fit")
        assert line.startswith(f"envfit fit: error: map forest.exr is all zero: the {scale} scale")
        assert "nothing to fit" in line
    assert cli.main(["table2", str(path), "--scale", "linear", "--n", "100"]) == 2
    assert "all zero on the linear scale" in _one_error_line(capsys, "table2")
    # through the API, every pipeline
    for call in (lambda: envfit.fit._smoothness.fit_smoothness(zero, n=100, scale="linear"),
                 lambda: envfit.fit._smoothness.fit_smoothness(zero, n=100, scale="linear", method="loo"),
                 lambda: envfit.fit._table2.run_table2(zero, [1.5], [100], scale="linear"),
                 lambda: envfit.validate._pipeline.run_validation(zero, envfit.validate._pipeline.ValidateConfig(
                     n_values=[16], fit_n=100, scale="linear", truncation=False)),
                 lambda: envfit.advisor._advise.advise(zero, "diffuse", 0.01, scale="linear", fit_n=100),
                 lambda: envfit.batch._library_fit.fit_smoothness_library([zero], n=100, scale="linear",
                                                                   options=INLINE),
                 lambda: envfit.batch._library.run_table2_library([zero], [1.5], [100],
                                                           scale="linear", options=INLINE)):
        with pytest.raises(ParameterError, match="all zero on the linear scale"):
            call()
    with pytest.raises(ParameterError, match="all zero: the log scale"):
        envfit.fit._smoothness.fit_smoothness(zero, n=100, scale="log")


def test_constant_map_and_constant_channel(tmp_path, capsys):
    const = EnvMap(np.full((16, 32, 3), 0.5, np.float32), name="grey.exr")
    path = save_envmap(tmp_path / "grey.exr", const)
    assert cli.main(["fit", str(path), "--scale", "linear", "--n", "100"]) == 2
    assert _one_error_line(capsys, "fit") == (
        "envfit fit: error: map grey.exr is constant on the linear scale (value 0.5): there is "
        "nothing to fit")
    with pytest.raises(ParameterError, match="constant on the display scale"):
        envfit.fit._smoothness.fit_smoothness(const, n=100)
    with pytest.raises(ParameterError, match="constant on the log scale"):
        envfit.fit._table2.run_table2(const, [1.5], [100], scale="log")
    with pytest.raises(ParameterError, match="nothing to fit"):
        envfit.fit._smoothness.fit_smoothness_samples(np.eye(3)[[0, 1, 2] * 5] * [1, 1, 1], np.ones(15))
    # one constant channel among varying ones: fitted on the others, noted, no NaN
    f = gaussian_process_map(1.5, 16, seed=6, channels=2)
    f[:, :, 1] = 0.0
    r = envfit.fit._smoothness.fit_smoothness(EnvMap(f), n=150, scale="linear")
    assert r.sigma[1] == 0.0 and r.sigma[0] > 0
    alone = envfit.fit._smoothness.fit_smoothness(EnvMap(f[:, :, :1]), n=150, scale="linear")
    assert r.s == pytest.approx(alone.s, abs=1e-9)      # fitted on channel 0 alone, as noted
    assert all(np.isfinite(r.s_interval))
    assert any("channel(s) 1 constant" in n for n in r.notes)


def test_every_fault_is_an_envfit_error():
    assert issubclass(MemoryBudgetError, EnvfitError) and issubclass(ParameterError, EnvfitError)
