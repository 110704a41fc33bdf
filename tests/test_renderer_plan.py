"""The renderer model's ranges and plan (issue 38): ``--nmin``/``--nmax`` with ``--renderer``
refused in the words used without it, the spp searched generated lazily (no set of every spp
up to ``--nmax``), and the memory/time plan of the model's stages checked before any work."""
from __future__ import annotations

import json

import pytest

from envfit.data_gen import gaussian_process_map
from envfit.maps import EnvMap, load_envmap, save_envmap
from envfit.predict.renderer._diffuse_model import DiffuseModel, RendererModelOptions
from envfit.renderers import get_renderer


@pytest.fixture(scope="module")
def gp_file(tmp_path_factory):
    env = EnvMap(gaussian_process_map(1.8, 16, seed=3, channels=3) + 2.0, name="gp16")
    path = tmp_path_factory.mktemp("maps") / "gp16.exr"
    save_envmap(path, env)
    return path


def _run(capsys, tmp_path, *args):
    from envfit.cli import main
    out = tmp_path / "a.json"
    rc = main(["advise", *map(str, args), "--cache-dir", str(tmp_path / "cache"),
               "--json", str(out)])
    cap = capsys.readouterr()
    d = json.loads(out.read_text()) if rc == 0 and out.exists() else None
    return rc, cap.out.splitlines(), cap.err.strip().splitlines(), d


# ----------------------------------------------------------------------------- --nmin, --nmax

@pytest.mark.parametrize("renderer", [[], ["--renderer", "mitsuba3"]])
def test_nmax_below_nmin_is_the_same_line_with_and_without_renderer(renderer, tmp_path,
                                                                    capsys):
    rc, _, err, _ = _run(capsys, tmp_path, tmp_path / "absent.exr", "--nmin", "1000",
                         "--nmax", "10", *renderer)
    assert rc == 2 and err == ["envfit advise: error: --nmax 10 is below --nmin 1000"]


def test_nmin_with_renderer_is_refused_unless_the_rules_use_it(tmp_path, capsys):
    rc, _, err, _ = _run(capsys, tmp_path, tmp_path / "absent.exr", "--renderer", "mitsuba3",
                         "--nmin", "10")
    assert rc == 2 and len(err) == 1 and "--nmin sizes envfit's rules (--rules)" in err[0]


def test_nmax_beyond_a_32_bit_spp_is_refused_fast(tmp_path, capsys):
    rc, _, err, _ = _run(capsys, tmp_path, tmp_path / "absent.exr", "--renderer", "mitsuba3",
                         "--nmax", "1e12")
    assert rc == 2 and len(err) == 1
    assert "--nmax) must be at most 2147483647 with --renderer" in err[0]


def test_spp_searched_are_lazy_and_the_top_of_the_range_is_searched(gp_file, tmp_path, capsys):
    from envfit.advisor._renderer_search import coarse_spp
    spec = get_renderer("mitsuba3").sampler("independent")
    r = spec.runnable(2 ** 31 - 1)
    assert isinstance(r, range) and len(r) == 2 ** 31 - 1
    assert coarse_spp(r)[:3] == [1, 2, 4] and coarse_spp(r)[-2:] == [2 ** 30, 2 ** 31 - 1]
    # end to end: a target no spp meets, searched to the top of the range in seconds
    m = DiffuseModel(load_envmap(gp_file), get_renderer("mitsuba3"),
                    options=RendererModelOptions(normals=1, max_level=7))
    top = m.predict("map", "independent", 2 ** 31 - 1).rmse
    rc, lines, _, d = _run(capsys, tmp_path, gp_file, "--renderer", "mitsuba3", "--strategies",
                           "map", "--renderer-normals", "1", "--nmax", str(2 ** 31 - 1),
                           "--target-rmse", repr(top / 2))
    assert rc == 0 and any("no spp up to 2147483647 meets" in x for x in lines)
    assert d["renderer"]["recommendation"]["predicted_rmse"] == pytest.approx(top, rel=1e-9)


# ----------------------------------------------------------------------------- limits' words

def test_memory_budget_names_the_variable_only_when_it_is_set(monkeypatch):
    from envfit.base._errors import MemoryBudgetError
    from envfit.base._resources import check_memory
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", "1")
    with pytest.raises(MemoryBudgetError) as e:
        check_memory(10 ** 6, "a test array")
    assert "only 0 B can be used (80% of ENVFIT_MEMORY_LIMIT=1)" in str(e.value)
    assert "available memory" not in str(e.value)
    monkeypatch.delenv("ENVFIT_MEMORY_LIMIT")
    with pytest.raises(MemoryBudgetError) as e:
        check_memory(10 ** 21, "a test array")
    assert "(80% of available memory)" in str(e.value) and "ENVFIT_" not in str(e.value)


def test_time_limit_says_what_was_set_and_refuses_a_limit_nothing_fits(monkeypatch):
    from envfit.base._errors import ParameterError
    from envfit.base._resources import time_limit_seconds, time_limit_words
    monkeypatch.delenv("ENVFIT_TIME_LIMIT", raising=False)
    assert time_limit_words(time_limit_seconds(900.0)) == "the 900 s limit (ENVFIT_TIME_LIMIT)"
    monkeypatch.setenv("ENVFIT_TIME_LIMIT", "2.5")
    assert time_limit_words(time_limit_seconds(900.0)) == \
        "the 2.5 s limit (ENVFIT_TIME_LIMIT=2.5)"
    monkeypatch.setenv("ENVFIT_TIME_LIMIT", "1e-9")
    with pytest.raises(ParameterError) as e:
        time_limit_seconds(900.0)
    assert str(e.value).startswith("ENVFIT_TIME_LIMIT=1e-9 is below 1 s")


def test_sh_refusal_over_a_set_time_limit_names_its_value(tmp_path, monkeypatch, capsys):
    from envfit.cli import main
    env = EnvMap(gaussian_process_map(1.8, 16, seed=3, channels=3) + 2.0, name="gp16")
    save_envmap(tmp_path / "m.exr", env)
    monkeypatch.setenv("ENVFIT_TIME_LIMIT", "1e-9")
    rc = main(["sh", str(tmp_path / "m.exr"), "--lmax", "2"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "ENVFIT_TIME_LIMIT=1e-9 is below 1 s" in err[0]
    assert "the 0 s limit" not in err[0]


# ----------------------------------------------------------------------------- the model's plan

def _opts(**kw):
    from envfit.advisor._renderer_options import RendererAdviseOptions
    return RendererAdviseOptions("mitsuba3", **kw)


def test_plan_memory_bounds_the_measured_peak(gp_file):
    """ldsampler at level 8 with a target nothing meets: every pass to the cap, its power
    above the grid sampled (the plan's worst case); the peak traced by tracemalloc (numpy's
    arrays) from the loaded map on, against the plan: at least the peak, at most 2.5x it."""
    import tracemalloc
    from envfit.advisor._budget import renderer_plan
    from envfit.advisor._renderer_advice import advise_renderer_map
    env = load_envmap(gp_file)
    o = _opts(sampler="ldsampler", level=8, normals=2)
    plan = renderer_plan(env.width * env.height, o, resident=env.data.nbytes)
    tracemalloc.start()
    try:
        adv = advise_renderer_map(env, o.asking(target_rmse=1e-9, cache=False))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert not adv.default.reached and adv.default.searched_max == 1024   # sampled to 1024
    assert peak <= plan.peak() <= 2.5 * peak, (peak, plan.lines())


def _refusal(capsys, tmp_path, monkeypatch, limit, *args):
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", limit)
    rc, _, err, _ = _run(capsys, tmp_path, *args)
    assert rc == 2 and len(err) == 1, err
    assert f"(80% of ENVFIT_MEMORY_LIMIT={limit})" in err[0]
    return err[0]


def _plan_fits(opts, limit, monkeypatch) -> bool:
    from envfit.advisor._budget import renderer_plan
    from envfit.base._resources import memory_budget_bytes
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", limit)
    return renderer_plan(32 * 16, opts, resident=32 * 16 * 12).fits(memory_budget_bytes())


def _fits(pixels, **kw) -> bool:
    from envfit.advisor._budget import renderer_plan
    return renderer_plan(pixels, _opts(**kw), resident=pixels * 12).fits()


def test_level_over_budget_names_the_largest_level_that_fits(gp_file, tmp_path, monkeypatch,
                                                             capsys):
    import re
    line = _refusal(capsys, tmp_path, monkeypatch, "1G", gp_file, "--renderer", "mitsuba3",
                    "--sampler", "ldsampler", "--renderer-level", "11")
    assert line.startswith("envfit advise: error: the renderer model at --renderer-level 11,")
    lv = int(re.search(r"--renderer-level (\d+) (fits|or)", line).group(1))
    px = 32 * 16
    assert _fits(px, sampler="ldsampler", level=lv)
    assert not _fits(px, sampler="ldsampler", level=lv + 1)


def test_normals_over_budget_names_the_most_normals_that_fit(gp_file, tmp_path, monkeypatch,
                                                             capsys):
    import re
    line = _refusal(capsys, tmp_path, monkeypatch, "300M", gp_file, "--renderer", "mitsuba3",
                    "--renderer-normals", "4096")
    k = int(re.search(r"--renderer-normals (\d+) fits", line).group(1))
    assert "the normals' proposal: 4096 normals x 4096 pilot points" in line
    assert 1024 <= k < 4096 and _fits(512, normals=k) and not _fits(512, normals=k + 1)


def test_nmax_over_budget_names_the_largest_runnable_spp_that_fits(gp_file, tmp_path,
                                                                  monkeypatch, capsys):
    import re
    line = _refusal(capsys, tmp_path, monkeypatch, "1G", gp_file, "--renderer", "mitsuba3",
                    "--sampler", "ldsampler", "--renderer-level", "9")
    n = int(re.search(r"--nmax (\d+) fits", line).group(1))
    assert "shifted points to 4096 spp" in line
    assert n in (256, 1024) and _fits(512, sampler="ldsampler", level=9, max_spp=n)
    assert not _fits(512, sampler="ldsampler", level=9, max_spp=4 * n)


def test_the_sized_default_fits_where_level_9_does_not_and_sizes_within_the_budget(
        gp_file, tmp_path, monkeypatch, capsys):
    """The sized default (level 7 pilot) runs under the 1 GB budget that refuses level 9, and
    its final model is one whose plan fits that budget (never refused after its pilot). At
    --renderer-model-error 0.03 the pilot (48 normals, 0.033) is followed by a larger model
    (96 normals). The tightest target, 0.01, takes the most normals the sizing allows (576:
    4.5 min of CPU at load 6) and is ``python bench/renderer_plan_sized_budget.py``; here the
    sizing's choice for it from the same pilot, with the budget's test, is checked to fit."""
    from dataclasses import replace

    from envfit.advisor._renderer_sizing import _fits_memory, sized_options
    monkeypatch.setenv("ENVFIT_MEMORY_LIMIT", "1G")
    rc, _, err, d = _run(capsys, tmp_path, gp_file, "--renderer", "mitsuba3", "--sampler",
                         "ldsampler", "--renderer-model-error", "0.03", "--quiet")
    assert rc == 0 and err == []
    m = d["renderer"]["model"]
    assert m["sized"] and m["level"] == 7 and m["pilot"] is not None and m["normals"] > 48
    o = _opts(sampler="ldsampler", level=7, normals=m["normals"])
    assert _plan_fits(replace(o, shifts=m["shifts"], reach=m["reach"]), "1G", monkeypatch)
    # the same pilot at a target of 0.01: the bench run's final model (576 normals, 16
    # scrambles), within the budget
    tight = _opts(sampler="ldsampler", model_error=0.01)
    f = sized_options(tight, m["pilot"]["model_se"][1:], reach=m["reach"],
                      fits=_fits_memory(load_envmap(gp_file)))
    assert (f.level, f.normals, f.shifts) == (7, 576, 16)
    assert _plan_fits(f, "1G", monkeypatch)


def test_progress_bar_over_the_normals_and_quiet_silences_it(gp_file, tmp_path, capsys):
    args = (gp_file, "--renderer", "mitsuba3", "--renderer-normals", "2",
            "--renderer-level", "5")
    rc, _, err, _ = _run(capsys, tmp_path, *args, "--no-cache")
    assert rc == 0 and "renderer model, pass 1 (planned ~" in "\n".join(err)
    rc, _, err, _ = _run(capsys, tmp_path, *args, "--no-cache", "--quiet")
    assert rc == 0 and err == []


def test_independent_sampler_answers_beyond_the_default_nmax_from_its_exact_rate(
        gp_file, tmp_path, capsys):
    """An independent sampler's RMSE is exactly sigma/sqrt(spp) (issue 40): without --nmax its
    answer is searched to the renderer's 32-bit spp, said as such, and equals the closed form
    ceil(sigma^2 / target^2) from the model's 1-spp prediction; with --nmax 65536 it is not."""
    m = DiffuseModel(load_envmap(gp_file), get_renderer("mitsuba3"),
                    options=RendererModelOptions(normals=4, max_level=7))
    sigma = m.predict("brdf", "independent", 1).rmse
    target = sigma / 1000.0                               # needs ~10^6 spp
    base = ["--renderer", "mitsuba3", "--strategies", "brdf", "--renderer-normals", "4",
            "--target-rmse", repr(target)]
    rc, lines, _, d = _run(capsys, tmp_path, gp_file, *base)
    rec = d["renderer"]["recommendation"]
    expect = int(-(-(sigma / target) ** 2 // 1))          # ceil, in exact arithmetic +- 1
    assert rc == 0 and rec["reached"] and abs(rec["spp"] - expect) <= 1
    assert d["renderer"]["max_spp"] == 2 ** 31 - 1
    assert "beyond 65536 spp from the independent sampler's exact rate" in "\n".join(lines)
    rc, lines, _, d = _run(capsys, tmp_path, gp_file, *base, "--nmax", "65536")
    assert rc == 0 and not d["renderer"]["recommendation"]["reached"]
    assert any("no spp up to 65536 meets" in x for x in lines)


def test_quiet_prints_the_answer_line_alone(gp_file, tmp_path, capsys):
    """--quiet hides the bars, tables and notes, not the answer (issue 38's hostile rerun)."""
    base = ["--renderer", "mitsuba3", "--renderer-normals", "4"]
    rc, loud, _, _ = _run(capsys, tmp_path, gp_file, *base)
    rc_q, quiet, _, d = _run(capsys, tmp_path, gp_file, *base, "--quiet")
    answer = [x for x in loud if not x.startswith("note: ")][0]
    assert rc == rc_q == 0 and quiet == [answer]
    assert f"spp = {d['renderer']['recommendation']['spp']} " in answer


def test_a_strategy_the_model_cannot_predict_is_said_left_out(gp_file, tmp_path, capsys):
    """envfit's jitter has no model of MIS's shared shift: the default answer leaves mis out
    and says so before the answer; with every strategy modelled, no such note."""
    from envfit.advisor._renderer_options import RendererAdviseOptions
    o = RendererAdviseOptions("envfit", sampler="jitter", normals=4)
    assert "mis" not in o.strategies and len(o.notes) == 1
    assert o.notes[0].startswith("strategy mis (both techniques (MIS)) is left out")
    assert RendererAdviseOptions("mitsuba3", normals=4).notes == []
    rc, lines, _, d = _run(capsys, tmp_path, gp_file, "--renderer", "envfit", "--sampler",
                           "jitter", "--renderer-normals", "4")
    assert rc == 0 and f"note: {o.notes[0]}" in lines and o.notes[0] in d["renderer"]["notes"]
    assert lines.index(f"note: {o.notes[0]}") < min(i for i, x in enumerate(lines) if "spp" in x)
