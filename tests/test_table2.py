"""Table 2 (Sec. 9.1) sweep: RMSE falls with N, cells resume, outputs are complete."""
from __future__ import annotations

import json

import numpy as np
import pytest

import envfit.cli as cli
from envfit.data_gen._gp import gaussian_process_map
from envfit.maps._envmap import EnvMap
from envfit.maps._io import save_envmap
from envfit.base._errors import ParameterError
from envfit.fit._table2 import format_table2, run_table2


@pytest.fixture(scope="module")
def small_map():
    f = gaussian_process_map(1.5, 32, seed=1, channels=3)
    return EnvMap((f - f.min() + 0.5).astype(np.float32), name="gp32")


def test_rmse_decreases_with_n(small_map):
    res = run_table2(small_map, [1.3, 1.7], [25, 100, 400], scale="linear")
    t = res.rmse_table()
    assert t.shape == (2, 3)
    assert np.all(np.diff(t, axis=1) < 0), t
    tw = res.rmse_table("rmse_solid_angle")
    assert np.all(np.diff(tw, axis=1) < 0), tw
    assert res.s_best in (1.3, 1.7)
    text = format_table2(res)
    assert "1.30" in text and "400" in text


def test_rmse_matches_direct_computation(small_map):
    # recompute one cell independently: scipy's RBFInterpolator is a second algorithm for s = 1.5
    from scipy.interpolate import RBFInterpolator

    from envfit.fit._table2 import sample_directions
    res = run_table2(small_map, [1.5], [200], scale="linear")
    pts = sample_directions(200, up=small_map.up)
    vals = small_map.lookup(pts).reshape(200, -1)
    rbf = RBFInterpolator(pts, vals, kernel="linear", degree=0)
    dirs = small_map.directions().reshape(-1, 3)
    recon = rbf(dirs).reshape(small_map.data.shape)
    direct = np.sqrt(np.mean((recon - small_map.data) ** 2))
    # K_gd(1.5) = 8/3 - r differs from -r + constant polynomial only by the constant's penalty
    assert res.cells[0].rmse == pytest.approx(direct, rel=2e-2)


def test_resume_skips_finished_cells(small_map, tmp_path):
    seen = []
    first = run_table2(small_map, [1.5], [50, 100], scale="display", out=tmp_path,
                       on_cell=lambda c, resumed: seen.append(resumed))
    assert seen == [False, False]
    assert (tmp_path / "cells").is_dir() and len(list((tmp_path / "cells").glob("*.json"))) == 2
    assert (tmp_path / "reconstruction_s1.50_n100.exr").exists()
    assert (tmp_path / "reconstruction_s1.50_n100.png").exists()
    seen.clear()
    # a larger grid: the two finished cells are resumed, only the new ones are computed
    second = run_table2(small_map, [1.5, 1.8], [50, 100], scale="display", out=tmp_path,
                        on_cell=lambda c, resumed: seen.append((c.s, c.n, resumed)))
    assert sorted(seen) == [(1.5, 50, True), (1.5, 100, True), (1.8, 50, False), (1.8, 100, False)]
    assert second.cell(1.5, 100).rmse == first.cell(1.5, 100).rmse
    # a different configuration in the same folder is refused, not mixed
    with pytest.raises(ParameterError, match="different table2 run"):
        run_table2(small_map, [1.5], [50], scale="linear", out=tmp_path)


def test_bad_grid():
    m = EnvMap(np.ones((4, 8, 1), np.float32))
    with pytest.raises(ParameterError):
        run_table2(m, [2.0], [10])
    with pytest.raises(ParameterError):
        run_table2(m, [1.5], [1])


def test_cli_table2_outputs(tmp_path, small_map, monkeypatch, capsys):
    monkeypatch.setattr(cli, "COMMANDS", ("table2",))
    path = save_envmap(tmp_path / "m.exr", small_map)
    out = tmp_path / "out"
    js = tmp_path / "t2.json"
    assert cli.main(["table2", str(path), "--s", "1.2,1.8", "--n", "30,120", "--out", str(out),
                     "--json", str(js)]) == 0
    d = json.loads(js.read_text())
    assert d["scale"] == "display" and len(d["rows"]) == 4
    assert set(d["rows"][0]) >= {"s", "n", "rmse", "rmse_solid_angle", "seconds"}
    assert d["s_best"] in (1.2, 1.8)
    for f in ("table2_rmse.png", "table2.csv", "reconstruction_s1.20_n120.exr",
              "reconstruction_s1.80_n120.png"):
        assert (out / f).exists(), f
    printed = capsys.readouterr().out
    assert "RMSE per pixel" in printed and "1.80" in printed
    assert cli.main(["table2", str(path), "--s", "2.3", "--n", "30"]) == 2
    err = capsys.readouterr().err
    assert "1 < s < 2" in err and "Traceback" not in err


def _curve(mse, n=500):
    from envfit.fit._kriging import KrigingCurve, SynthesisModel
    m = SynthesisModel.data_gen(1.5, 32, 16)
    mse = np.asarray(mse, dtype=float)
    return KrigingCurve(model=m, n=n, s_values=[1.3, 1.5, 1.7, 1.9], mse_pixel=mse,
                        mse_solid_angle=mse, variance=1.0, rows=16)


def test_known_s_sentence_is_true_both_ways():
    from envfit.fit._kriging import known_s_sentence
    above = _curve([4.0, 3.0, 2.0, 2.5])                 # expected optimum 1.7 > s0
    s = known_s_sentence(above, 1.7, "linear")
    assert "lowest at s = 1.7 among these s (parabola vertex 1.7" in s
    assert "not at s0 = 1.5, because the band limit, resize and lookup" in s
    assert s.endswith("at s = 1.7, the same s.") and "computed on the linear" not in s
    s = known_s_sentence(above, 1.9, "display")
    assert "a different s" in s and "the same s" not in s
    assert "(computed on the linear scale)" in s and "RMSE on the display scale is at s = 1.9" in s
    at_s0 = known_s_sentence(_curve([3.0, 1.0, 2.0, 2.5]), 1.5, "linear")
    assert "lowest at s = 1.5 = s0" in at_s0 and "because" not in at_s0
    below = known_s_sentence(_curve([1.0, 2.0, 3.0, 4.0]), 1.5, "linear")
    assert "lowest at s = 1.3 among these s, not at s0" in below      # grid end: no vertex
    assert "because" not in below and "a different s" in below


def test_builtin_synthesis_recognises_only_the_builtin_map(small_map):
    from envfit.fit._kriging import builtin_synthesis
    from envfit.maps._default_map import DEFAULT_HEIGHT, DEFAULT_S0, default_envmap
    assert builtin_synthesis(small_map) is None
    m = builtin_synthesis(default_envmap(height=64))
    assert (m.s0, m.height, m.lmax, m.factor) == (DEFAULT_S0, 64, 63, 1)
    m = builtin_synthesis(default_envmap().resized(64))
    assert (m.height, m.lmax, m.factor) == (64, DEFAULT_HEIGHT - 1, DEFAULT_HEIGHT // 64)
    assert builtin_synthesis(default_envmap(height=48).resized(32)) is None
    assert builtin_synthesis(default_envmap(height=512).resized(256)) is None


def test_cli_table2_builtin_map_says_what_to_conclude(tmp_path, small_map, monkeypatch, capsys):
    monkeypatch.setattr(cli, "COMMANDS", ("table2",))
    js = tmp_path / "t2.json"
    assert cli.main(["table2", "--max-height", "64", "--s", "1.3,1.9", "--n", "100,300",
                     "--scale", "linear", "--json", str(js)]) == 0
    printed = capsys.readouterr().out
    d = json.loads(js.read_text())
    k = d["known_s"]
    rows = {(r["s"], r["n"]): r["rmse"] for r in d["rows"]}
    measured = min((1.3, 1.9), key=lambda s: rows[(s, 300)])          # from the rows
    expected = (1.3, 1.9)[int(np.argmin(k["expected_rmse_pixel"]))]
    assert k["n"] == 300 and k["measured_s_best"] == measured and k["expected_s_best"] == expected
    line = [ln for ln in printed.splitlines() if ln.startswith("Known s:")]
    assert len(line) == 1 and line[0] == k["sentence"]
    assert f"lowest at s = {expected:g}" in line[0]
    assert f"measured RMSE is at s = {measured:g}" in line[0]
    assert ("the same s" in line[0]) == (measured == expected)
    # the expected RMSE is of the size measured (one map, 3 channels: within 20 %)
    assert abs(k["expected_rmse_pixel"][0] / rows[(1.3, 300)] - 1) < 0.2
    path = save_envmap(tmp_path / "m.exr", small_map)
    assert cli.main(["table2", str(path), "--s", "1.3", "--n", "30"]) == 0
    assert "Known s" not in capsys.readouterr().out
