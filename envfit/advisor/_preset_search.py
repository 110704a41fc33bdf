r"""The renderer advice's search: the smallest spp a renderer's sampler can run whose predicted
RMSE meets the target, per strategy, with every prediction cached.

Predictions (:class:`CachedPresetModel`): the RMSE over uniform normals of the renderer's own
estimator on a white diffuse surface,
:meth:`envfit.predict.renderer._preset_model.PresetModel.predict_many` — one *pass* over the
model's K normals serves any number of (strategy, spp) cells, and a pass costs the same at
every spp (the integrand is tabulated at the model's finest level), so the search asks for
many cells per pass and as few passes as it can. Each cell is stored in the advisor's cache
(:mod:`envfit.advisor._cache`, kind ``"preset"``: one checksummed JSON file per map, renderer,
sampler, technique options, model options and :func:`model_version`), so a second run on the
same map and sampler builds no model at all.

Search (:func:`search_spp`), per strategy over the spp the sampler can run
(:meth:`~envfit.renderers.SamplerSpec.runnable`, the sampler's own rounding, e.g.
``ldsampler`` 4, 16, 64, …):

1. pass 1: the *coarse* spp — the runnable spp at every power of two (:func:`coarse_spp`),
   the largest spp searched and the ``--spp`` list; the answer lies between the last coarse
   spp that misses the target and the first that meets it (the search assumes, as the
   advisor's other searches do, that the prediction falls with spp between coarse points);
   none meets it: "not reached up to the largest spp searched". The advice asks for every
   coarse spp in this one pass: the nets sampled above the grid (Mitsuba's ``ldsampler``,
   the Owen-scrambled nets above the grid's 2^(L−1) spp) read every N from one table at the
   largest (:meth:`~envfit.predict.renderer._preset_model.PresetModel._shifts`), which costs
   about as much as the grid's own tables, while a second pass would recompute those.
   With ``first_cap``, pass 1 takes the coarse spp up to it only, and the coarse spp above
   it follow in one more pass only for the strategies that none of those meets (cheaper
   when most targets are met on the grid);
2. later passes: up to :data:`CANDIDATES` runnable spp spread over each open bracket (for
   the ``independent`` sampler also the spp the model's exact 1/N law puts at the target,
   :math:`\lceil N_c\,\mathrm{MSE}(N_c)/t^2\rceil` and the runnable spp around it), until no
   runnable spp is left between the last miss and the first meet.

The answer is a *crossing*: prediction(spp) ≤ target < prediction(the runnable spp below it).
"""
from __future__ import annotations

import bisect
import hashlib
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from envfit.advisor._budget import check_preset_plan, preset_passes
from envfit.advisor._cache import AdviseCache
from envfit.advisor._model import map_key
from envfit.advisor._preset_options import NET_RANDOMISATIONS
from envfit.base._resources import format_bytes
from envfit.defaults import FOOTPRINT_SIDE, MICROFACET_FRAMES_SEED, SWITCH_FACTOR
from envfit.predict.renderer._footprint import pixel_footprints
from envfit.predict.renderer._frames import band_frames
from envfit.predict.renderer._microfacet_model import MicrofacetModel
from envfit.predict.renderer._preset_model import PresetModel

__all__ = ["CachedPresetModel", "StrategyAnswer", "answer_error", "next_runnable", "search_model",
           "model_version", "switched_strategy", "coarse_spp", "search_spp", "CANDIDATES",
           "PRESET_CACHE_FORMAT"]

#: runnable spp evaluated per open bracket and pass
CANDIDATES = 16
#: the layout of a cached entry of kind "preset"
PRESET_CACHE_FORMAT = 1


def model_version() -> str:
    """A digest of the noise model's source — every module of the renderer model
    (:mod:`envfit.predict.renderer`, its randomisations), of the renderers' folders
    (:mod:`envfit.renderers`) and of the microfacet BSDFs (:mod:`envfit.shading.microfacet`):
    any change to them makes cached predictions stale."""
    import envfit.predict.renderer as pr
    import envfit.renderers as rr
    import envfit.shading.microfacet as sm
    h = hashlib.sha256()
    for pkg in (pr, rr, sm):
        root = Path(pkg.__file__).parent
        for f in sorted(root.rglob("*.py")):
            h.update(str(f.relative_to(root.parent)).encode())
            h.update(f.read_bytes())
    return h.hexdigest()[:20]


class CachedPresetModel:
    """Predicted RMSE per (strategy, spp rendered), from the cache or the model (built only
    when a cell is missing) and written back after every pass.

    Attributes ``passes`` (model passes run), ``cells_computed``, ``cells_cached`` and
    ``seconds`` (in the model) say what the run cost.
    """

    def __init__(self, envmap, opts, store: AdviseCache, map_key: dict, technique=None):
        self.envmap, self.opts, self.store = envmap, opts, store
        self.technique = technique            # built once for a map (PresetModel's)
        self.key = {**map_key, **opts.key(), "model_version": model_version(),
                    "format": PRESET_CACHE_FORMAT}
        doc = store.load("preset", self.key, envmap=envmap)     # checked against the map
        self.cells: dict[str, dict] = dict(doc["cells"]) if doc else {}
        self.cells_cached = len(self.cells)
        self.asked: set[str] = set()          # the cells of this run (cached or not)
        self.model: PresetModel | None = None
        self.plan = None                      # the model's Plan, made before it is built
        self.passes = self.cells_computed = 0
        self.seconds = 0.0
        self.stage = None                     # the progress bar's word for a pass

    def _model(self):
        """The diffuse model over importance-sampled normals, or the microfacet model over
        frames of an orthographic sphere view and uniform map orientations (a pool of
        ``pool`` frames, ``normals`` of them importance-sampled; with ``sphere_pixels``, each
        frame's pixel footprint)."""
        o = self.opts
        if not o.microfacet:
            return PresetModel(self.envmap, o.preset, o.technique_options(), o.model_options(),
                               technique=self.technique)
        m = o.model_options()
        frames = band_frames(max(m.pool, o.normals), (0.0, 90.0), seed=MICROFACET_FRAMES_SEED)
        foot = (None if o.sphere_pixels is None
                else pixel_footprints(*frames, o.sphere_pixels, FOOTPRINT_SIDE))
        return MicrofacetModel(self.envmap, o.preset, o.conductor(), frames,
                               technique_options=o.technique_options(), options=m,
                               select=o.normals, footprints=foot, technique=self.technique)

    def bands(self, strategy: str, n: int) -> dict:
        """The stored per-band predictions of a cell ({} for the diffuse model)."""
        return dict(self.cells[self._name(strategy, n)].get("bands", {}))

    def band_errors(self, strategy: str, n: int) -> dict:
        """The stored frames and relative standard error per band and ``"all"`` of a cell
        ({} for the diffuse model)."""
        return dict(self.cells[self._name(strategy, n)].get("band_errors", {}))

    @staticmethod
    def _name(strategy: str, n: int) -> str:
        return f"{strategy}:{int(n)}"

    def rmse(self, strategy: str, n: int) -> float:
        """The stored prediction of a cell (KeyError if not predicted yet)."""
        return float(self.cells[self._name(strategy, n)]["rmse"])

    def model_error(self, strategy: str, n: int) -> list | None:
        """The stored model error of a cell: [relative standard error of the RMSE, its
        normals' part, its sampled randomisations' part], or None (one normal)."""
        return self.cells[self._name(strategy, n)].get("model_se")

    def has(self, strategy: str, n: int) -> bool:
        """Whether this run asked for the cell (so that a cached run takes the same path)."""
        return self._name(strategy, n) in self.asked

    def asked_spp(self, strategy: str) -> list[int]:
        """The spp of ``strategy`` this run asked for, ascending."""
        return sorted(int(k.partition(":")[2]) for k in self.asked
                      if k.partition(":")[0] == strategy)

    def predict(self, cells) -> None:
        """Make sure every (strategy, spp rendered) of ``cells`` is predicted: one model pass
        for the missing ones, then the cache entry rewritten."""
        names = {(s, int(n)) for s, n in cells}
        self.asked.update(self._name(s, n) for s, n in names)
        todo = sorted((s, n) for s, n in names if self._name(s, n) not in self.cells)
        if not todo:
            return
        t0 = time.perf_counter()
        if self.model is None:
            self.plan = check_preset_plan(self.envmap, self.opts)   # one line if over budget
            self.model = self._model()
            self.model.quiet = self.opts.quiet
            self.technique = self.model.technique
        rand = self.opts.preset.sampler(self.opts.sampler).randomisation
        self.model.progress_label = (
            f"renderer model, {self.stage or 'pass'} {self.passes + 1} (planned ~"
            f"{_duration(self.plan, preset_passes(rand))} a pass, "
            f"peak ~{format_bytes(self.plan.peak())})")
        res = self.model.predict_many([(s, self.opts.sampler, n) for s, n in todo])
        for (s, n), r in zip(todo, res):
            cell = {"rmse": float(r.rmse), "mse": [float(x) for x in np.ravel(r.mse)],
                    "model_se": (None if r.model_se is None else
                                 [float(r.model_se), *map(float, r.model_se_parts)])}
            if self.opts.microfacet:
                cell["bands"] = self.model.predict_bands(s, self.opts.sampler, n)
                cell["band_errors"] = self.model.predict_band_errors(s, self.opts.sampler, n)
            self.cells[self._name(s, n)] = cell
        self.passes = self.model.runs      # a prefix sampler's N between powers: no pass
        self.cells_computed += len(todo)
        self.seconds += time.perf_counter() - t0
        self.store.save("preset", self.key, {"cells": self.cells})


def _duration(plan, passes: int) -> str:
    """A pass's planned seconds in words (:func:`envfit.advisor._budget.preset_plan`, of
    ``passes`` passes)."""
    secs = plan.seconds() / passes
    return f"{secs:.0f} s" if secs < 120 else f"{secs / 60:.0f} min"


def next_runnable(spec, spp: int, every: bool = False) -> int:
    """The smallest spp above ``spp`` the sampler runs (a power of two for the model's nets;
    a sampler may round a request down, as pbrt-v4's ``zsobol`` does).

    >>> from envfit.renderers import get_renderer
    >>> next_runnable(get_renderer("pbrt4").sampler("zsobol"), 32), next_runnable(
    ...     get_renderer("mitsuba3").sampler("ldsampler"), 256)
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


def _bracket(cm: CachedPresetModel, strategy: str, runnable: list[int], target: float):
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


def search_spp(cm: CachedPresetModel, strategies, runnable: list[int], target: float,
               listed=(), *, independent: bool = False,
               first_cap: int | None = None) -> dict[str, StrategyAnswer]:
    """The smallest runnable spp per strategy whose prediction meets ``target`` (module
    docstring); ``listed`` spp are predicted in the first pass too, and the coarse spp above
    ``first_cap`` only where needed."""
    coarse = coarse_spp(runnable)
    cap = runnable[-1] if first_cap is None else first_cap
    first = {n for n in coarse if n <= cap} | {n for n in listed}
    cm.predict([(s, n) for s in strategies for n in first])
    open_ = [s for s in strategies if _bracket(cm, s, runnable, target)[1] is None]
    cm.predict([(s, n) for s in open_ for n in coarse if n > cap])
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
                 technique=None, strategies=None, stage: str | None = None):
    """(the cached model, the answers per strategy) of one search over the runnable spp
    (``technique``: the map's, built by an earlier model; ``strategies``: these only;
    ``stage``: the progress bar's word for its passes, e.g. ``"pilot pass"``)."""
    spec = opts.preset.sampler(opts.sampler)
    runnable = spec.runnable(opts.spp_cap())
    if not opts.every_spp:                             # the model's nets: N = 2^m
        runnable = [n for n in runnable if n & (n - 1) == 0]
    cm = CachedPresetModel(envmap, opts, store, map_key(envmap, "linear"), technique)
    cm.stage = stage
    answers = search_spp(cm, strategies or opts.strategies, runnable, target, listed,
                         independent=spec.randomisation == "independent")
    return cm, answers


def answer_error(cm: CachedPresetModel, a: StrategyAnswer) -> list | None:
    """The model error [total, normals', scrambles'] at a strategy's answer (or at the
    largest spp searched)."""
    return cm.model_error(a.strategy, a.spp if a.reached else a.searched_max)


def switched_strategy(answers: dict, preset, default: str) -> str | None:
    """The strategy recommended instead of the renderer's ``default``, or None: the one that
    meets the target with the fewest samples traced per pixel (spp × the emitter and BSDF
    samples per spp), when the default meets it only with at least
    :data:`~envfit.defaults.SWITCH_FACTOR` times as many, or not at all."""
    def cost(a: StrategyAnswer) -> int:
        st = preset.strategy(a.strategy)
        return a.spp * (st.emitter_samples + st.bsdf_samples)

    d = answers[default]
    met = [a for a in answers.values() if a.reached]
    if not met:
        return None
    best = min(met, key=cost)
    if best.strategy == d.strategy or (d.reached and cost(d) < SWITCH_FACTOR * cost(best)):
        return None
    return best.strategy
