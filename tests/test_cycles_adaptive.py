"""Cycles' adaptive sampling (envfit.renderers.cycles._adaptive) and the adaptive model
(envfit.predict.renderer._adaptive): the settings against the rules and figures Cycles' source
states, the pattern's points against the nets they must be, the model's fixed-spp error against
the exact randomisation model (a second algorithm), and the refusals."""
from __future__ import annotations

import math

import numpy as np
import pytest

from envfit.base import ParameterError
from envfit.maps import EnvMap
from envfit.predict.renderer import DiffuseModel, RendererModelOptions
from envfit.predict.renderer._adaptive import AdaptiveModel, AdaptiveOptions
from envfit.renderers import get_renderer
from envfit.renderers.cycles._adaptive import CYCLES_ADAPTIVE
from envfit.renderers.cycles._patterns import (class_a, nested_uniform_scramble,
                                               table_size, tabulated_sobol_tables)


def _need_filter(s: int, min_samples: int, step: int = 16) -> bool:
    """``AdaptiveSampling::need_filter`` (integrator/adaptive_sampling.cpp) as written there."""
    return s > min_samples and (s & (step - 1)) == step - 1


def _is_net(p: np.ndarray, m: int) -> bool:
    for a in range(m + 1):
        ix = np.floor(p[:, 0] * 2 ** a).astype(int)
        iy = np.floor(p[:, 1] * 2 ** (m - a)).astype(int)
        if len(set(zip(ix.tolist(), iy.tolist()))) != len(p):
            return False
    return True


@pytest.mark.parametrize("tau, expected", [(0.1, 32), (0.01, 64), (0.001, 128)])
def test_automatic_min_samples_are_the_sources_figures(tau, expected):
    # integrator.cpp's own comment: "Threshold 0.1 -> 32, 0.01 -> 64, 0.001 -> 128"
    assert CYCLES_ADAPTIVE.settings(tau).min_samples == expected


@pytest.mark.parametrize("tau, samples, lo", [(0.1, 4096, 0), (0.01, 1000, 0), (0.03, 256, 100),
                                              (0.0, 64, 0)])
def test_the_tests_run_where_the_naive_loop_of_align_samples_puts_them(tau, samples, lo):
    s = CYCLES_ADAPTIVE.settings(tau, samples, lo)
    naive = [i + 1 for i in range(samples) if _need_filter(i, s.min_samples)]
    if not naive or naive[-1] != samples:
        naive.append(samples)                  # the render ends at the most samples
    assert s.checks.tolist() == naive
    assert s.scaled_threshold == pytest.approx(5 * s.threshold)
    if tau == 0.0:                             # automatic: max(0.001, 1/samples)
        assert s.threshold == pytest.approx(1 / 64)


def test_class_a_is_the_popcount_rule_and_halves_every_16_samples():
    a = class_a(4096)
    byhand = [bin(i & 0xAAAAAAAA).count("1") % 2 == 1 for i in range(4096)]
    assert a.tolist() == byhand
    assert np.all(a.reshape(-1, 16).sum(axis=1) == 8)


def test_the_tables_aligned_blocks_are_nets_and_a_pixel_reads_one_block():
    tables = tabulated_sobol_tables(256, 4)
    for t in tables:
        for m in (2, 4, 6, 8):
            for k in range(0, 256, 2 ** m):
                assert _is_net(t[k:k + 2 ** m].astype(np.float64), m)
    for seed in (1, 77, 123456789):
        idx = nested_uniform_scramble(np.arange(64, dtype=np.uint32), seed) & np.uint32(255)
        assert len(set((idx >> 6).tolist())) == 1 and sorted((idx & 63).tolist()) == list(range(64))
    assert (table_size(4096), table_size(100), table_size(4097), table_size(20000)) == \
        (4096, 256, 8192, 8192)
    ue, ub = CYCLES_ADAPTIVE.points("tabulated_sobol", 256, 3, np.random.default_rng(0))
    assert all(_is_net(p[:64], 6) and _is_net(p, 8) for p in (*ue, *ub))
    assert not np.array_equal(ue, ub)


def test_the_error_estimate_is_the_kernels_formula():
    total = np.array([[3.0, 2.0, 1.0], [300.0, 200.0, 100.0]])
    half = np.array([[2.0, 2.0, 2.0], [200.0, 200.0, 200.0]])
    e = CYCLES_ADAPTIVE.error(total, half, 10)
    # |I−A| summed = 2 → 0.2 per sample; intensity 0.6 (< 1: its square root) and 60 (linear)
    assert e[0] == pytest.approx(0.2 / (1e-4 + math.sqrt(0.6)))
    assert e[1] == pytest.approx(20.0 / (1e-4 + 60.0))


def _sunny(h: int = 16) -> EnvMap:
    th = (np.arange(h) + 0.5) / h * np.pi
    ph = (np.arange(2 * h) + 0.5) / (2 * h) * 2 * np.pi
    data = 0.3 + 0.2 * np.cos(th)[:, None, None] * np.sin(ph)[None, :, None] * np.ones(3)
    data[h // 3, h // 2] = [60.0, 50.0, 40.0]
    return EnvMap(data.astype(np.float32), up="y")


@pytest.mark.parametrize("sampler", ["tabulated_sobol", "blue_noise"])
def test_the_draws_at_a_fixed_spp_agree_with_the_fixed_spp_model(sampler):
    """Tabulated Sobol against the exact Owen model; blue noise against the fixed-spp model's
    own drawn runs (a run of length 256's first 2^m samples is an aligned 2^m-run)."""
    env, cyc = _sunny(), get_renderer("cycles")
    m = AdaptiveModel(env, cyc, samples=256, sampler=sampler,
                      options=AdaptiveOptions(normals=8, pool=64, realizations=100, level=7))
    exact = DiffuseModel(env, cyc, options=RendererModelOptions(normals=8, pool=64,
                                                                max_level=7))
    assert np.allclose(m.normals, exact.normals)      # one proposal: the same normals
    p = m.predict(0.01)
    for n in (16, 64, 256):
        ref = exact.predict("mis", sampler, n).rmse
        assert p.fixed[n] == pytest.approx(ref, rel=0.15), n


def test_with_the_pixel_footprint_the_draws_agree_with_the_exact_footprint_model():
    env, cyc = _sunny(), get_renderer("cycles")
    m = AdaptiveModel(env, cyc, samples=256, sphere_pixels=8,
                      options=AdaptiveOptions(normals=8, pool=64, realizations=100, level=7))
    exact = DiffuseModel(env, cyc, options=RendererModelOptions(normals=8, pool=64, max_level=7,
                                                                sphere_pixels=8))
    p = m.predict(0.01)
    point = AdaptiveModel(env, cyc, samples=256, options=m.options).predict(0.01)
    for n in (64, 256):
        assert p.fixed[n] == pytest.approx(exact.predict("mis", "tabulated_sobol", n).rmse,
                                           rel=0.15), n
    assert p.fixed[256] > point.fixed[256]           # an 8-pixel sphere: the footprint adds


def test_a_lower_threshold_spends_more_and_leaves_less_error():
    m = AdaptiveModel(_sunny(), get_renderer("cycles"), samples=1024,
                      options=AdaptiveOptions(normals=8, pool=64, realizations=36, level=6))
    hi, lo = m.predict(0.1), m.predict(0.005)
    assert lo.mean_spp > hi.mean_spp and lo.predicted_rmse < hi.predicted_rmse
    assert hi.spp_percentiles[5] >= CYCLES_ADAPTIVE.settings(0.1, 1024).checks[0]
    assert lo.fixed[1024] <= lo.predicted_rmse <= hi.fixed[16] * 2


def test_the_advised_threshold_meets_the_target_and_a_larger_one_does_not():
    m = AdaptiveModel(_sunny(), get_renderer("cycles"), samples=1024,
                      options=AdaptiveOptions(normals=8, pool=64, realizations=36, level=6))
    target = m.predict(0.02).predicted_rmse
    tau, p = m.threshold_for(target)
    assert p.predicted_rmse <= target and tau >= 0.015
    assert m.predict(tau * 1.6).predicted_rmse > target
    assert m.threshold_for(1e-9) == (None, None)


def test_refusals_are_one_line():
    env = _sunny(8)
    with pytest.raises(ParameterError, match="no adaptive sampling"):
        AdaptiveModel(env, get_renderer("mitsuba3"))
    with pytest.raises(ParameterError, match="tabulated_sobol and blue_noise only"):
        AdaptiveModel(env, get_renderer("cycles"), sampler="sobol_burley")
    with pytest.raises(ParameterError, match="threshold"):
        CYCLES_ADAPTIVE.settings(-1.0)
    with pytest.raises(ParameterError, match="samples"):
        CYCLES_ADAPTIVE.settings(0.01, samples=0)


def test_sample_counts_are_read_back_from_the_passes_scale():
    from envfit.renderers.cycles._render import _sample_counts
    counts = np.array([[48, 48, 64], [96, 944, 48]], dtype=float)
    assert np.array_equal(_sample_counts(counts / 944.0, 48), counts)
    with pytest.raises(RuntimeError):
        _sample_counts(np.array([[0.05, 0.07, 1.0]]), 48)


# ------------------------------------------------- envfit advise --adaptive-threshold
def _advise(capsys, tmp_path, *args):
    import json

    from envfit.cli import main
    from envfit.maps import save_envmap
    path = tmp_path / "sunny.exr"
    if not path.exists():
        save_envmap(path, _sunny())
    out = tmp_path / "a.json"
    rc = main(["advise", str(path), "--renderer", "cycles", "--renderer-normals", "6",
               "--renderer-level", "5", "--cache-dir", str(tmp_path / "cache"),
               "--json", str(out), *map(str, args)])
    cap = capsys.readouterr()
    return rc, cap.out.splitlines(), cap.err.strip(), (json.loads(out.read_text())
                                                       if rc == 0 else None)


def test_advise_writes_the_adaptive_contract_and_says_its_numbers(capsys, tmp_path):
    rc, lines, _, d = _advise(capsys, tmp_path, "--adaptive-threshold", "0.02",
                              "--adaptive-samples", "512")
    assert rc == 0
    a = d["renderer"]["adaptive"]
    assert a["threshold"] == 0.02 and a["samples"] == 512
    assert 0 < a["predicted_rmse"] and CYCLES_ADAPTIVE.settings(0.02, 512).checks[0] <= \
        a["mean_spp"] <= 512
    said = next(ln for ln in lines if ln.startswith("adaptive sampling (Cycles' Noise Threshold"))
    assert f"predicted RMSE {a['predicted_rmse']:.4g}" in said
    assert f"{a['mean_spp']:.0f} samples on average" in said
    assert f"Min Samples {a['min_samples']}," in said
    adv = a["advised"]
    if adv is None:                              # then even every pixel at 512 misses
        assert a["fixed"]["512"] > a["target_rmse"]
    else:
        assert adv["predicted_rmse"] <= a["target_rmse"] == d["renderer"]["target_rmse"]
        assert any(f"meets the target RMSE {a['target_rmse']:.4g}: {adv['threshold']:.3g}" in ln
                   for ln in lines)


@pytest.mark.parametrize("args, words", [
    (("--adaptive-min-samples", "8"), "--adaptive-min-samples needs --adaptive-threshold"),
    (("--adaptive-threshold", "0.01", "--sampler", "sobol_burley"),
     "tabulated_sobol and blue_noise patterns only"),
    (("--adaptive-threshold", "-1"), "--adaptive-threshold"),
])
def test_advise_adaptive_refusals_are_one_line(capsys, tmp_path, args, words):
    rc, _, err, _ = _advise(capsys, tmp_path, *args)
    assert rc == 2 and words in err and len(err.splitlines()) == 1


def test_a_renderer_without_adaptive_sampling_is_refused_in_one_line(capsys, tmp_path):
    import json  # noqa: F401
    from envfit.cli import main
    from envfit.maps import save_envmap
    save_envmap(tmp_path / "s.exr", _sunny(8))
    rc = main(["advise", str(tmp_path / "s.exr"), "--renderer", "mitsuba3",
               "--adaptive-threshold", "0.01"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "Mitsuba 3 has no adaptive sampling modelled" in err


def test_adaptive_sampling_of_a_library_is_refused_in_one_line(capsys, tmp_path):
    from envfit.cli import main
    from envfit.maps import save_envmap
    for k in range(2):
        save_envmap(tmp_path / f"m{k}.exr", _sunny(8))
    rc = main(["advise", str(tmp_path), "--renderer", "cycles", "--adaptive-threshold", "0.01"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and err.endswith("--adaptive-threshold answers one map at a time so far")
