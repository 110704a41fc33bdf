r"""Advice in a renderer's own terms (``envfit advise MAP --renderer NAME``): the spp that
renderer's sampler must run, with its integrator's settings, for an RMSE target, and the scene
text to paste — the result (:class:`RendererAdvice`) and the pipeline that makes it
(:func:`advise_renderer_map`, reached from :func:`envfit.advisor.advise_with`).

The prediction is the noise of the renderer's *own* estimator as its record describes it
(:mod:`envfit.renderers`: the emitter's density and warp, the BSDF sampling, the MIS
heuristic and the samples per spp of its integrator, the sampler's randomisation) on a white
diffuse surface (or a microfacet BSDF): the RMSE over uniform normals, RMS over the colour
channels, in the map's radiance units, made by the predictor ``renderer`` of
:data:`envfit.predict.PREDICTORS` (:mod:`envfit.advisor._renderer_model`). The target is
``target_rmse``, or ``target_relative`` (default 1 %) of the map's mean radiance (for the
diffuse lobe, :func:`envfit.advisor._prediction.mean_shading_value`).

For each strategy the renderer can render (``mis`` = both techniques as its integrator
combines them, the renderer's default; ``map`` = emitter sampling only; ``brdf`` = BSDF
sampling only) the answer is the smallest spp the sampler can run whose prediction meets the
target (:func:`envfit.advisor._renderer_search.search_spp`), up to the largest spp the model
resolves for that sampler
(:meth:`~envfit.advisor._renderer_options.RendererAdviseOptions.spp_cap`). The recommendation
is the renderer's default strategy (the first of ``strategies``), or one at least 10× cheaper
where there is one (:attr:`RendererAdvice.default`).

Example
-------
>>> import tempfile, numpy as np
>>> from envfit.maps import EnvMap
>>> from envfit.renderers import RENDERERS
>>> from envfit.advisor._renderer_options import RendererAdviseOptions
>>> env = EnvMap(np.random.default_rng(0).random((8, 16, 3)) + 0.5, name="noise")
>>> name = next(n for n, r in RENDERERS.items() if "independent" in r.samplers)
>>> opts = RendererAdviseOptions(name, sampler="independent", normals=4, level=3,
...                              target_relative=0.05, cache_dir=tempfile.mkdtemp())
>>> a = advise_renderer_map(env, opts)
>>> r = a.recommendation
>>> r["strategy"], r["sampler"], r["predicted_rmse"] <= r["target_rmse"]
('mis', 'independent', True)
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from envfit.advisor._cache import AdviseCache
from envfit.advisor._prediction import mean_shading_value
from envfit.advisor._renderer_options import (DEFAULT_LEVEL, DEFAULT_MAX_SPP, DEFAULT_NORMALS,
                                            SIZED_RANDOMISATIONS, STRATA_CAP,
                                            STRATEGY_WORDS, RendererAdviseOptions, spp_cap)
from envfit.predict.renderer.randomisation import ALWAYS_DRAWN, STRATA_SAMPLED
from envfit.advisor._renderer_search import StrategyAnswer, next_runnable, switched_strategy
from envfit.advisor._renderer_sizing import (below_words, model_dict, model_error_lines,
                                           sized_search)
from envfit.base import ParameterError
from envfit.defaults import BAND_MIN_FRAMES, DEFAULT_TARGET_RELATIVE

__all__ = ["RendererAdvice", "PresetAdvice", "advise_renderer_map", "advise_preset",
           "integrator_text"]


def integrator_text(record, strategy: str, mis_compensation: bool = False) -> str:
    """``direct (emitter_samples=1, bsdf_samples=0)``: the integrator of the renderer's
    ``record`` for ``strategy`` and its settings (its name alone where it runs at its
    defaults).

    >>> from types import SimpleNamespace as S
    >>> rec = S(strategy=lambda s: S(integrator="direct",
    ...                              settings={"emitter_samples": 1, "bsdf_samples": 0}))
    >>> integrator_text(rec, "map"), integrator_text(rec, "map", mis_compensation=True)[-29:]
    ('direct (emitter_samples=1, bsdf_samples=0)', 'envmap mis_compensation=true)')
    """
    s = record.strategy(strategy)
    items = [f"{k}={v}" for k, v in s.settings.items()]
    if mis_compensation:
        items.append("envmap mis_compensation=true")
    return f"{s.integrator} ({', '.join(items)})" if items else s.integrator


#: how the model line names a microfacet --brdf ({} the renderer's possessive)
_BSDF_WORDS = {"ggx": "GGX", "multiggx": "Multiscatter GGX ({} default)"}


def _maker(record) -> str:
    """The possessive of the renderer's name without its version (``X 3`` → ``X's``)."""
    w = record.display.split()[0]
    return w + ("'" if w.endswith("s") else "'s")


@dataclass
class RendererAdvice:
    """The renderer section of ``envfit advise --renderer``: the answer per strategy, every
    prediction made, the recommendation (the default strategy's answer) and the scene text.

    ``answers`` maps a strategy to its :class:`~envfit.advisor._renderer_search.StrategyAnswer`;
    ``listed`` is the ``--spp`` list as (requested, runnable) pairs; ``cells`` the predicted
    RMSE per (strategy, spp); ``spp_cap`` the largest spp searched; ``model`` what the model
    cost (passes, cells computed and cached, seconds, K, L).
    """

    options: RendererAdviseOptions
    target_rmse: float
    target_relative: float | None
    mean_radiance: float
    answers: dict
    listed: list
    cells: dict
    spp_cap: int
    model: dict = field(default_factory=dict)
    snippet: str | None = None
    snippet_spp: int | None = None
    notes: list = field(default_factory=list)
    bands: dict = field(default_factory=dict)
    band_errors: dict = field(default_factory=dict)

    @property
    def display(self) -> str:
        return self.options.record.display

    constant_map: bool = False

    @property
    def default(self) -> StrategyAnswer:
        """The recommended answer: the renderer's default strategy's, or a cheaper strategy's
        (:meth:`switched`)."""
        return self.answers[self.switched() or self.options.default_strategy]

    def _cost(self, a: StrategyAnswer) -> int:
        """Samples traced per pixel: spp × (emitter + BSDF samples per spp)."""
        s = self.options.record.strategy(a.strategy)
        return a.spp * (s.emitter_samples + s.bsdf_samples)

    def switched(self) -> str | None:
        """The strategy recommended instead of the renderer's default, or None: the one that
        meets the target with the fewest samples traced per pixel, when the default meets it
        only with at least :data:`~envfit.defaults.SWITCH_FACTOR` times as many, or not at all."""
        return switched_strategy(self.answers, self.options.record,
                                 self.options.default_strategy)

    def switch_line(self) -> str | None:
        """Why a strategy other than the renderer's default is recommended (None if not)."""
        name = self.switched()
        if name is None:
            return None
        a, d = self.answers[name], self.answers[self.options.default_strategy]
        words = STRATEGY_WORDS[d.strategy]
        need = (f"needs {d.spp} spp ({self._cost(d)} samples per pixel against "
                f"{self._cost(a)})" if d.reached else
                f"meets the target at no spp up to {d.searched_max}")
        dflt = ", the renderer's default," if d.strategy == "mis" else ""
        out = f"recommended instead of {words}{dflt} which {need}"
        if a.predicted_rmse == 0.0:
            out += (f": {STRATEGY_WORDS[name]} is exact here (predicted RMSE 0"
                    + ("; the map is constant, so the cosine-weighted BSDF sample has no "
                       "variance at any spp)" if self.constant_map and name == "brdf"
                       and not self.options.microfacet else ")"))
        return out

    @property
    def recommendation(self) -> dict:
        """The default strategy's answer as the JSON's ``renderer.recommendation``."""
        a, p = self.default, self.options.record
        s = p.strategy(a.strategy)
        return {"strategy": a.strategy, "sampler": self.options.sampler, "spp": a.spp,
                "reached": a.reached, "integrator": s.integrator, "settings": dict(s.settings),
                "mis_compensation": self.options.mis_compensation,
                "predicted_rmse": a.predicted_rmse, "target_rmse": self.target_rmse,
                "searched_max": a.searched_max,
                "default_strategy": self.options.default_strategy,
                "why": self.switch_line()}

    def predictions(self) -> list[dict]:
        """Every predicted (strategy, spp): ``{"strategy", "sampler", "spp",
        "predicted_rmse"}``, the strategies in the renderer's order, spp ascending."""
        return [{"strategy": s, "sampler": self.options.sampler, "spp": n,
                 "predicted_rmse": self.cells[(s, n)],
                 **({"bands": self.bands[(s, n)]} if (s, n) in self.bands else {}),
                 **({"band_errors": self.band_errors[(s, n)]}
                    if (s, n) in self.band_errors else {})}
                for s in self.options.strategies
                for n in sorted(n for (t, n) in self.cells if t == s)]

    def band_lines(self) -> list[str]:
        """A microfacet BSDF: the default strategy's RMSE per view-angle stratum at the
        recommended spp (or the largest searched), each with its share of the sphere's weight
        (the whole sphere's MSE is the bands' mean with these weights), its frames and their
        95 % bootstrap interval (:mod:`envfit.predict.renderer._bands`), and where the band
        meets the target among the spp this run predicted (the smallest that meets it, the
        largest below it that misses: the band's crossing lies between). A band of fewer than
        :data:`~envfit.defaults.BAND_MIN_FRAMES` frames has no interval: its value is
        withheld."""
        a = self.default
        n = a.spp if a.reached else a.searched_max
        spread = self.band_errors.get((a.strategy, n))
        if not spread or "all" not in spread:
            return []
        out = [f"per view angle theta_o ({STRATEGY_WORDS[a.strategy]}, {n} spp; target "
               f"{self._f(self.target_rmse)}; the whole sphere's MSE is the bands' mean "
               f"weighted by their share of the sphere; 95 % bootstrap interval over the "
               f"frames, none below {BAND_MIN_FRAMES} frames):",
               f"  whole sphere ({self._spread(spread['all'], spread)}): predicted RMSE "
               f"{self._f(self.cells[(a.strategy, n)])}"]
        for band, e in spread.items():
            if band == "all":
                continue
            if e.get("interval") is None:
                out.append(f"  {band} deg ({self._spread(e)}): withheld, too few frames for an "
                           f"interval (at least {BAND_MIN_FRAMES}; --renderer-normals "
                           f"{6 * BAND_MIN_FRAMES} gives every band that many)")
                continue
            out.append(f"  {band} deg ({self._spread(e)}): predicted RMSE "
                       f"{self._f(e['rmse'])}; {self._band_crossing(a, n, band)}")
        return out

    def _band_value(self, strategy: str, n: int, band: str) -> float:
        """A band's predicted RMSE at ``n`` spp (inf where not predicted)."""
        e = self.band_errors.get((strategy, n), {}).get(band, {})
        return float(e.get("rmse", self.bands.get((strategy, n), {}).get(band, np.inf)))

    def _band_crossing(self, a: StrategyAnswer, n: int, band: str) -> str:
        """Where ``band`` meets the target among the spp this run predicted."""
        asked = sorted(m for (t, m) in self.band_errors if t == a.strategy)
        ok = [m for m in asked if self._band_value(a.strategy, m, band) <= self.target_rmse]
        if not ok:
            return f"no spp up to {asked[-1]} meets the target"
        miss = [m for m in asked if m < ok[0]]
        return (f"meets the target at {ok[0]} spp"
                + (f" ({ok[0] / n:.3g}x the recommendation)" if a.reached and ok[0] != n
                   else "") + (f", not at {miss[-1]}" if miss else ""))

    @staticmethod
    def _spread(e: dict, strata: dict | None = None) -> str:
        """The bracket of a band's line: its share of the sphere, its frames and their
        interval (the whole sphere, ``strata`` given: the frames, and why there is no interval
        when a band has too few)."""
        k = e["frames"]
        head = (f"{k} frame{'s' if k != 1 else ''}" if strata is not None else
                f"{100 * e['weight']:.3g} % of the sphere, {k} frame{'s' if k != 1 else ''}")
        if e.get("interval") is not None:
            return f"{head}, 95 % {e['interval'][0]:.4g}…{e['interval'][1]:.4g}"
        if strata is None:
            return head
        few = [f"{b} deg ({x['frames']})" for b, x in strata.items()
               if b != "all" and x["frames"] < BAND_MIN_FRAMES]
        return f"{head}; no interval: fewer than {BAND_MIN_FRAMES} frames in {', '.join(few) or 'a band'}"

    def _goal(self) -> str:
        if self.target_relative is not None:
            return (f"{self.target_relative * 100:g} % of the map's mean radiance "
                    f"{self.mean_radiance:.4g}")
        if not self.mean_radiance > 0:      # never a negative or infinite percentage
            return f"the map's mean radiance is {self.mean_radiance:.4g}"
        return f"{self.target_rmse / self.mean_radiance:.2%} of the map's mean radiance"

    def _why_max(self, a: StrategyAnswer) -> str:
        """Why the search stopped at ``a.searched_max``: the model's resolution (and the
        level that reaches the next runnable spp) or ``--nmax``."""
        o = self.options
        spec = o.record.sampler(o.sampler)
        nxt = next_runnable(spec, a.searched_max, o.every_spp)
        if nxt > o.max_spp:
            return "raise --nmax or relax the target"
        rand = spec.randomisation
        if rand in ALWAYS_DRAWN and o.spp_cap() == min(STRATA_CAP, o.max_spp):
            return (f"the model predicts {o.sampler} to {STRATA_CAP} spp (its runs of the "
                    f"shared sequence drawn at every spp); {nxt} spp is beyond it")
        if rand in STRATA_SAMPLED and o.spp_cap() == min(STRATA_CAP, o.max_spp):
            return (f"the model predicts {o.sampler} to {STRATA_CAP} spp (exactly to "
                    f"{o.spp_cap(sampled=False)} spp at grid level {o.level}, from drawn "
                    f"point sets above); {nxt} spp is beyond it")
        level = next((lv for lv in range(o.level + 1, 12)
                      if spp_cap(rand, lv, o.max_spp) >= nxt),
                     None)
        head = (f"the model resolves {o.sampler} to {a.searched_max} spp at grid level "
                f"{o.level}")
        if level is None:
            return f"{head}; {nxt} spp is beyond its finest level 11"
        if self.model.get("sized"):         # its cost is not the level's: say the unsized one
            return (f"{head}; {nxt} spp needs --renderer-level {level} (its "
                    f"{DEFAULT_NORMALS} normals at level {level} take "
                    f"{4 ** (level - DEFAULT_LEVEL)}x the time and memory of level "
                    f"{DEFAULT_LEVEL})")
        return (f"{head}; {nxt} spp needs --renderer-level {level} "
                f"({4 ** (level - o.level)}x the time and memory)")

    def _f(self, x: float) -> str:
        """A number with the digits that tell every printed prediction from the target."""
        vals = [a.predicted_rmse for a in self.answers.values()] + [
            a.below_rmse for a in self.answers.values() if a.below_rmse is not None]
        k = next((k for k in range(4, 13)
                  if all(f"{v:.{k}g}" != f"{self.target_rmse:.{k}g}"
                         for v in vals if v != self.target_rmse)), 13)
        return f"{x:.{k}g}"

    def answer_line(self, a: StrategyAnswer, *, head: bool) -> str:
        """One strategy's sentence: the first line (``head``) with the renderer, sampler,
        target and why the search stopped; the others shorter."""
        o, p = self.options, self.options.record
        who = (f"{self.display}, sampler {o.sampler}, integrator " if head
               else f"  {STRATEGY_WORDS[a.strategy]}, ")
        who += integrator_text(p, a.strategy, o.mis_compensation and a.strategy != "brdf")
        f = self._f
        goal = f"an RMSE of at most {f(self.target_rmse)} ({self._goal()})"
        if not a.reached:
            if not head:
                return (f"{who}: no spp up to {a.searched_max} meets the target (predicted "
                        f"RMSE {f(a.predicted_rmse)} at {a.searched_max} spp; "
                        f"{self._why_max(a)})")
            return (f"{who}: no spp up to {a.searched_max} meets {goal}; predicted RMSE "
                    f"{f(a.predicted_rmse)} at {a.searched_max} spp ({self._why_max(a)})")
        spec = p.sampler(o.sampler)
        below = ("" if a.below is None else f", {f(a.below_rmse)} at {a.below} spp"
                 + below_words(a, self.target_rmse, self.model, o.every_spp and spec.spp(3) == 3))
        if spec.randomisation == "independent" and a.spp > DEFAULT_MAX_SPP:
            below += (f"; beyond {DEFAULT_MAX_SPP} spp from the independent sampler's exact "
                      f"rate, RMSE = sigma/sqrt(spp)")
        if not head:
            return f"{who}: spp = {a.spp} (predicted RMSE {f(a.predicted_rmse)}{below})"
        pow2 = ("; spp searched at powers of two (the model predicts this sampler's nets "
                "there)" if not o.every_spp and spec.spp(3) == 3 else
                "; between powers of two from the scrambled sequence's sampled prefixes, "
                "calibrated at the exact powers of two" if spec.prefix and o.every_spp else "")
        e = self.model.get("model_se", {}).get(a.strategy)
        pm = f" (±{100 * e[0]:.1f} %)" if e else ""
        return (f"{who}: spp = {a.spp} for {goal}; predicted RMSE {f(a.predicted_rmse)}{pm} at "
                f"{a.spp} spp{below}{pow2}")

    def table_lines(self) -> list[str]:
        """The ``--spp`` table: the predicted RMSE per strategy at each listed spp."""
        if not self.listed:
            return []
        strategies = self.options.strategies
        out = [f"predicted RMSE at the listed spp (sampler {self.options.sampler}; target "
               f"{self._f(self.target_rmse)}):",
               "  " + f"{'spp':>10s}" + "".join(f" {s:>10s}" for s in strategies)]
        for req, n in self.listed:
            lab = str(n) if req == n else f"{req}->{n}"
            out.append("  " + f"{lab:>10s}" + "".join(f" {self.cells[(s, n)]:>10.3e}"
                                                      for s in strategies))
        return out

    def lines(self) -> list[str]:
        """Everything printed, the answer first."""
        o = self.options
        out = [self.answer_line(self.default, head=True)]
        out += [f"  ({why})" for why in [self.switch_line()] if why]
        out += [self.answer_line(self.answers[s], head=False) for s in o.strategies
                if s != self.default.strategy]
        out += self.table_lines()
        if self.snippet is not None:
            a = self.default
            state = ("the recommendation" if a.reached else
                     "the largest spp searched, which misses the target")
            out.append(f"scene ({self.display}, {STRATEGY_WORDS[a.strategy]}, "
                       f"{self.snippet_spp} spp: {state}):")
            out += self.snippet.rstrip("\n").split("\n")
        out += self.band_lines()
        m = self.model
        a = self.default
        frames = self.band_errors.get((a.strategy, a.spp if a.reached else a.searched_max),
                                      {}).get("all", {}).get("frames")
        count = (f"{m['normals']} normals" if not o.microfacet else f"{m['normals']} frames"
                 if frames in (None, m["normals"]) else
                 f"{frames} frames ({m['normals']} asked, each view-angle band at least "
                 f"{m['normals'] // 6})")
        scrambles = (f", {m['shifts']} scrambles" if m.get("sized") and self.options.record
                     .sampler(self.options.sampler).randomisation in SIZED_RANDOMISATIONS
                     else "")
        out.append(f"renderer model: {self._surface()} (RMS over the channels), "
                   f"{count}, grid level "
                   f"{m['level']}{scrambles}; {m['passes']} pass(es), {m['cells_computed']} "
                   f"cell(s) computed, {m['cells_cached']} from the cache"
                   + (f"; strategies other than {m.get('sized_strategy', o.strategies[0])}: "
                      f"the pilot's "
                      f"{m['pilot']['normals']} {m.get('unit', 'normals')}"
                      if m.get("pilot") and len(self.answers) > 1 else ""))
        out += model_error_lines(self.model, self.default)
        if o.record.estimator_note:
            out.append(f"note: {o.record.estimator_note}")
        return out

    def _surface(self) -> str:
        o = self.options
        pixels = ("" if o.sphere_pixels is None else
                  f", {o.sphere_pixels} pixels across (each pixel's footprint included, "
                  f"{self._filter_words()})")
        if not o.microfacet:
            if o.sphere_pixels is None:
                return "the RMSE over uniform normals of a white diffuse surface"
            return (f"the RMSE over uniform normals of a white diffuse sphere{pixels[1:]}, "
                    f"each pixel seen by the axis view nearest its normal")
        c = o.conductor()
        if o.bsdf == "roughplastic":
            bsdf = (f"rough plastic ({_maker(o.record)} roughplastic: a GGX coat of alpha "
                    f"{c.alpha:.4g}, eta 1.49, over a diffuse base of reflectance 0.5)")
        elif o.bsdf == "principled":
            rest = ", ".join(f"{k} {v:g}" for k, v in self._bsdf_params().items())
            lobe = (f"eta {c.eta:.4g}" if c.eta is not None else
                    "its metallic closure alone: Multiscatter GGX, F82-tint Fresnel")
            bsdf = (f"principled BSDF ({_maker(o.record)} "
                    f"{o.record.bsdf_names.get('principled', 'principled')}: roughness "
                    f"{o.roughness:g}, GGX alpha {c.alpha:.4g}, {rest}, {lobe})")
        else:
            bsdf = (f"white {_BSDF_WORDS.get(o.bsdf, o.bsdf.title()).format(o.record.possessive)}"
                    f" conductor (alpha {c.alpha:.4g}, Fresnel 1)")
        return (f"the RMSE of a {bsdf} over the views an "
                f"orthographic camera has of a sphere{pixels} (theta_o density cos sin) and "
                f"uniform map orientations")

    def _film_dict(self) -> dict:
        """``pixel_filter``: the footprint's filter (with ``sphere_pixels`` only)."""
        o = self.options
        if o.sphere_pixels is None:
            return {}
        return {"pixel_filter": o.model_options().film(o.record).name}

    def _filter_words(self) -> str:
        """The pixel filter the footprint assumes, in the renderer's words."""
        o = self.options
        film = o.model_options().film(o.record)
        if film.table is not None:
            return f"{o.record.possessive} default pixel filter, {film.name}"
        note = o.record.pixel_filter_note
        return "the box pixel filter" + (f"; {note}" if note else "")

    def _bsdf_params(self) -> dict:
        """The BSDF's own parameters (the record's defaults, those asked over them), without
        the roughness."""
        o = self.options
        return {k: float(v) for k, v in {**o.record.bsdf_params.get(o.bsdf, {}),
                                         **o.bsdf_params}.items() if k != "roughness"}

    def _bsdf_dict(self) -> dict:
        """The JSON's ``bsdf`` of a microfacet BSDF."""
        o = self.options
        c = o.conductor()
        d = {"type": o.bsdf, "roughness": o.roughness, "alpha": c.alpha}
        if o.bsdf == "roughplastic":
            d.update(distribution="ggx", eta=c.eta, diffuse_reflectance=c.diffuse_reflectance)
        elif o.bsdf == "principled":
            d.update(distribution="multiggx" if getattr(c, "multiscatter", False) else "ggx",
                     **({"eta": c.eta} if c.eta is not None else {"fresnel": "f82_tint"}),
                     **self._bsdf_params())
        else:
            d["fresnel"] = 1.0
        return {**d, "sphere_pixels": o.sphere_pixels, **self._film_dict()}

    def to_dict(self) -> dict:
        """The JSON's ``renderer`` section."""
        o = self.options
        return {"name": o.renderer, "display": self.display, "renderer": o.record.renderer,
                "sampler": o.sampler, "strategies": list(o.strategies),
                "mis_compensation": o.mis_compensation, "target_rmse": self.target_rmse,
                "bsdf": (self._bsdf_dict() if o.microfacet
                         else {"type": "diffuse", "reflectance": 1.0,
                               "sphere_pixels": o.sphere_pixels, **self._film_dict()}),
                "target_relative": self.target_relative, "mean_radiance": self.mean_radiance,
                "recommendation": self.recommendation, "predictions": self.predictions(),
                "answers": [{**self._answer_dict(self.answers[s])} for s in o.strategies],
                "listed_spp": [{"requested": r, "spp": n} for r, n in self.listed],
                "spp_cap": self.spp_cap, "max_spp": o.max_spp, "model": dict(self.model),
                "snippet": self.snippet, "snippet_spp": self.snippet_spp, "notes": self.notes}

    def _repr_html_(self) -> str:       # Jupyter: the printed answer, escaped
        from envfit.base import html_result
        return html_result(f"RendererAdvice: {self.display}", [("", x) for x in self.lines()])

    def _answer_dict(self, a: StrategyAnswer) -> dict:
        s = self.options.record.strategy(a.strategy)
        return {"strategy": a.strategy, "spp": a.spp, "reached": a.reached,
                "predicted_rmse": a.predicted_rmse, "below_spp": a.below,
                "below_rmse": a.below_rmse, "searched_max": a.searched_max,
                "model_se": self.model.get("model_se", {}).get(a.strategy),
                "below_model_se": self.model.get("below_se", {}).get(a.strategy),
                "spp_span": self.model.get("spp_span", {}).get(a.strategy),
                "integrator": s.integrator, "settings": dict(s.settings)}


def _target(mean: float, target_rmse, target_relative) -> tuple[float, float | None]:
    """(absolute target, relative or None): ``target_rmse`` or ``target_relative`` (default
    0.01) × the mean radiance."""
    if target_rmse is not None:
        return float(target_rmse), None
    rel = DEFAULT_TARGET_RELATIVE if target_relative is None else float(target_relative)
    if not mean > 0:
        raise ParameterError(f"the map's mean radiance is {mean:.3g}, not positive: give "
                             f"--target-rmse instead")
    return rel * mean, rel


def _add_snippet(adv: RendererAdvice, envmap, filename: str) -> None:
    """The scene text of the recommendation (or of the largest spp searched) reading
    ``filename``: the BSDF, the film the model assumed (``sphere_pixels``), the light frame of
    the map's ``up`` (each where the renderer's snippet takes it)."""
    opts = adv.options
    a = adv.default
    adv.snippet_spp = a.spp if a.reached else a.searched_max
    kw = {"sphere_pixels": opts.sphere_pixels, "up": getattr(envmap, "up", "y")}
    if opts.mis_compensation:
        kw["mis_compensation"] = True
    if opts.microfacet:     # a renderer whose snippet writes one (the CLI refuses the rest)
        kw["microfacet"] = (opts.bsdf, opts.conductor().alpha, dict(opts.bsdf_params))
    takes = opts.record.snippet_options()
    adv.snippet = opts.record.snippet(a.strategy, opts.sampler, adv.snippet_spp,
                                      filename=filename,
                                      **{k: v for k, v in kw.items() if k in takes})


def advise_renderer_map(envmap, opts: RendererAdviseOptions) -> RendererAdvice:
    """The renderer advice on ``envmap`` (module docstring): the checked options → the cached
    model, asked through the predictor registry (:mod:`~envfit.advisor._renderer_model`) →
    the spp search, sized to the model's own error (:mod:`~envfit.advisor._renderer_sizing`)
    → the :class:`RendererAdvice`.

    Parameters
    ----------
    envmap : EnvMap
        The map as the renderer reads its file (linear radiance).
    opts : RendererAdviseOptions
        Renderer, sampler, strategies, listed spp, model resolution, the target, the snippet
        and the cache.
    """
    t0 = time.perf_counter()
    mean = mean_shading_value(envmap)
    target, rel = _target(mean, opts.target_rmse, opts.target_relative)
    spec = opts.record.sampler(opts.sampler)
    listed = [(n, spec.spp(n)) for n in opts.spp]
    store = AdviseCache(opts.cache_dir, enabled=opts.cache)
    snippet, filename = opts.snippet, opts.filename
    opts, by, answers, pilot, cms = sized_search(envmap, opts, store, target,
                                                  [n for _, n in listed])
    cap = max(a.searched_max for a in answers.values())
    cells = {(s, n): by[s].rmse(s, n) for s in opts.strategies for n in by[s].asked_spp(s)}
    notes = [*opts.notes, *store.notes]
    if opts.bsdf in opts.record.bsdf_notes:
        notes.append(opts.record.bsdf_notes[opts.bsdf])
    px = np.asarray(envmap.data).reshape(envmap.height * envmap.width, -1)
    adv = RendererAdvice(opts, target, rel, mean, answers, listed, cells, cap, notes=notes,
                         constant_map=bool(np.all(px == px[0])),
                         bands={k: b for k in cells if (b := by[k[0]].bands(*k))},
                         band_errors={k: b for k in cells if (b := by[k[0]].band_errors(*k))})
    if snippet:
        _add_snippet(adv, envmap, filename)
    adv.model = model_dict(opts, by, answers, pilot, cms)
    adv.model.update(seconds=time.perf_counter() - t0, cache_hits=store.hits,
                     cache_writes=store.writes)
    return adv


def advise_preset(envmap, opts: RendererAdviseOptions, *, target_rmse: float | None = None,
                  target_relative: float | None = None, snippet: bool | None = None,
                  filename: str | None = None, cache: bool | None = None,
                  cache_dir=None) -> RendererAdvice:
    """The former entry point, kept for its callers: :func:`advise_renderer_map` with the
    target, the snippet and the cache given as keywords (each one given replaces the
    options' own)."""
    asked = {"target_rmse": target_rmse, "target_relative": target_relative,
             "snippet": snippet, "filename": filename, "cache": cache, "cache_dir": cache_dir}
    return advise_renderer_map(envmap, opts.asking(**{k: v for k, v in asked.items()
                                                      if v is not None}))


#: the former name of :class:`RendererAdvice`
PresetAdvice = RendererAdvice
