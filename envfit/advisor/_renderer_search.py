r"""The renderer advice's search: the smallest spp a renderer's sampler can run whose predicted
RMSE meets the target, per strategy, with every prediction cached.

Predictions: :class:`~envfit.advisor._renderer_model.CachedRendererModel` (the model, through
the predictor registry, cached) — one *pass* over the model's K normals serves any number of
(strategy, spp) cells, and a pass costs the same at every spp (the integrand is tabulated at
the model's finest level), so the search asks for many cells per pass and as few passes as it
can.

Search (:func:`search_spp`), per strategy over the spp the sampler can run
(:meth:`~envfit.renderers.SamplerSpec.runnable`, the sampler's own rounding, e.g.
``ldsampler`` 4, 16, 64, …):

1. pass 1: the *coarse* spp — the runnable spp at every power of two (:func:`coarse_spp`),
   the largest spp searched and the ``--spp`` list; the answer lies between the last coarse
   spp that misses the target and the first that meets it (the search assumes, as the
   advisor's other searches do, that the prediction falls with spp between coarse points);
   none meets it: "not reached up to the largest spp searched". The advice asks for every
   coarse spp in this one pass: the nets sampled above the grid (a digitally shifted net,
   the Owen-scrambled nets above the grid's 2^(L−1) spp) read every N from one table at the
   largest (:mod:`envfit.predict.renderer._sampled_nets`), which costs
   about as much as the grid's own tables, while a second pass would recompute those.
   With ``first_cap``, pass 1 takes the coarse spp up to it only, and the coarse spp above
   it follow in one more pass only for the strategies that none of those meets (cheaper
   when most targets are met on the grid);
2. later passes: up to :data:`CANDIDATES` runnable spp spread over each open bracket (for
   the ``independent`` sampler also the spp the model's exact 1/N law puts at the target,
   :math:`\lceil N_c\,\mathrm{MSE}(N_c)/t^2\rceil` and the runnable spp around it), until no
   runnable spp is left between the last miss and the first meet.

The answer is a *crossing*: prediction(spp) ≤ target < prediction(the runnable spp below it).

**Around a known answer** (``around``: a sized model's final search after its pilot's,
:mod:`~envfit.advisor._renderer_sizing`): pass 1 takes, instead of every coarse spp, the
earlier answer, the runnable spp below it, the coarse spp its span needs
(:func:`~envfit.advisor._renderer_sizing.spp_span`: the powers of two around it), the two
coarse spp past either where the earlier prediction there lies within two of its model errors
of the target, and the ``--spp`` list; then, while no spp meets, the next two coarse spp above
the largest asked, and while none below the first that meets misses, the next two below it,
a pass each, until the predictions bracket a crossing; then pass 2 as above (and the span's
powers of two at the answer, where it moved). Where the prediction falls with spp (as the
search assumes) the answer, and every prediction at it and its span, is the full search's;
the spp far from it are not predicted: the final model's work is spent where its error was
sized, at the answer.
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

import numpy as np

from envfit.advisor._cache import AdviseCache
from envfit.advisor._model import map_key
from envfit.advisor._renderer_model import CachedRendererModel
from envfit.advisor._renderer_options import NET_RANDOMISATIONS
from envfit.defaults import SWITCH_FACTOR
from envfit.predict.renderer.randomisation import STRATA_SAMPLED

__all__ = ["StrategyAnswer", "answer_error", "next_runnable", "search_model",
           "switched_strategy", "coarse_spp", "search_spp", "CANDIDATES"]

#: runnable spp evaluated per open bracket and pass
CANDIDATES = 16


def next_runnable(spec, spp: int, every: bool = False) -> int:
    """The smallest spp above ``spp`` the sampler runs (a power of two for the model's nets;
    a sampler may round a request down: its :meth:`~envfit.renderers.SamplerSpec.spp`).

    >>> from types import SimpleNamespace as S
    >>> net = S(randomisation="owen", spp=lambda n: 1 << (n.bit_length() - 1))  # rounds down
    >>> four = S(randomisation="digital_shift", spp=lambda n: next(4 ** k for k in range(32)
    ...                                                          if 4 ** k >= n))  # rounds up
    >>> next_runnable(net, 32), next_runnable(four, 256)
    (64, 1024)
    """
    net = spec.randomisation in NET_RANDOMISATIONS and not every
    n = 1 << int(spp).bit_length() if net else int(spp) + 1
    while spec.spp(n) <= spp:
        n *= 2
    return spec.spp(n)


def coarse_spp(runnable) -> list[int]:
    """The runnable spp nearest above each power of two, and the largest (``runnable``
    ascending, a list or a range: found by bisection, nothing of its size is built).

    >>> coarse_spp([1, 4, 9, 16, 25, 36, 49, 64])
    [1, 4, 9, 16, 36, 64]
    >>> len(coarse_spp(range(1, 10 ** 12 + 1)))
    41
    """
    out, p = set(), 1
    while p <= runnable[-1]:
        out.add(int(runnable[bisect.bisect_left(runnable, p)]))
        p *= 2
    out.add(int(runnable[-1]))
    return sorted(out)


@dataclass
class StrategyAnswer:
    """One strategy's answer: ``spp`` the smallest runnable spp meeting the target (None when
    none up to ``searched_max`` does), ``predicted_rmse`` there (at ``searched_max`` when not
    reached), ``below`` / ``below_rmse`` the runnable spp under it and its prediction (the
    crossing's other side; None when ``spp`` is the smallest runnable)."""

    strategy: str
    spp: int | None
    predicted_rmse: float
    searched_max: int
    below: int | None = None
    below_rmse: float | None = None
    evaluated: list = field(default_factory=list)

    @property
    def reached(self) -> bool:
        return self.spp is not None


def _bracket(cm: CachedRendererModel, strategy: str, runnable: list[int], target: float):
    """(last evaluated runnable spp that misses below the first that meets, the first that
    meets) — None for the latter when none evaluated meets."""
    known = [n for n in cm.asked_spp(strategy) if n in runnable]
    meet = next((n for n in known if cm.rmse(strategy, n) <= target), None)
    if meet is None:
        return None, None
    below = [n for n in known if n < meet]
    return (below[-1] if below else None), meet


def _candidates(cm, strategy, runnable, target, lo, hi, independent: bool) -> list[int]:
    """Runnable spp strictly between lo and hi to evaluate next (module docstring)."""
    i0 = 0 if lo is None else runnable.index(lo) + 1
    inner = runnable[i0:runnable.index(hi)]
    if not inner:
        return []
    pick = {inner[int(round(k))] for k in np.linspace(0, len(inner) - 1,
                                                       min(CANDIDATES, len(inner)))}
    if independent:
        guess = math.ceil(hi * cm.rmse(strategy, hi) ** 2 / target ** 2)
        j = bisect.bisect_left(inner, guess)
        pick.update(inner[max(0, j - 1):j + 2])
    return sorted(pick)


def _span_spp(spp: int, coarse: list[int], cap: int) -> set[int]:
    """The coarse spp around an answer ``spp`` that its span reads (the powers of two p/2, p,
    2p, p ≤ spp < 2p: :func:`~envfit.advisor._renderer_sizing.spp_span`) and that a full
    search asks: those at most ``cap`` (``first_cap``), or all where the answer lies above
    it."""
    p, have = 1 << (int(spp).bit_length() - 1), set(coarse)
    return {x for x in (p // 2, p, 2 * p) if x in have and (x <= cap or spp > cap)}


def _start_around(a: StrategyAnswer, error: float, target: float, coarse: list[int],
                  cap: int, steps: int = 2) -> set[int]:
    """The spp a search around the earlier answer ``a`` (relative model error ``error`` there)
    predicts first: the answer, the runnable spp below it, the coarse spp of its span
    (:func:`_span_spp`), and where the earlier prediction lies within two of its errors of
    ``target``, the ``steps`` coarse spp past it on that side (the crossing may have moved
    there; with two, the second is the power of two an spp between the first and it is
    predicted from, so that one pass finds a crossing that moved one coarse step, not two
    passes; one where each spp costs its own points, as a drawn cell's)."""
    out, near = {a.spp} | _span_spp(a.spp, coarse, cap), 2.0 * float(error)
    if a.below is not None:
        out.add(a.below)
        if a.below_rmse is not None and a.below_rmse * (1.0 - near) <= target:
            out |= set([n for n in coarse if n < a.below][-steps:])
    if a.predicted_rmse * (1.0 + near) > target:
        out |= set([n for n in coarse if n > a.spp][:steps])
    return out


def _runs(runnable, n: int) -> bool:
    """Whether ``n`` is in ``runnable`` (ascending, a list or a range: by bisection)."""
    i = bisect.bisect_left(runnable, n)
    return i < len(runnable) and runnable[i] == n


def _extend_around(cm, around: dict, runnable: list[int], target: float) -> None:
    """The passes of :func:`search_spp` for the strategies of ``around`` after their first
    (module docstring): the coarse spp next past the predictions (two a pass), until each
    strategy's bracket a crossing, or meet at the smallest runnable spp, or miss at the
    largest."""
    coarse = coarse_spp(runnable)
    while True:
        todo = []
        for s in around:
            known = [n for n in cm.asked_spp(s) if _runs(runnable, n)]
            meets = [n for n in known if cm.rmse(s, n) <= target]
            if not meets:
                todo += [(s, n) for n in coarse if n > max(known)][:2]
            elif not any(n < meets[0] for n in known) and meets[0] > runnable[0]:
                todo += [(s, n) for n in coarse if n < meets[0]][-2:]
        if not todo:
            return
        cm.predict(todo)


def search_spp(cm: CachedRendererModel, strategies, runnable: list[int], target: float,
               listed=(), *, independent: bool = False,
               first_cap: int | None = None, around: dict | None = None
               ) -> dict[str, StrategyAnswer]:
    """The smallest runnable spp per strategy whose prediction meets ``target`` (module
    docstring); ``listed`` spp are predicted in the first pass too, and the coarse spp above
    ``first_cap`` only where needed; with ``around`` (strategy → (an earlier reached
    :class:`StrategyAnswer`, its relative model error[, the coarse steps past it:
    :func:`_start_around`])), those strategies' search starts at those answers."""
    coarse = coarse_spp(runnable)
    cap = runnable[-1] if first_cap is None else first_cap
    around = {s: around[s] for s in strategies if around and s in around
              and around[s][0].reached and _runs(runnable, around[s][0].spp)}
    plain = [s for s in strategies if s not in around]
    first = {(s, n) for s in plain for n in coarse if n <= cap}
    first |= {(s, n) for s, (a, e, *steps) in around.items()
              for n in _start_around(a, e, target, coarse, cap, *steps) if _runs(runnable, n)}
    cm.predict(sorted(first | {(s, n) for s in strategies for n in listed}))
    open_ = [s for s in plain if _bracket(cm, s, runnable, target)[1] is None]
    cm.predict([(s, n) for s in open_ for n in coarse if n > cap])
    _extend_around(cm, around, runnable, target)
    while True:
        todo = []
        for s in strategies:
            lo, hi = _bracket(cm, s, runnable, target)
            if hi is not None:
                todo += [(s, n) for n in _candidates(cm, s, runnable, target, lo, hi,
                                                     independent)]
        if not todo:
            break
        cm.predict(todo)
    if around:                                  # the span's powers of two at the answer
        cm.predict([(s, n) for s in around
                    if (hi := _bracket(cm, s, runnable, target)[1]) is not None
                    for n in _span_spp(hi, coarse, cap)])
    out = {}
    for s in strategies:
        lo, hi = _bracket(cm, s, runnable, target)
        ev = cm.asked_spp(s)
        if hi is None:
            out[s] = StrategyAnswer(s, None, cm.rmse(s, runnable[-1]), runnable[-1],
                                    evaluated=ev)
        else:
            out[s] = StrategyAnswer(s, hi, cm.rmse(s, hi), runnable[-1], lo,
                                    None if lo is None else cm.rmse(s, lo), ev)
    return out


def search_model(envmap, opts, store: AdviseCache, target: float, listed,
                 technique=None, strategies=None, stage: str | None = None,
                 around: dict | None = None):
    """(the cached model, the answers per strategy) of one search over the runnable spp
    (``technique``: the map's, built by an earlier model; ``strategies``: these only;
    ``stage``: the progress bar's word for its passes, e.g. ``"pilot pass"``; ``around``:
    earlier answers to start from, :func:`search_spp`)."""
    spec = opts.record.sampler(opts.sampler)
    runnable = spec.runnable(opts.spp_cap())
    if not opts.every_spp:                             # the model's nets: N = 2^m
        runnable = [n for n in runnable if n & (n - 1) == 0]
    cm = CachedRendererModel(envmap, opts, store, map_key(envmap, "linear"), technique)
    cm.stage = stage
    drawn = opts.draws_strata and spec.randomisation in STRATA_SAMPLED  # drawn above the grid
    answers = search_spp(cm, strategies or opts.strategies, runnable, target, listed,
                         independent=spec.randomisation == "independent",
                         first_cap=opts.spp_cap(sampled=False) if drawn else None,
                         around=around)
    return cm, answers


def answer_error(cm: CachedRendererModel, a: StrategyAnswer) -> list | None:
    """The model error [total, normals', scrambles'] at a strategy's answer (or at the
    largest spp searched)."""
    return cm.model_error(a.strategy, a.spp if a.reached else a.searched_max)


def switched_strategy(answers: dict, record, default: str) -> str | None:
    """The strategy recommended instead of the renderer's ``default``, or None: the one that
    meets the target with the fewest samples traced per pixel (spp × the emitter and BSDF
    samples per spp), when the default meets it only with at least
    :data:`~envfit.defaults.SWITCH_FACTOR` times as many, or not at all."""
    def cost(a: StrategyAnswer) -> int:
        st = record.strategy(a.strategy)
        return a.spp * (st.emitter_samples + st.bsdf_samples)

    d = answers[default]
    met = [a for a in answers.values() if a.reached]
    if not met:
        return None
    best = min(met, key=cost)
    if best.strategy == d.strategy or (d.reached and cost(d) < SWITCH_FACTOR * cost(best)):
        return None
    return best.strategy
