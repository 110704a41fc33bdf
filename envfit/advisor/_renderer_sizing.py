r"""The renderer model sized to its own error: a cheap pilot, then the normals and scrambles
the answer needs.

The model of a sampled net (Owen scrambling, a digital shift:
:data:`~envfit.advisor._renderer_options.SIZED_RANDOMISATIONS`) samples two things, and each
prediction carries the relative standard error of its RMSE from both
(:mod:`envfit.predict.renderer._model_error`): the normals (K, importance-sampled from a
spherical Fibonacci pool; error :math:`e_n \propto 1/\sqrt K`) and the random scrambles of the
net above the grid (Q; :math:`e_s \propto 1/\sqrt Q`). The grid level matters little once the
power above the grid is sampled — the grid is a control variate — so the sized model runs at
:data:`~envfit.advisor._renderer_options.AUTO_LEVEL` and spends its time where the error is.

1. **Pilot**: K₀ = 48 normals, Q₀ = 16 scrambles at level 7 (a pass costs ~1/14 of the
   unsized model's: level 9, Q = 256); the search runs to the answer.
2. If the answer's model error :math:`\sqrt{e_n^2 + e_s^2}` (the default strategy's, at its
   answer or at the largest spp searched) exceeds the target ``model_error`` (default 5 %),
   the cheapest (K, Q) of :data:`NORMALS` × :data:`SHIFTS` whose predicted error
   :math:`\sqrt{e_n^2 K_0/K + e_s^2 Q_0/Q}` meets it — at most :data:`BUDGET` integrand
   points a pass, the unsized model's; if none meets it within that, the one of smallest
   predicted error — and the search runs again with those (:func:`sized_options`), starting
   at the pilot's answer (:func:`~envfit.advisor._renderer_search.search_spp`'s ``around``:
   the final model predicts the spp around its answer, not every coarse spp).

Samplers without sampled nets (independent points, stratified:
:data:`~envfit.advisor._renderer_options.NORMALS_SIZED_RANDOMISATIONS`; multi-jittered and
orthogonal-array point sets where they are drawn above their exact reach) are sized in their
normals alone: the pilot's 48, then the fewest of :data:`NORMALS` whose predicted error
:math:`\sqrt{e_n^2 K_0/K + e_s^2}` meets the target (:math:`e_s` the drawn point sets' part,
which the normals do not shrink).

The answer reports the final model's error; it is an estimate (of the normals' spread and the
scrambles' spread), not a bound.
"""
from __future__ import annotations

import math
from dataclasses import replace

from envfit.advisor._budget import renderer_plan
from envfit.advisor._cache import AdviseCache
from envfit.advisor._renderer_search import (StrategyAnswer, answer_error, search_model,
                                           switched_strategy)
from envfit.base import memory_budget_bytes
from envfit.predict.renderer.randomisation import ALWAYS_DRAWN, STRATA_SAMPLED

__all__ = ["NORMALS", "SHIFTS", "BUDGET", "pass_points", "sized_options", "predicted_error",
           "sized_search", "model_dict", "model_error_lines", "miss_words", "spp_span",
           "below_words"]

#: the normals the sized model may take (the pool holds 1024)
NORMALS = (48, 96, 144, 192, 288, 384, 576)
#: the scrambles (Q) it may take
SHIFTS = (16, 64, 256)
#: the most integrand points a pass may evaluate: the unsized default's (48 normals, tables
#: of 4^10 points at level 9 and 256 × 4096 scrambled points), per technique
BUDGET = 48 * (4 ** 10 + 256 * 4096)


def pass_points(normals: int, level: int, shifts: int, reach: int) -> int:
    """Integrand points a pass evaluates per technique: per normal the fine table of
    4^(L+1) midpoints and Q·reach scrambled points.

    >>> pass_points(48, 9, 256, 4096) == BUDGET
    True
    """
    return int(normals) * (4 ** (int(level) + 1) + int(shifts) * int(reach))


def sized_options(opts, parts, reach: int | None = None, fits=None):
    """The options of the final model after a pilot whose answer's model error parts are
    ``parts`` = (normals', scrambles') relative standard errors (module docstring), its
    sampled nets to ``reach`` (None: the pilot's), or None when the pilot meets
    ``opts.model_error`` (or its error is unknown). ``fits(options) -> bool``: whether a
    model's plan fits the memory budget (None: all do); only those are taken, so that no
    final model is refused after its pilot."""
    if not parts:
        return None
    reach = opts.reach if reach is None else int(reach)
    e_n, e_s = (float(x) for x in parts)
    tol = opts.model_error
    if math.hypot(e_n, e_s) <= tol:
        return None
    k0, q0 = opts.normals, opts.shifts
    if q0 is None or reach is None:          # no sampled nets: the normals only
        return _sized_normals(opts, e_n, e_s, fits)

    def error(k, q):
        return math.hypot(e_n * math.sqrt(k0 / k), e_s * math.sqrt(q0 / q))

    sizes = [(k, q) for k in NORMALS for q in SHIFTS if k >= k0 and q >= q0
             and pass_points(k, opts.level, q, reach) <= BUDGET
             and (fits is None or fits(replace(opts, normals=k, shifts=q, reach=reach, sized=False)))]
    if not sizes:
        return None
    meets = [c for c in sizes if error(*c) <= tol]
    if meets:
        k, q = min(meets, key=lambda c: (pass_points(c[0], opts.level, c[1], reach),
                                         error(*c)))
    else:
        k, q = min(sizes, key=lambda c: error(*c))
    if (k, q) == (k0, q0):
        return None
    return replace(opts, normals=k, shifts=q, reach=reach, sized=False)


def _sized_normals(opts, e_n: float, e_s: float, fits):
    r""":func:`sized_options` of a model without sampled nets: the fewest :data:`NORMALS`
    whose predicted error :math:`\sqrt{e_n^2 K_0/K + e_s^2}` meets the target (``e_s``: the
    drawn point sets' part of a multi-jittered or orthogonal-array cell, which more normals
    do not shrink; 0 elsewhere), else the fewest whose normals' part is at most ``e_s``
    (past them the drawn sets' part dominates), else the most within the budget."""
    k0, tol = opts.normals, opts.model_error
    sizes = [k for k in NORMALS if k > k0 and pass_points(k, opts.level, 0, 0) <= BUDGET
             and (fits is None or fits(replace(opts, normals=k, sized=False)))]
    if not sizes:
        return None
    part = [(k, e_n * math.sqrt(k0 / k)) for k in sizes]
    k = next((k for k, e in part if math.hypot(e, e_s) <= tol), None)
    if k is None:
        k = next((k for k, e in part if e <= e_s), sizes[-1])
    return replace(opts, normals=k, sized=False)


def predicted_error(opts, parts, final) -> float:
    """The error :func:`sized_options` expects of ``final`` from the pilot's ``parts``.

    >>> from types import SimpleNamespace as S
    >>> round(predicted_error(S(normals=48, shifts=16), (0.06, 0.04), S(normals=192,
    ...       shifts=64)), 4)
    0.0361
    """
    e_n, e_s = parts
    shifts = 1.0 if opts.shifts is None else opts.shifts / final.shifts
    return math.hypot(e_n * math.sqrt(opts.normals / final.normals), e_s * math.sqrt(shifts))


def sized_search(envmap, opts, store: AdviseCache, target: float,
                 listed):
    """The search (:func:`~envfit.advisor._renderer_search.search_model`); for a sized model
    (``opts.auto``) the pilot's, then, where its error at the recommended strategy's answer
    (the renderer's default, or the cheaper one the pilot's answers recommend:
    :func:`~envfit.advisor._renderer_search.switched_strategy`) exceeds the target, a larger
    model's for that strategy (to :func:`_final_reach`; the other strategies keep the
    pilot's answers). Returns (the final model's options, the cached model per
    strategy, the answers, the pilot's figures or None, every cached model searched)."""
    cm, answers = search_model(envmap, opts, store, target, listed,
                               stage="pilot pass" if opts.auto else None)
    by = {s: cm for s in opts.strategies}
    first = _sized_strategy(opts, answers)
    parts = answer_error(cm, answers[first]) if opts.auto else None
    final = sized_options(opts, parts[1:] if parts else (),
                          reach=_final_reach(opts, answers[first], listed,
                                             parts[0] if parts else 0.0),
                          fits=_fits_memory(envmap))
    if final is None:
        return opts, by, answers, None, [cm]
    pilot = {"normals": opts.normals, "shifts": opts.shifts, "level": opts.level,
             "strategy": first,
             "reach": opts.reach, "model_se": parts, "answer": answers[first].spp,
             "predicted_model_se": predicted_error(opts, parts[1:], final)}
    cms, stage = [cm], f"sized ({_size_words(final, _unit(opts))}) pass"
    drawn = (opts.draws_strata                      # a drawn cell's spp costs its points
             and opts.record.sampler(opts.sampler).randomisation in STRATA_SAMPLED)
    around = {first: (answers[first], parts[0] if parts else 0.0, 1 if drawn else 2)}
    fcm, fans = search_model(envmap, final, store, target, listed, cm.technique, (first,),
                             stage, around)
    if (not fans[first].reached and final.reach is not None
            and final.reach < opts.reach):                          # moved past its reach
        cms.append(fcm)
        final = replace(final, reach=opts.reach)
        fcm, fans = search_model(envmap, final, store, target, listed, cm.technique, (first,),
                                 stage, around)
    by[first] = fcm
    return final, by, {**answers, first: fans[first]}, pilot, cms + [fcm]


def _sized_strategy(opts, answers: dict) -> str:
    """The strategy a sized model sizes: the one its answers recommend (the renderer's
    default or :func:`~envfit.advisor._renderer_search.switched_strategy`); unsized, the
    first asked."""
    if not opts.auto:
        return opts.strategies[0]
    return switched_strategy(answers, opts.record, opts.default_strategy) or opts.default_strategy


def _unit(opts) -> str:
    """What the model's normals are: ``frames`` (normal, view) for a microfacet BSDF."""
    return "frames" if opts.microfacet else "normals"


def _size_words(m, unit: str = "normals") -> str:
    """``48 normals and 16 scrambles`` (``48 normals`` without sampled nets; ``frames`` for a
    microfacet BSDF's (normal, view) frames) of options or a pilot's dict."""
    get = m.get if isinstance(m, dict) else lambda k: getattr(m, k)
    shifts = get("shifts")
    return f"{get('normals')} {unit}" + ("" if shifts is None else
                                          f" and {shifts} scrambles")


def _fits_memory(envmap):
    """Whether a model's plan on ``envmap`` fits the memory budget
    (:func:`~envfit.advisor._budget.check_renderer_plan`'s test)."""
    pixels = envmap.width * envmap.height
    resident, budget = int(getattr(envmap.data, "nbytes", 0)), memory_budget_bytes()
    return lambda o: renderer_plan(pixels, o, resident=resident).fits(budget)


def _final_reach(opts, a: StrategyAnswer, listed, error: float = 0.0) -> int | None:
    """The sampled nets' reach of the sized model's final search: the power of two at or
    above the pilot's answer moved up by two of the pilot's relative standard errors
    ``error`` on the RMSE, :math:`N(1 + 2e)^2` (the spp for an RMSE ``1 + 2e`` times larger
    at the slowest rate the samplers have, RMSE ∝ N^(-1/2)), and above every listed spp; at
    most the pilot's. A final answer beyond it is searched again at the pilot's reach
    (:func:`sized_search`).

    >>> from types import SimpleNamespace as S
    >>> a = S(reached=True, spp=1229)
    >>> _final_reach(S(reach=4096), a, [], 0.084), _final_reach(S(reach=4096), a, [], 0.2)
    (2048, 4096)
    """
    if opts.reach is None or not a.reached:
        return opts.reach
    top = max([math.ceil(a.spp * (1.0 + 2.0 * float(error)) ** 2), *listed])
    return min(opts.reach, 1 << (top - 1).bit_length())


def model_dict(opts, by: dict, answers: dict, pilot, cms) -> dict:
    """What the model was and what the searches ``cms`` cost (:attr:`RendererAdvice.model`)."""
    m = opts.model_options()
    rand = opts.record.sampler(opts.sampler).randomisation
    drawn = opts.draws_strata and rand in STRATA_SAMPLED
    out = {"normals": m.normals, "unit": _unit(opts), "level": opts.level, "shifts": m.shifts,
           "draws_word": ("drawn runs" if rand in ALWAYS_DRAWN else "drawn point sets")
           if drawn else "scrambles",
           "reach": m.reach,
           "model_error_target": opts.model_error,
           "model_se": {s: answer_error(by[s], a) for s, a in answers.items()},
           "below_se": {s: e[0] for s, a in answers.items() if a.reached and a.below
                        and (e := by[s].model_error(s, a.below))},
           "spp_span": {s: span for s, a in answers.items()
                        if (span := spp_span(by[s], a, answer_error(by[s], a)))},
           "pilot": pilot, "sized": opts.auto or pilot is not None,
           "sized_strategy": pilot["strategy"] if pilot else _sized_strategy(opts, answers),
           "passes": sum(c.passes for c in cms),
           "cells_computed": sum(c.cells_computed for c in cms),
           "cells_cached": sum(c.cells_cached for c in cms),
           "seconds_model": sum(c.seconds for c in cms)}
    return out


def model_error_lines(m: dict, a) -> list[str]:
    """The model's own error at the answer ``a`` (a
    :class:`~envfit.advisor._renderer_search.StrategyAnswer`) from the model dict ``m``
    (:func:`model_dict`), and how the sized model got there."""
    e = m.get("model_se", {}).get(a.strategy)
    if not e:
        return []
    where = f"{a.spp} spp" if a.reached else f"{a.searched_max} spp"
    unit = m.get("unit", "normals")
    parts = f"±{100 * e[1]:.1f} % from the {unit}" + (
        f", ±{100 * e[2]:.1f} % from the {m.get('draws_word', 'scrambles')}" if e[2] > 0
        else "")
    line = (f"model error at {where}: ±{100 * e[0]:.1f} % of the predicted RMSE (one "
            f"standard error: {parts})")
    p = m.get("pilot")
    if m.get("sized"):
        target = m["model_error_target"]
        if p is None:
            line += f"; sized to ±{100 * target:g} %: " + (
                "the pilot meets it" if e[0] <= target else
                "no larger model fits the memory budget")
        else:
            line += (f"; sized to ±{100 * target:g} % after a pilot of {_size_words(p, unit)} "
                     f"(±{100 * p['model_se'][0]:.1f} %)")
            if e[0] > target:
                line += (f"; the pilot's estimate for this model was "
                         f"±{100 * p['predicted_model_se']:.1f} %")
            if p["predicted_model_se"] > target and m["draws_word"] == "drawn point sets":
                line += _drawn_words(m, p, unit)
            elif p["predicted_model_se"] > target:
                line += (f" (the model of least error within the unsized model's cost "
                         f"{BUDGET // 10 ** 6} M points a pass)")
    return [line]


def _drawn_words(m: dict, p: dict, unit: str) -> str:
    """Why a model sized in its normals alone (:func:`_sized_normals`) misses the target: the
    drawn point sets' part, which more normals do not shrink."""
    e_n, e_s = p["model_se"][1], p["model_se"][2]
    own = e_n * math.sqrt(p["normals"] / m["normals"])
    how = (f"the fewest {unit} whose own part (±{100 * own:.1f} %) is at most it" if own <= e_s
           else f"the most {unit} within the unsized model's cost")
    return f" (more {unit} do not shrink the drawn point sets' ±{100 * e_s:.1f} %: {how})"


def miss_words(a, target: float, below_se: dict) -> str:
    r"""How the runnable spp below the answer ``a`` misses ``target``, stated against the
    model's own error there (``below_se``: strategy → relative standard error of the RMSE
    predicted at ``a.below``). The true RMSE is the prediction × (1 ± e), so the spp below
    meets the target only if the model overestimates it by
    :math:`z = (1 - t/\hat\sigma)/e` standard errors; under 2 that is not unlikely.

    >>> from types import SimpleNamespace as S
    >>> a = S(strategy="mis", below=256, below_rmse=1.006)
    >>> miss_words(a, 1.0, {"mis": 0.04})
    'misses by 0.6 %, 0.1 times the model error there (±4.0 %): 256 spp may meet it too'
    >>> miss_words(S(strategy="mis", below=256, below_rmse=1.2), 1.0, {"mis": 0.04})
    'misses by 20.0 %, 4.2 times the model error there (±4.0 %)'
    """
    x = a.below_rmse / target - 1.0
    e = below_se.get(a.strategy)
    if not e:
        return "misses"
    z = (1.0 - target / a.below_rmse) / e
    text = f"misses by {100 * x:.1f} %, {z:.1f} times the model error there (±{100 * e:.1f} %)"
    return text + (f": {a.below} spp may meet it too" if z < 2 else "")


def spp_span(cm, a, error) -> dict | None:
    r"""The spp the answer ``a`` would take were the true RMSE the prediction × (1 ∓ e)
    (``error``: the model error [e, …] at the answer), at the local rate
    :math:`\hat\sigma \propto N^{-\alpha}` between the two exact powers of two around the
    answer: :math:`N(1 \mp e)^{1/\alpha}` — the answer's one-standard-error span in spp.
    None when unreached, without an error, or without two such predictions.

    >>> from types import SimpleNamespace as S
    >>> cm = S(asked_spp=lambda s: [512, 1024, 2048],
    ...        rmse=lambda s, n: {512: 2.0, 1024: 2 ** 0.5, 2048: 1.0}[n])
    >>> span = spp_span(cm, S(strategy="mis", spp=1229, reached=True), [0.05])
    >>> round(span["rate"], 12), span["spp"]             # 1229 · 0.95², 1229 · 1.05²
    (0.5, [1109, 1355])
    """
    if not a.reached or not error or not error[0] > 0:
        return None
    asked, p = cm.asked_spp(a.strategy), 1 << (a.spp.bit_length() - 1)
    for lo, hi in ((p, 2 * p), (p // 2, p)):
        if lo >= 1 and lo in asked and hi in asked:
            r_lo, r_hi = cm.rmse(a.strategy, lo), cm.rmse(a.strategy, hi)
            if r_lo > r_hi > 0:
                rate = math.log(r_lo / r_hi) / math.log(hi / lo)
                e = min(float(error[0]), 0.99)
                return {"rate": rate, "spp": [max(1, math.floor(a.spp * (1 - e) ** (1 / rate))),
                                              math.ceil(a.spp * (1 + e) ** (1 / rate))]}
    return None


def below_words(a, target: float, model: dict, every: bool) -> str:
    """What follows the runnable spp below the answer on the answer line: how it misses
    (:func:`miss_words`) where the sampler runs powers of two or squares; where it runs every
    integer (``every``), where one spp less is no step worth stating, the answer's span in
    spp (:func:`spp_span`) instead.

    >>> from types import SimpleNamespace as S
    >>> m = {"spp_span": {"mis": {"rate": 0.5, "spp": [1109, 1355]}},
    ...      "model_se": {"mis": [0.05, 0.03, 0.04]}}
    >>> below_words(S(strategy="mis"), 1.0, m, True)
    '; the model error (±5.0 %) spans 1109–1355 spp at the local rate RMSE ∝ spp^-0.50'
    """
    span = model.get("spp_span", {}).get(a.strategy)
    if every and span:
        e = model["model_se"][a.strategy][0]
        lo, hi = span["spp"]
        return (f"; the model error (±{100 * e:.1f} %) spans {lo}–{hi} spp at the local rate "
                f"RMSE ∝ spp^-{span['rate']:.2f}")
    return " (" + miss_words(a, target, model.get("below_se", {})) + ")"
