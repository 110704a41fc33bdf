"""Issue 22, item 7: ``envfit sh``'s options bounded before the work — degrees within the
map's band limit H − 1, the planned time and memory within the limits, refused in one line
naming the option and the largest value that fits; the dense check in bounded memory."""
from __future__ import annotations

import math
import re
import time

import numpy as np
import pytest

import envfit.cli as cli
import envfit.sh._plan as sh_plan
from envfit.base._errors import MemoryBudgetError, ParameterError
from envfit.maps import EnvMap
from envfit.maps import pixel_directions, pixel_solid_angles
from envfit.sh._plan import Rates, check_sh_plan, sh_stages
from envfit.sh._ringing import dense_negative_fractions
from envfit.sh._sh_export import sh_coefficients, sh_eval

#: fixed kernel speeds (this machine's order of magnitude), so messages are deterministic
RATES = Rates(basis=2e-8, flop=2e-10, synthesis=1e-9, rotation=2e-9)


@pytest.fixture
def fixed_rates(monkeypatch):
    monkeypatch.setattr(sh_plan, "machine_rates", lambda: RATES)
    monkeypatch.delenv("ENVFIT_TIME_LIMIT", raising=False)


@pytest.fixture
def map64(tmp_path):
    from envfit.maps._io import save_envmap
    d = pixel_directions(64, up="y")
    return save_envmap(tmp_path / "m64.exr", (1.0 + 0.3 * d).astype(np.float32))   # 128x64


@pytest.fixture
def sun_env():
    d = pixel_directions(32, up="y")
    sun = np.exp(40.0 * (d @ np.array([0.6, 0.64, 0.48]) - 1.0))             # a sharp lobe
    return EnvMap(np.stack([0.2 + 30 * sun, 0.3 + 20 * sun, 0.4 + 10 * sun], axis=-1), up="y")


def _one_line(capsys, rc) -> str:
    cap = capsys.readouterr()
    assert rc == 2 and "Traceback" not in cap.err
    lines = [ln for ln in cap.err.splitlines() if ln.strip()]
    assert len(lines) == 1, cap.err
    return lines[0]


# ---------------------------------------------------------------- the reported cases
def test_table_lmax_above_the_band_limit_is_refused_at_once(map64, fixed_rates, capsys):
    t0 = time.perf_counter()
    line = _one_line(capsys, cli.main(["sh", str(map64), "--lmax", "2", "--table-lmax", "500"]))
    assert time.perf_counter() - t0 < 5.0                  # was > 300 s
    assert line == ("envfit sh: error: --table-lmax 500 is outside 1 <= L <= H-1 (the map's "
                    "band limit): H-1 = 63 for this 128x64 map")
    line = _one_line(capsys, cli.main(["sh", str(map64), "--lmax", "64"]))
    assert line.startswith("envfit sh: error: --lmax 64 is outside 0 <= L <= H-1 (the map's "
                           "band limit): H-1 = 63")


def test_check_height_over_the_time_limit_is_refused_with_the_largest_that_fits(map64, fixed_rates, capsys):
    t0 = time.perf_counter()
    line = _one_line(capsys, cli.main(["sh", str(map64), "--lmax", "2", "--check-height",
                                       "16384"]))
    assert time.perf_counter() - t0 < 5.0                  # was a MemoryError traceback
    m = re.fullmatch(r"envfit sh: error: --check-height 16384: the work would take about "
                     r"(\S+) s on this machine \(the dense check \(99 signals on a "
                     r"32768x16384 grid\): \S+ s\), over the 900 s limit \(ENVFIT_TIME_LIMIT\); "
                     r"the largest --check-height that fits is (\d+)", line)
    assert m, line
    best = int(m.group(2))
    # independently: the dense check is 2h^2 (t+1)^2 (basis + K flop) with t = 8, K = 33 x 3
    per_pixel = 81 * (RATES.basis + 99 * RATES.flop)
    assert float(m.group(1)) == pytest.approx(2 * 16384 ** 2 * per_pixel, rel=0.01)
    rest = sum(s.seconds for s in sh_stages(64, 3, 2, 8, dense_height=1, rates=RATES))
    closed = math.floor(math.sqrt((900 - rest) / (2 * per_pixel)))
    assert abs(best - closed) <= 1
    check_sh_plan(64, 3, 2, 8, dense_height=best, rates=RATES)             # fits
    with pytest.raises(ParameterError):
        check_sh_plan(64, 3, 2, 8, dense_height=best + 2, rates=RATES)


def test_memory_refusal_names_the_option_and_what_fits(map64, fixed_rates, monkeypatch, capsys):
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", "200M")        # budget: 80 % of 200 MiB
    line = _one_line(capsys, cli.main(["sh", str(map64), "--lmax", "2", "--irradiance",
                                       "--check-axes", "1048576"]))
    m = re.fullmatch(r"envfit sh: error: --check-axes 1048576: the measured error at 1048576 "
                     r"directions needs 184.5 MB but only 167.8 MB can be used \(80% of "
                     r"ENVFIT_MEMORY_LIMIT=200M\); the largest --check-axes that fits is (\d+)",
                     line)
    assert m, line
    best = int(m.group(1))                  # 32 MiB + 8 M (6 + 4 C) bytes <= budget, C = 3
    assert best == (int(0.8 * 200 * 2**20) - 32 * 2**20) // (8 * 18)


def test_time_limit_from_the_environment(fixed_rates, monkeypatch):
    monkeypatch.setenv("ENVFIT_TIME_LIMIT", "1")
    with pytest.raises(ParameterError, match=r"--table-lmax 40: .* over the 1 s limit"):
        check_sh_plan(64, 3, 2, 40, rates=RATES)
    monkeypatch.setenv("ENVFIT_TIME_LIMIT", "none")
    assert check_sh_plan(64, 3, 2, 63, dense_height=5000, rates=RATES)
    monkeypatch.setenv("ENVFIT_TIME_LIMIT", "soon")
    with pytest.raises(ParameterError, match="ENVFIT_TIME_LIMIT must be"):
        check_sh_plan(64, 3, 2, 8, rates=RATES)


def test_nothing_fits_says_what_to_do(fixed_rates, monkeypatch):
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", "1M")
    with pytest.raises(MemoryBudgetError, match="no value of it fits with the other options: "
                                                r"use --no-check or a smaller map"):
        check_sh_plan(64, 3, 2, 8, rates=RATES)


def test_default_table_on_a_small_map_and_bad_values(tmp_path, capsys):
    from envfit.maps._io import save_envmap
    small = save_envmap(tmp_path / "s.exr", np.full((4, 8, 1), 0.5, dtype=np.float32))
    rc = cli.main(["sh", str(small), "--lmax", "1", "--check-axes", "64", "--check-height",
                   "16", "--json", str(tmp_path / "r.json"), "-q"])
    assert rc == 0
    import json
    rows = json.loads((tmp_path / "r.json").read_text())["ringing"]
    assert sorted({r["L"] for r in rows}) == [1, 2, 3]         # min(8, H - 1) = 3
    line = _one_line(capsys, cli.main(["sh", str(small), "--lmax", "1", "--check-height", "0"]))
    assert line == ("envfit sh: error: argument --check-height: 0 is outside 1 <= H <= 16384 "
                    "(see 'envfit sh --help')")


# ---------------------------------------------------------------- the dense check, in blocks
def test_dense_check_in_blocks_equals_the_whole_grid_sum(sun_env):
    exps = [sh_coefficients(sun_env, L, window=w) for L in (2, 6) for w in ("none", "hanning")]
    exps.append(sh_coefficients(sun_env, 40))                       # above DIRECT_LMAX: None
    blocks = dense_negative_fractions(exps, 48, block_bytes=1)      # one row at a time
    whole = dense_negative_fractions(exps, 48, block_bytes=2**40)
    om = pixel_solid_angles(48)
    brute = []
    for e in exps[:-1]:                                  # the whole grid at once, by hand
        v = sh_eval(e.coefficients, pixel_directions(48, up=e.up))
        tol = 1e-9 * float(np.abs(e.coefficients[0]).max()) / math.sqrt(4 * np.pi)
        brute.append(float(((v < -tol).any(axis=-1) * om).sum() / (4 * np.pi)))
    assert blocks[-1] is None and whole[-1] is None
    assert max(brute) > 0.01                                  # the sun rings: a real test
    assert blocks[:-1] == pytest.approx(brute, abs=1e-12)
    assert whole[:-1] == pytest.approx(brute, abs=1e-12)


def test_dense_check_estimate_within_a_factor_of_its_time(sun_env):
    """The model's dense-check seconds against a real run, both on this machine now."""
    rates = sh_plan.machine_rates()
    exps = [sh_coefficients(sun_env, L, window=w) for L in range(1, 9)
            for w in ("none", "hanning", "lanczos", "none")] + [sh_coefficients(sun_env, 2)]
    height = 160
    t0 = time.perf_counter()
    dense_negative_fractions(exps, height)
    took = time.perf_counter() - t0
    est = next(s for s in sh_stages(32, 3, 2, 8, dense_height=height, rates=rates)
               if s.option == "--check-height").seconds
    assert est / 8 < took + 0.05 and took < 8 * est + 0.5, (est, took)


def test_note_before_a_long_run_states_the_plan_both_ways(tmp_path, monkeypatch, capsys):
    from envfit.maps._io import save_envmap
    small = save_envmap(tmp_path / "s.exr", np.full((8, 16, 3), 0.5, dtype=np.float32))
    argv = ["sh", str(small), "--lmax", "1", "--table-lmax", "2", "--check-axes", "64",
            "--check-height", "16", "--json", str(tmp_path / "r.json")]
    slow = Rates(basis=1e-2, flop=2e-10, synthesis=1e-9, rotation=2e-9)    # a slow machine
    monkeypatch.setattr(sh_plan, "machine_rates", lambda: slow)
    monkeypatch.delenv("ENVFIT_TIME_LIMIT", raising=False)
    assert cli.main(argv) == 0
    err = [ln for ln in capsys.readouterr().err.splitlines() if "note: about" in ln]
    stages = sh_stages(8, 3, 1, 2, check_axes=64, dense_height=16, rates=slow)
    dense = next(s for s in stages if s.option == "--check-height")
    assert dense.seconds == pytest.approx(2 * 16 ** 2 * 9 * (1e-2 + 27 * 2e-10))  # t = 2, K = 27
    assert err == [f"envfit sh: note: about {sum(s.seconds for s in stages):.0f} s of work on "
                   f"this machine (estimated; the dense check (27 signals on a 32x16 grid): "
                   f"{dense.seconds:.0f} s, sized by --check-height)"]
    monkeypatch.setattr(sh_plan, "machine_rates", lambda: RATES)           # a fast one: none
    assert cli.main(argv) == 0
    assert "note: about" not in capsys.readouterr().err


def test_radiance_check_makes_no_directions(sun_env, monkeypatch):
    import envfit.sh._ringing as ringing
    monkeypatch.setattr(ringing, "spherical_fibonacci_sphere",
                        lambda n: (_ for _ in ()).throw(AssertionError("directions made")))
    e = sh_coefficients(sun_env, 2)
    assert ringing.measured_rmse(sun_env, [e], axes=10 ** 9)[0] > 0
