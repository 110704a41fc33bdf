"""Tests of the advisor's renderer rows (envfit.advisor._rule_rows; ``envfit advise`` with its
renderer table, --strategies, --renderer-pointsets, --no-renderer, advise.png) and of the
early stop of the paper rows' N search (envfit.advisor._search.smallest_n).

Reference values come from a second path: every N of the renderer grid predicted directly
with :func:`envfit.predict.predict_rule` against the search; rows constructed by hand
against the recommendation; a fresh model against the cached one; :func:`measure_rule` called
directly against the check; the doubling-and-bisection search written out again against the
early-stopping one. Maps are 16 rows (a sun on a GP background, a GP map), the spectra on a
grid of 32 with 8 axes.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from envfit.advisor._advise import advise
from envfit.advisor._cache import AdviseCache
from envfit.advisor._rule_rows import (RendererRow, best_renderer_row, check_renderer_rows,
                                      renderer_n_grid, renderer_recommendation,
                                      search_renderer_row)
from envfit.advisor._rule_rows_cache import cached_renderer_model
from envfit.advisor._search import smallest_n
from envfit.data_gen._gp import gaussian_process_map
from envfit.data_gen._sun_gp import sun_gp_map
from envfit.maps._envmap import EnvMap
from envfit.maps._io import save_envmap
from envfit.predict import predict_rule
from envfit.predict.warped._predictor import renderer_model
from envfit.predict.warped._warped_spectrum import WarpedSpectrum
from envfit.sampling import STRATEGIES, RendererRule
from envfit.measure import RendererSetup, measure_rule

GRID, AXES = 32, 8
KEY = {"fingerprint": "test", "shape": [16, 32, 1], "up": "y", "scale": "linear"}


@pytest.fixture(scope="module")
def sun16():
    return EnvMap(sun_gp_map(16, seed=2, sun_radiance=30.0, sun_radius=0.25)[0], name="sun16")


@pytest.fixture(scope="module")
def setup16(sun16):
    return RendererSetup.of(sun16)


@pytest.fixture(scope="module")
def model16(setup16):
    return renderer_model(setup16, "diffuse", strategies=tuple(STRATEGIES), grid=GRID, axes=AXES)


# ----------------------------------------------------------------------------- the N grid

def test_renderer_grid_is_powers_of_two_for_sobol_and_adds_three_halves_for_others():
    assert renderer_n_grid("sobol", 4, 100) == [4, 8, 16, 32, 64]
    assert renderer_n_grid("sobol", 5, 8) == [8]
    want = sorted({2 ** k for k in range(1, 8)} | {3 * 2 ** (k - 1) for k in range(1, 7)})
    assert renderer_n_grid("sf", 1, 128) == want                     # 2, 3, 4, 6, …, 96, 128
    assert renderer_n_grid("random", 7, 40) == [8, 12, 16, 24, 32]
    assert renderer_n_grid("sobol", 5, 7) == []


# ----------------------------------------------------------------------------- the rows

def _direct(model, strategy, pointset, target, nmin, nmax):
    """Second path: every grid N predicted; the smallest passing N, or None if nmax misses."""
    ns = renderer_n_grid(pointset, nmin, nmax)
    preds = [predict_rule(model, RendererRule(strategy, pointset, n)).rmse for n in ns]
    if preds[-1] > target:
        return None, ns, preds
    return next(n for n, p in zip(ns, preds) if p <= target), ns, preds


@pytest.mark.parametrize("pointset", ["sobol", "sf", "random"])
def test_each_row_is_the_smallest_grid_n_meeting_the_target(model16, setup16, pointset):
    pixels = sum(s.summary()["pixels"] for s in setup16.sources)
    assert pixels > 0                                                # the sun is found
    p64 = predict_rule(model16, RendererRule("mis", pointset, 64)).rmse
    for target in (p64, 0.5 * p64, 1e-9):
        for strategy in STRATEGIES:
            row = search_renderer_row(model16, strategy, pointset, target, 4, 1024, pixels)
            n, ns, preds = _direct(model16, strategy, pointset, target, 4, 1024)
            assert row.n == n, (strategy, target)
            if n is None:
                assert row.setting == "N > 1024" and row.cost is None
                assert row.predicted_rmse == preds[-1] > target
                assert "not reached" in row.note
            else:
                k = ns.index(n)
                assert preds[k] <= target and row.predicted_rmse == preds[k]
                assert k == 0 or preds[k - 1] > target                # the grid N below misses
                assert row.cost == n + (pixels if strategy == "split" else 0)
            assert row.predictor == ("random-variance" if pointset == "random"
                                     else "warped-spectrum")


# ----------------------------------------------------------------------------- recommendation

def _row(strategy, pointset, n, pred, extra=0, top=65536):
    r = RendererRow(strategy=strategy, pointset=pointset, n=n, extra_cost=extra,
                    predicted_rmse=pred, searched_max=top,
                    cost=None if n is None else n + extra)
    return r


def test_recommendation_is_the_cheapest_meeting_row_with_the_split_cost():
    rows = [_row("mis", "sobol", 32, 0.009), _row("split", "sobol", 16, 0.008, extra=24),
            _row("brdf", "sobol", None, 0.05), _row("map", "sf", 64, 0.0091)]
    best = best_renderer_row(rows)
    assert best.label == "mis/sobol"                               # 32 < 16 + 24
    text = renderer_recommendation(rows, 0.0095, 0.95, 0.01)
    assert text.startswith("renderer: use mis/sobol with N = 32 per shading point")
    assert "1 % of the mean shading" in text
    assert "BRDF sampling would need N > 65536" in text
    rows[1] = _row("split", "sobol", 16, 0.008, extra=8)            # 16 + 8 < 32
    assert best_renderer_row(rows).label == "split/sobol"
    text = renderer_recommendation(rows, 0.0095, 0.95, 0.01)
    assert "split/sobol with N = 16 + 8 source pixels = cost 24" in text
    rows[2] = _row("brdf", "sobol", 4096, 0.009)                    # now BRDF sampling reaches
    text = renderer_recommendation(rows, 0.0095, 0.95, 0.01)
    assert "would need" not in text and "BRDF sampling needs sobol N = 4096" in text


def test_recommendation_ties_go_to_the_lower_prediction_and_none_is_said():
    rows = [_row("map", "sf", 64, 0.009), _row("map", "sobol", 64, 0.007)]
    assert best_renderer_row(rows).label == "map/sobol"
    none = [_row("map", "sf", None, 0.03), _row("brdf", "sobol", None, 0.02)]
    assert best_renderer_row(none) is None
    text = renderer_recommendation(none, 0.01, 1.0, 0.01)
    assert text.startswith("renderer: no renderer rule meets 1 % of the mean shading")
    assert "closest is brdf/sobol (predicted 0.02 at N = 65536)" in text


# ----------------------------------------------------------------------------- the cache

def test_cached_spectra_give_bit_identical_predictions(setup16, model16, tmp_path):
    for key, spec in model16.spectra.items():
        back = WarpedSpectrum.from_json(json.loads(json.dumps(spec.to_json())))
        for name in ("variance", "power", "cross"):
            assert np.array_equal(getattr(back, name), getattr(spec, name))
    store = AdviseCache(tmp_path)
    fresh, loaded, computed = cached_renderer_model(setup16, KEY, "diffuse", 30.0,
                                                    tuple(STRATEGIES), GRID, AXES, store)
    assert (loaded, computed) == (0, 4)
    again, loaded, computed = cached_renderer_model(setup16, KEY, "diffuse", 30.0,
                                                    tuple(STRATEGIES), GRID, AXES,
                                                    AdviseCache(tmp_path))
    assert (loaded, computed) == (4, 0)
    for s in STRATEGIES:
        for ps, n in (("sobol", 16), ("sf", 24), ("random", 12)):
            r = RendererRule(s, ps, n)
            p = predict_rule(model16, r).rmse
            assert predict_rule(fresh, r).rmse == p == predict_rule(again, r).rmse


def test_a_corrupt_cache_file_is_ignored_with_a_note(setup16, model16, tmp_path):
    cached_renderer_model(setup16, KEY, "diffuse", 30.0, ("map",), GRID, AXES,
                          AdviseCache(tmp_path))
    victim = next((tmp_path / "advise" / "renderer").glob("*.json"))
    victim.write_bytes(victim.read_bytes()[:-40] + b"garbage")
    store = AdviseCache(tmp_path)
    m, loaded, computed = cached_renderer_model(setup16, KEY, "diffuse", 30.0, ("map",), GRID,
                                                AXES, store)
    assert (loaded, computed) == (0, 1)
    assert len(store.notes) == 1 and str(victim) in store.notes[0]
    r = RendererRule("map", "sobol", 32)
    assert predict_rule(m, r).rmse == predict_rule(model16, r).rmse


# ----------------------------------------------------------------------------- the check

def test_check_is_measure_rule_at_the_rows_n(setup16, model16):
    pixels = sum(s.summary()["pixels"] for s in setup16.sources)
    rows = [search_renderer_row(model16, s, "sobol", 0.2, 4, 256, pixels) for s in ("map", "split")]
    rows.append(search_renderer_row(model16, "brdf", "random", 1e-9, 4, 256))   # unreached
    check_renderer_rows(setup16, rows, "diffuse", 30.0, 0.2, seed=3, axes_start=8, max_axes=16)
    for r in rows[:2]:
        out = measure_rule(setup16, RendererRule(r.strategy, r.pointset, r.n), "diffuse", 30.0,
                           seed=3, target_relative=0.10, axes_start=8, max_axes=16)
        assert r.measured_rmse == out.interval.rmse
        assert (r.measured_low, r.measured_high) == (out.interval.low, out.interval.high)
        assert r.measured_axes == out.axes and r.measured_over_target == r.measured_rmse / 0.2
    assert rows[2].measured_rmse is None


def test_advise_carries_a_renderer_section(sun16, tmp_path):
    a = advise(sun16, "glossy", target_relative=0.05, shininess=10.0, s=1.5, fit_n=100,
               pointsets=(), bases=("sh",), nmax=512, renderer=True,
               strategies=("map", "split"), renderer_pointsets=("sobol", "random"),
               renderer_grid=GRID, renderer_spectrum_axes=AXES, cache_dir=tmp_path)
    sec = a.renderer
    assert [r.label for r in sec.rows] != [] and len(sec.rows) == 4
    assert sec.recommendation == renderer_recommendation(sec.rows, a.target_rmse,
                                                         a.mean_shading, 0.05)
    m = renderer_model(RendererSetup.of(sun16), "glossy", 10.0, strategies=("map", "split"),
                       grid=GRID, axes=AXES)
    for r in sec.rows:
        n, _, _ = _direct(m, r.strategy, r.pointset, a.target_rmse, 4, 512)
        assert r.n == n
    d = json.loads(json.dumps(a.to_dict()))
    assert d["renderer"]["rows"][0]["label"] == sec.rows[0].label
    assert d["renderer"]["source_pixels"] == sec.source_pixels > 0
    assert advise(sun16, "diffuse", target_relative=0.05, s=1.5, fit_n=100, pointsets=("sf",),
                  weights=("equal",), bases=(), nmax=64, cache=False).renderer is None


def test_advise_goes_through_the_predictor_registry(sun16, tmp_path, monkeypatch):
    """Every prediction of the advisor — the quadrature rows' (b), (b′), (c) and the renderer
    rows' — is made by envfit.predict.predict from PREDICTORS: wrapping the entries sees
    every one of them called, and the rows' numbers are the wrapped predictors' own."""
    from envfit.predict import PREDICTORS
    calls: dict[str, int] = {}

    def counted(name, f):
        def g(ctx, rule):
            calls[name] = calls.get(name, 0) + 1
            return f(ctx, rule)
        g.rule_type = f.rule_type
        return g
    for name, f in list(PREDICTORS.items()):
        monkeypatch.setitem(PREDICTORS, name, counted(name, f))
    a = advise(sun16, "diffuse", target_relative=0.05, s=1.5, fit_n=100, pointsets=("sf",),
               weights=("equal",), bases=(), nmax=256, renderer=True, strategies=("map",),
               renderer_pointsets=("sobol", "random"), renderer_grid=GRID,
               renderer_spectrum_axes=AXES, cache_dir=tmp_path)
    assert set(calls) == {"plain", "bandlimited", "spectral", "random-variance",
                          "warped-spectrum"}
    assert {r.predictor for r in a.renderer.rows} == {"random-variance", "warped-spectrum"}
    assert sum(len(r.curve["n"]) for r in a.renderer.rows) == (calls["random-variance"] +
                                                               calls["warped-spectrum"])


# ----------------------------------------------------------------------------- the paper search

def _old_smallest_n(predict, target, nmin, nmax):
    """The search before the early stop: doubling from nmin, then bisection."""
    seen = {}

    def ok(n):
        seen.setdefault(n, predict(n))
        return seen[n] <= target

    if ok(nmin):
        return nmin
    lo, hi = nmin, min(2 * nmin, nmax)
    while not ok(hi):
        if hi >= nmax:
            return None
        lo, hi = hi, min(2 * hi, nmax)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if ok(mid) else (mid, hi)
    return hi


def test_early_stop_returns_the_full_search_n_or_stops_after_one_evaluation():
    rng = np.random.default_rng(5)
    for _ in range(40):
        a, b = rng.uniform(0.3, 2.0), rng.uniform(0.1, 10.0)
        f = (lambda a, b: lambda n: b * n ** -a)(a, b)
        target = f(int(rng.integers(4, 5000)))
        assert smallest_n(f, target, 4, 4096)[0] == _old_smallest_n(f, target, 4, 4096)
    calls = []
    n, seen = smallest_n(lambda n: calls.append(n) or 1.0 / n, 1e-6, 4, 65536)
    assert n is None and calls == [65536] and seen == {65536: 1.0 / 65536}


# ----------------------------------------------------------------------------- the CLI

@pytest.fixture(scope="module")
def exr16(sun16, tmp_path_factory):
    p = tmp_path_factory.mktemp("maps") / "sun16.exr"
    save_envmap(p, sun16.data)
    return p


def _cli(args, cwd):
    env = {**os.environ, "ENVFIT_CACHE_DIR": str(Path(cwd) / "cache")}
    return subprocess.run([sys.executable, "-m", "envfit.cli", "advise", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize("flag, bad", [("--strategies", "map,bogus"),
                                       ("--renderer-pointsets", "sobol,halton")])
def test_cli_bad_names_are_one_line_and_exit_2(exr16, tmp_path, flag, bad):
    p = _cli([str(exr16), flag, bad], tmp_path)
    assert p.returncode == 2
    lines = [x for x in p.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and bad.split(",")[1] in lines[0]
    assert not (tmp_path / "cache" / "advise" / "fit").exists()  # before any work


def test_cli_renderer_table_json_and_png(exr16, tmp_path):
    common = [str(exr16), "--fit-n", "100", "--s", "1.5", "--pointsets", "sf", "--weights",
              "equal", "--bases", "sh", "--nmax", "256", "--target-relative", "0.05",
              "--renderer-grid", str(GRID), "--renderer-spectrum-axes", str(AXES), "-q"]
    p = _cli([*common[:-1], "--strategies", "map,split", "--renderer-pointsets", "sobol",
              "--json", "a.json", "--out", "out"], tmp_path)
    assert p.returncode == 0, p.stderr
    assert "renderer rule" in p.stdout and "renderer: " in p.stdout
    d = json.loads((tmp_path / "a.json").read_text())
    assert [r["label"] for r in d["renderer"]["rows"]] and \
        {r["strategy"] for r in d["renderer"]["rows"]} == {"map", "split"}
    png = (tmp_path / "out" / "advise.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and png[12:16] == b"IHDR" and png[-8:-4] == b"IEND"
    w, h = int.from_bytes(png[16:20], "big"), int.from_bytes(png[20:24], "big")
    assert w > 200 and h > 200
    p = _cli([*common[:-1], "--no-renderer", "--json", "b.json"], tmp_path)
    assert p.returncode == 0 and "renderer" not in p.stdout
    assert json.loads((tmp_path / "b.json").read_text())["renderer"] is None


# ----------------------------------------------------------------------------- the box note
# (issue 22, item 8: "conservative" was printed where the check measured 1.48x the prediction)

@pytest.mark.parametrize("low, high, says", [
    (0.0141, 0.0155, "not conservative here"),           # the whole interval above: 1.48x
    (0.0060, 0.0080, "conservative here"),               # the whole interval below
    (0.0090, 0.0110, "cannot tell whether it is conservative"),   # straddles the prediction
])
def test_box_note_is_what_the_measurement_says(low, high, says):
    from envfit.advisor._rule_rows import extrapolation_note
    r = RendererRow("brdf", "sf", n=24576, predicted_rmse=0.01, box=4096)
    before = extrapolation_note(r)
    assert before.endswith("; not checked") and "conservative" not in before
    r.measured_rmse, r.measured_low, r.measured_high = 0.5 * (low + high), low, high
    after = extrapolation_note(r)
    assert after.endswith(says) and after.startswith(before[:-len("; not checked")])
    assert f"measured {r.measured_rmse / 0.01:.2f}x the prediction" in after
    if says == "conservative here":
        assert "not conservative" not in after


def test_box_note_on_a_searched_and_checked_row(setup16, model16):
    """A sobol row sized beyond the grid-32 box (16): the note says "not checked" and never
    "conservative"; after the check it states where the measured interval lies."""
    pred = {n: predict_rule(model16, RendererRule("map", "sobol", n)).rmse
            for n in renderer_n_grid("sobol", 4, 256)}
    target = 0.5 * (pred[32] + pred[64])                  # N = 64 > (32/8)^2 = 16
    r = search_renderer_row(model16, "map", "sobol", target, 4, 256)
    assert r.n == 64 and r.box == 16
    assert r.note.endswith("not checked") and "conservative" not in r.note
    check_renderer_rows(setup16, [r], "diffuse", 30.0, target, seed=3, axes_start=8,
                        max_axes=16)
    p = r.predicted_rmse
    want = ("conservative here" if r.measured_high <= p else "not conservative here"
            if r.measured_low > p else "cannot tell")
    assert want in r.note and "not checked" not in r.note
    q = search_renderer_row(model16, "map", "sobol", pred[8] * 1.0001, 4, 256)
    assert q.n <= 16 and q.box is None and "box" not in q.note
