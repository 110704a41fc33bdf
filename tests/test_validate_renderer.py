"""Tests of ``envfit validate --renderer``: envfit.validate._renderer, its report section
(envfit.validate._report_verdicts' renderer verdicts and the ``renderer_*`` conditions), envfit.plots._renderer and
the CLI flags.

Independent references: :func:`envfit.predict.predict_rule` and
:func:`envfit.measure._rules.measure_rule` called directly on a fresh setup (a second
path, same seeds), ``statistics.median`` and hand-written loops for the summaries,
``json`` for the round trip, matplotlib's PNG reader, and results constructed by hand where a
report condition holds and where it fails. A 32×16 sun-on-GP map, N ≤ 32, few axes.
"""
from __future__ import annotations

import json
import math
import statistics
import subprocess
import sys

import numpy as np
import pytest

import envfit.validate._renderer as VR
from envfit.base._atomic import to_jsonable
from envfit.base._errors import ParameterError
from envfit.data_gen._sun_gp import sun_gp_map
from envfit.maps._envmap import EnvMap
from envfit.maps._io import load_envmap, save_envmap
from envfit.predict import predict_rule
from envfit.predict.warped._predictor import renderer_model
from envfit.measure._adaptive_rmse import agreement_with_interval
from envfit.sampling._rules import RendererRule
from envfit.measure._rules import RendererSetup, measure_rule
from envfit.validate import _report as R
from envfit.validate import _report_predicates as RC
from envfit.validate import _report_template as RT
from envfit.validate import _report_verdicts as RV

SMALL = dict(strategies=("map", "split"), pointsets=("sobol", "random"), lobes=("diffuse",),
             n_values=(16, 32), grid=64, spectrum_axes=8, axes_start=60, max_axes=120,
             resamples=200)


@pytest.fixture(scope="module")
def sun_map():
    data, _ = sun_gp_map(16, seed=5, sun_radiance=50.0, sun_radius=0.25)
    return EnvMap(data, name="sun-gp")


@pytest.fixture(scope="module")
def cfg():
    return VR.renderer_quick_config(**SMALL)


@pytest.fixture(scope="module")
def result(sun_map, cfg):
    return VR.run_renderer_validation(sun_map, cfg)


# ----------------------------------------------------------------------------- the cells

def test_cells_cover_the_configuration(result, cfg):
    got = [(c.lobe, c.strategy, c.pointset, c.n) for c in result.cells]
    assert got == [(lb, s, p, n) for lb in cfg.lobes for s in cfg.strategies
                   for p in cfg.pointsets for n in cfg.n_values]
    assert {c.predictor for c in result.cells if c.pointset == "random"} == {"random-variance"}
    assert {c.predictor for c in result.cells if c.pointset == "sobol"} == {"warped-spectrum"}
    assert len(result.sources) == 1 and 0.0 < result.sources[0]["share"] < 1.0


def test_predicted_equal_predict_rule_directly(result, sun_map, cfg):
    setup = RendererSetup.of(sun_map)                          # a second, fresh path
    model = renderer_model(setup, "diffuse", cfg.shininess, strategies=list(cfg.strategies),
                           grid=cfg.grid, axes=cfg.spectrum_axes)
    for c in result.cells:
        p = predict_rule(model, RendererRule(c.strategy, c.pointset, c.n))
        assert c.predictor == p.name
        assert c.predicted_rmse == pytest.approx(p.rmse, rel=1e-12)


@pytest.mark.parametrize("strategy,pointset,n", [("split", "sobol", 32), ("map", "random", 16)])
def test_measured_equal_measure_rule_directly(result, sun_map, cfg, strategy, pointset, n):
    setup = RendererSetup.of(sun_map)
    m = measure_rule(setup, RendererRule(strategy, pointset, n), "diffuse", cfg.shininess,
                     seed=cfg.seed, target_relative=cfg.target_relative,
                     axes_start=cfg.axes_start, max_axes=cfg.max_axes, resamples=cfg.resamples,
                     sampling=cfg.axis_sampling)
    c = result.cell("diffuse", strategy, pointset, n)
    assert c.axis_sampling == m.sampling == cfg.axis_sampling == "importance"
    assert (c.measured_rmse, c.measured_low, c.measured_high) == pytest.approx(
        (m.interval.rmse, m.interval.low, m.interval.high), rel=1e-12)
    assert (c.axes, c.target_met, c.interval_method) == (m.axes, m.target_met, m.interval.method)
    a = agreement_with_interval(c.predicted_rmse, m.interval, band=cfg.band)
    assert c.ratio == pytest.approx(c.predicted_rmse / m.interval.rmse, rel=1e-12)
    assert (c.within_band, c.inside_interval, c.agrees) == (a.within_band, a.inside, a.either)


# ----------------------------------------------------------------------------- summaries

def _by_hand_worst(cs):
    return max(cs, key=lambda c: abs(math.log(c.ratio)))


def test_rule_and_lobe_summaries_by_hand(result):
    for r in result.rules:
        cs = [c for c in result.cells if (c.lobe, c.strategy, c.pointset) == (r.lobe, r.strategy, r.pointset)]
        assert r.cells == len(cs) == 2
        assert r.median_ratio == pytest.approx(statistics.median(c.ratio for c in cs))
        assert r.fraction_agree == sum(1 for c in cs if c.agrees) / len(cs)
        w = _by_hand_worst(cs)
        assert (r.worst_ratio, r.worst_n) == (w.ratio, w.n)
    (lobe,) = result.lobes
    assert lobe.median_ratio == pytest.approx(statistics.median(c.ratio for c in result.cells))
    w = _by_hand_worst(result.cells)
    assert (lobe.worst_ratio, lobe.worst_rule, lobe.worst_n) == (w.ratio, f"{w.strategy}/{w.pointset}", w.n)
    for e in lobe.lowest_by_n:
        at_n = sorted((c for c in result.cells if c.n == e["n"]), key=lambda c: c.measured_rmse)
        assert e["lowest"]["strategy"] == at_n[0].strategy
        assert e["lowest"]["measured_rmse"] == at_n[0].measured_rmse
        other = next(c for c in at_n if c.strategy != at_n[0].strategy)
        assert (e["runner_up"]["strategy"], e["runner_up"]["pointset"]) == (other.strategy, other.pointset)


def _cell(strategy="map", pointset="sobol", n=16, pred=1.0, meas=1.0, lo=None, hi=None,
          lobe="diffuse", met=True, band=0.2):
    lo = 0.9 * meas if lo is None else lo
    hi = 1.1 * meas if hi is None else hi
    ratio = pred / meas
    inside, within = lo <= pred <= hi, abs(ratio - 1) <= band
    return VR.RendererCell(lobe, strategy, pointset, n, "warped-spectrum", pred, meas, lo, hi,
                           (hi - lo) / (2 * meas), 250 if met else 4000, met, "bca", ratio,
                           within, inside, inside or within, {})


def test_summaries_of_constructed_cells():
    cells = [_cell(n=16, pred=0.5), _cell(n=64, pred=1.1), _cell(n=256, pred=1.3)]
    (r,) = VR.summarize_rules(cells)
    assert r.median_ratio == pytest.approx(1.1) and r.worst_ratio == pytest.approx(0.5)
    assert r.worst_n == 16 and r.fraction_agree == pytest.approx(1 / 3)   # only 1.1 agrees
    # ratio 0 is the worst of all; a cell without a ratio is skipped
    zero = _cell(n=1024, pred=0.0)
    none = _cell(n=2048)
    none.ratio = None
    assert VR.worst_ratio([*cells, zero, none]) is zero


def test_config_checks():
    with pytest.raises(ParameterError, match="strategy"):
        VR.RendererValidationConfig(strategies=("nope",))
    with pytest.raises(ParameterError, match="point set"):
        VR.RendererValidationConfig(pointsets=("grid",))
    with pytest.raises(ParameterError):
        VR.RendererValidationConfig(n_values=(1, 16))
    with pytest.raises(ParameterError):
        VR.RendererValidationConfig(axes_start=500, max_axes=100)
    full, quick = VR.RendererValidationConfig(), VR.renderer_quick_config()
    assert (full.strategies, full.pointsets, full.n_values) == (
        ("brdf", "map", "mis", "split"), ("random", "sobol", "sf"), (16, 64, 256, 1024))
    assert (full.grid, full.spectrum_axes, full.axes_start, full.max_axes) == (512, 256, 500, 16000)
    assert (quick.n_values, quick.grid, quick.spectrum_axes, quick.axes_start, quick.max_axes) == (
        (16, 256), 256, 32, 250, 4000)


# ----------------------------------------------------------------------------- JSON and resume

def test_json_round_trip(result):
    text = json.dumps(to_jsonable(result.to_json()))
    back = VR.RendererValidation.from_json(json.loads(text))
    assert back == result
    assert back.to_json() == json.loads(text)


def test_resume_reads_stored_cells(sun_map, cfg, tmp_path, monkeypatch):
    first = VR.run_renderer_validation(sun_map, cfg, out=tmp_path)
    assert len(list((tmp_path / "cells").glob("renderer_*.json"))) == len(first.cells)

    def boom(*a, **k):
        raise RuntimeError("recomputed")
    for name in ("measure_rule", "renderer_model", "predict"):
        monkeypatch.setattr(VR, name, boom)
    seen = []
    again = VR.run_renderer_validation(sun_map, cfg, out=tmp_path,
                                       on_cell=lambda k, resumed: seen.append(resumed))
    assert again.resumed_cells == len(first.cells) and seen == [True] * len(first.cells)
    assert [c.measured_rmse for c in again.cells] == [c.measured_rmse for c in first.cells]
    assert [c.predicted_rmse for c in again.cells] == [c.predicted_rmse for c in first.cells]
    assert all(c.resumed for c in again.cells) and not any(c.resumed for c in first.cells)
    # other measurement settings: the stored cells are not this run's, so they are recomputed
    with pytest.raises(RuntimeError, match="recomputed"):
        VR.run_renderer_validation(sun_map, VR.renderer_quick_config(**{**SMALL, "max_axes": 240}),
                                   out=tmp_path)


# ----------------------------------------------------------------------------- report

def _section(cells, sources=(), strategies=None, cfg_over=None):
    cfg = VR.renderer_quick_config(**{**SMALL, **(cfg_over or {})})
    d = cfg.to_dict()
    if strategies:
        d["strategies"] = list(strategies)
    return VR.RendererValidation("m", [32, 16], "linear", d, list(sources), list(cells),
                                 VR.summarize_rules(cells), VR.summarize_lobes(cells),
                                 {"spectra": 1.0, "measure": 2.0, "total": 3.0}).to_json()


#: every renderer condition, each tested where it holds and where it fails below
TESTED_BOTH_WAYS = {"renderer_ratios_within", "renderer_lobe_agrees", "renderer_lowest_resolved",
                    "renderer_sources", "renderer_split_helps", "renderer_targets_met"}


def _says(rd, *statements):
    """The sentences of the renderer verdicts of ``rd`` that are one of ``statements``."""
    return [RT.sentence(v) for v in RV.renderer_verdicts(rd) if v.statement in statements]


def _say(rd, statement):
    """The sentence of ``statement`` on ``rd`` ("" when there is none)."""
    return " ".join(_says(rd, statement))


def test_every_renderer_condition_is_tested():
    assert set(RC.RENDERER_CONDITIONS) == TESTED_BOTH_WAYS
    assert not TESTED_BOTH_WAYS & set(RC.CONDITIONS)


def test_predicates_both_ways():
    assert RC.ratios_in_range([0.95, 1.05]) and not RC.ratios_in_range([0.95, 1.2])
    assert not RC.ratios_in_range([]) and not RC.ratios_in_range([None])
    assert RC.interval_below(1.0, 1.5) and not RC.interval_below(1.6, 1.5)
    assert RC.any_found(1) and not RC.any_found(0)
    assert RC.all_below([(1, 2)]) and not RC.all_below([(1, 2), (3, 2)])
    assert not RC.all_below([])


def test_ratio_statement_both_ways():
    ok = _section([_cell(pred=1.05), _cell("split", pred=0.95)])
    assert _say(ok, "renderer_ratios_within") == ("For every rule (2) the median predicted/measured ratio "
                                       "is within 0.9–1.1 (0.95–1.05).")
    bad = _section([_cell(pred=1.3), _cell("split", pred=0.95)])
    s = _say(bad, "renderer_ratios_within")
    assert s.startswith("The median predicted/measured ratio is outside 0.9–1.1 for 1 of the 2")
    assert "diffuse map/sobol (1.30)" in s and "split" not in s


def test_lobe_statement_both_ways():
    (ok,) = _says(_section([_cell(pred=1.05), _cell(n=32, pred=0.9)]), "renderer_lobe_agrees")
    assert ok.startswith("diffuse: all 2 cells agree") and "worst 0.90 (map/sobol, N = 32)" in ok
    (bad,) = _says(_section([_cell(pred=1.05), _cell(n=32, pred=0.5)]), "renderer_lobe_agrees")
    assert bad.startswith("diffuse: 1 of 2 cells agree") and "worst 0.50" in bad


def test_lowest_statement_both_ways():
    resolved = _section([_cell("map", meas=1.0, lo=0.9, hi=1.1), _cell("split", meas=0.5, lo=0.45, hi=0.55)])
    (s,) = _says(resolved, "renderer_lowest_resolved")
    assert "`split` (sobol) has the lowest measured RMSE, 0.5 [0.45, 0.55], its interval below" in s
    assert "`map` (sobol, 1 [0.9, 1.1])" in s
    overlap = _section([_cell("map", meas=1.0, lo=0.7, hi=1.3), _cell("split", meas=0.8, lo=0.6, hi=1.0)])
    (s,) = _says(overlap, "renderer_lowest_resolved")
    assert "`split` (sobol) has the lowest" in s and "overlaps" in s and "not resolved" in s
    (s,) = _says(_section([_cell("map")]), "renderer_only_strategy")
    assert s.startswith("diffuse, N = 16: only `map` was measured")


def test_source_statement_both_ways():
    src = {"direction": [0.0, 1.0, 0.0], "solid_angle": 0.19, "pixels": 24, "share": 0.171}
    s = _say(_section([_cell()], sources=[src]), "renderer_sources")
    assert s.startswith("Split off by `split` (1 bright source(s)") and "17.1% of the map's power" in s
    assert "(+0.000, +1.000, +0.000)" in s and "0.19 sr" in s
    assert _say(_section([_cell()]), "renderer_sources").startswith("No bright source was found")


def test_split_statement_both_ways():
    helps = _section([_cell("mis", meas=1.0), _cell("split", meas=0.5)])
    assert _say(helps, "renderer_split_helps").startswith("`split` measures below `mis` in all 1 cells")
    hurts = _section([_cell("mis", meas=1.0), _cell("split", meas=1.5),
                      _cell("mis", n=32, meas=1.0), _cell("split", n=32, meas=0.5)])
    s = _say(hurts, "renderer_split_helps")
    assert s.startswith("`split` does not measure below `mis` in 1 of the 2 cells")
    assert "diffuse sobol N = 16 (1.5 vs 1)" in s
    assert _say(_section([_cell("split")]), "renderer_split_helps") == ""      # nothing to compare


def test_target_statement_both_ways():
    assert _say(_section([_cell(), _cell(n=32)]), "renderer_targets_met") == (
        "Every measured interval reached ±10% (250–250 axes).")
    s = _say(_section([_cell(), _cell(n=32, met=False)]), "renderer_targets_met")
    assert s.startswith("1 of 2 cells stopped at max_axes = 120 before") and "map/sobol N = 32" in s


def test_measured_axes_sentence_both_ways():
    imp = R._measured_axes({"axis_sampling": "importance"})
    assert "importance-sampled" in imp and "weighted by u/q" in imp
    for c in ({"axis_sampling": "uniform"}, {}):           # a run from before the option
        assert R._measured_axes(c) == "the RMSE over uniform random axes"


def test_report_has_the_section_only_with_renderer(result):
    rd = result.to_json()
    lines = R.renderer_section(rd, RV.renderer_verdicts(rd))
    assert lines[0] == "## Renderer rules (`--renderer`)"
    assert sum(1 for x in lines if x.startswith("| diffuse ")) == len(result.rules)
    assert R.renderer_section(None, RV.renderer_verdicts(None)) == []


# ----------------------------------------------------------------------------- plot

def _png_shape(path):
    import matplotlib.image
    with open(path, "rb") as fh:
        assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
    return matplotlib.image.imread(str(path)).shape


def test_plot_renderer_writes_a_png(tmp_path):
    from envfit.plots._renderer import plot_renderer
    cells = [_cell(s, p, n, pred=1.0 / n, meas=1.1 / n, lobe=lb).to_json()
             for lb in ("diffuse", "glossy") for s in ("map", "mis") for p in ("sobol", "random")
             for n in (16, 64)]
    cells[0]["predicted_rmse"] = None                          # a missing value is left out
    path = plot_renderer({"map": "m", "map_size": [32, 16], "scale": "linear",
                          "config": {"shininess": 30.0}, "cells": cells}, tmp_path / "r.png")
    h, w, _ = _png_shape(path)
    assert w > h > 100                                         # two panels side by side


# ----------------------------------------------------------------------------- CLI

def _cli(tmp_path, *argv):
    return subprocess.run([sys.executable, "-m", "envfit.cli", "validate", *argv], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("argv,message", [
    (["--renderer", "--strategies", "map,nope"], "strategy"),
    (["--renderer", "--renderer-pointsets", "grid"], "point set"),
    (["--renderer", "--renderer-n", "1,16"], "N"),
    (["--strategies", "map"], "--renderer"),
    (["--renderer-axes", "uniform"], "--renderer"),
    (["--renderer", "--renderer-axes", "stratified"], "axis sampling"),
])
def test_cli_bad_renderer_options_one_line_exit_2(tmp_path, argv, message):
    p = _cli(tmp_path, *argv, "--quiet")
    assert p.returncode == 2
    lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("envfit validate: error:") and message in lines[0]
    assert "Traceback" not in p.stderr


def test_cli_renderer_n_must_be_whole_numbers(tmp_path):
    p = _cli(tmp_path, "--renderer", "--renderer-n", "16.5", "--quiet")
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr.strip().splitlines()[-1].startswith("envfit validate: error:")


def test_cli_end_to_end_and_resume(tmp_path, sun_map):
    path = save_envmap(tmp_path / "sun.exr", sun_map.data.astype(np.float32))
    argv = [str(path), "--s", "1.5", "--brdf", "diffuse", "--n", "16", "--axes", "40",
            "--pointsets", "sf", "--weights", "equal", "--no-truncation", "--fit-n", "100",
            "--scale", "linear", "--quick", "--renderer", "--strategies", "map",
            "--renderer-pointsets", "sobol", "--renderer-n", "16", "--out", "out",
            "--json", "res.json"]
    p = _cli(tmp_path, *argv)
    assert p.returncode == 0, p.stderr
    res = json.loads((tmp_path / "res.json").read_text())
    (cell,) = res["renderer"]["cells"]
    # the same cell measured directly on the map as validate reads it (linear = raw values)
    env = load_envmap(path)
    scaled = env.with_data(np.asarray(env.data, dtype=np.float64))
    m = measure_rule(RendererSetup.of(scaled), RendererRule("map", "sobol", 16), "diffuse", 30.0,
                     seed=0, axes_start=250, max_axes=4000)
    assert cell["measured_rmse"] == pytest.approx(m.interval.rmse, rel=1e-12)
    assert "diffuse map/sobol" in p.stdout and "per rule: median ratio" in p.stdout
    out = tmp_path / "out"
    assert (out / "cells" / "renderer_diffuse_map_sobol_16.json").exists()
    assert "## Renderer rules" in (out / "report.md").read_text()
    assert "![renderer](renderer.png)" in (out / "report.md").read_text()
    assert len(_png_shape(out / "renderer.png")) == 3
    again = _cli(tmp_path, *argv)
    assert again.returncode == 0, again.stderr
    res2 = json.loads((tmp_path / "res.json").read_text())
    assert res2["renderer"]["resumed_cells"] == 1 and "resumed" in again.stdout
    assert res2["renderer"]["cells"][0]["measured_rmse"] == cell["measured_rmse"]
