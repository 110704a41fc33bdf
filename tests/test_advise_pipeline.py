"""The advisor's one pipeline (issue 39): one entry point, ``envfit.advisor.advise_with``, that
dispatches on what is asked (envfit's rules or a renderer's terms), and the renderer's
predictions made through the predictor registry (``envfit.predict.PREDICTORS["renderer"]``),
not past it.

The registry test replaces the registered predictor by a closed form (RMSE = c/√spp, the
independent sampler's law) and checks that the advice's numbers are the stand-in's: a search
that called the renderer model directly would not see the stand-in, and fails here.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from envfit.advisor import (Advice, AdviseOptions, PresetAdvice, PresetAdviseOptions,
                            RendererAdvice, RendererAdviseOptions, advise_preset, advise_with)
from envfit.base import ParameterError
from envfit.maps import EnvMap
from envfit.predict import PREDICTORS
from envfit.predict._registry import (SamplerPrediction, SamplerRule, predict_many,
                                      predict_renderer)
from envfit.renderers import RENDERERS


def _renderer_with(sampler: str) -> str:
    """A renderer of the registry that has ``sampler`` (by its own name)."""
    return next(n for n, r in RENDERERS.items() if sampler in r.samplers)


@pytest.fixture(scope="module")
def env():
    return EnvMap(np.random.default_rng(0).random((8, 16, 3)) + 0.5, name="noise")


def _opts(tmp_path, **kw):
    return RendererAdviseOptions(_renderer_with("independent"), sampler="independent",
                                 normals=4, level=3, strategies=["mis", "map"],
                                 cache_dir=tmp_path, **kw)


def test_the_renderer_predictor_is_registered_and_reads_a_sampler_rule():
    assert PREDICTORS["renderer"] is predict_renderer
    assert predict_renderer.rule_type is SamplerRule
    with pytest.raises(ParameterError, match="reads a SamplerRule"):
        predict_many("renderer", None, [SamplerRule("mis", "independent", 4), object()])


def test_the_renderer_search_calls_the_registered_predictor(env, tmp_path, monkeypatch):
    """Every cell the search predicts comes from PREDICTORS["renderer"], in batches (one call
    per model pass), and the answer is the stand-in's exact crossing."""
    batches: list[list[SamplerRule]] = []
    c = 3.05

    def fake(ctx, rule):
        raise AssertionError("the search asks for its cells in batches")

    def many(ctx, rules):
        batches.append(list(rules))
        out = []
        for r in rules:
            rmse = c / math.sqrt(r.n)
            cell = ctx.renderer.predict(r.strategy, r.sampler, 1)      # its shape: a real cell
            out.append(SamplerPrediction("renderer", rmse, cell=replace(
                cell, rmse=rmse, mse=np.full(3, rmse ** 2), spp=r.n, spp_rendered=r.n)))
        return out

    fake.rule_type, fake.many = SamplerRule, many
    monkeypatch.setitem(PREDICTORS, "renderer", fake)
    target = 0.1
    adv = advise_with(env, _opts(tmp_path, target_rmse=target))
    assert isinstance(adv, RendererAdvice)
    assert batches and all(isinstance(r, SamplerRule) for b in batches for r in b)
    want = math.ceil((c / target) ** 2)                       # c/√n ≤ t ⟺ n ≥ (c/t)²
    for s in ("mis", "map"):
        a = adv.answers[s]
        assert a.spp == want and a.predicted_rmse == pytest.approx(c / math.sqrt(want))
        assert a.below == want - 1
    assert adv.cells[("mis", want)] == pytest.approx(c / math.sqrt(want))


def test_advise_with_dispatches_on_the_options(env, tmp_path):
    """The renderer's options give a RendererAdvice equal to the keyword form's (the former
    advise_preset); the rules' options give an Advice; anything else is one line."""
    a = advise_with(env, _opts(tmp_path / "a", target_relative=0.05))
    b = advise_preset(env, _opts(tmp_path / "b"), target_relative=0.05)
    assert isinstance(a, RendererAdvice) and a.lines() == b.lines()
    assert a.recommendation["predicted_rmse"] <= a.target_rmse
    rules = advise_with(env, AdviseOptions(target_relative=0.05, s=1.5, fit_n=100,
                                           pointsets=("sf",), weights=("equal",), bases=(),
                                           nmax=64, renderer=False, cache=False))
    assert isinstance(rules, Advice)
    with pytest.raises(ParameterError, match="options must be AdviseOptions or "
                                             "RendererAdviseOptions, got dict"):
        advise_with(env, {})


def test_the_former_names_are_aliases():
    assert PresetAdvice is RendererAdvice and PresetAdviseOptions is RendererAdviseOptions
    import envfit
    assert envfit.PresetAdvice is envfit.RendererAdvice is RendererAdvice


def test_run_fields_are_checked_with_the_options(tmp_path):
    with pytest.raises(ParameterError, match="must be < 1"):
        _opts(tmp_path, target_relative=1.5)
    with pytest.raises(ParameterError, match="must be < 1"):
        _opts(tmp_path).asking(target_relative=2.0)
    o = _opts(tmp_path).asking(target_rmse=0.5, snippet=True)
    assert (o.target_rmse, o.snippet, o.key()) == (0.5, True, _opts(tmp_path).key())
