r"""The renderer advice's model: a real renderer's noise model on the map, asked through the
predictor registry and cached.

Each (strategy, spp) cell is predicted by the predictor ``renderer`` of
:data:`envfit.predict.PREDICTORS` (:func:`envfit.predict._registry.predict_many`, one
:class:`~envfit.predict._registry.SamplerRule` per cell): the RMSE of the renderer's own
estimator over the model's normals (:class:`~envfit.predict.renderer.DiffuseModel`; a microfacet
BSDF's over frames, :class:`~envfit.predict.renderer.MicrofacetModel`), every cell of a search
pass in one pass of the model. Each cell is stored in the advisor's cache
(:mod:`envfit.advisor._cache`, kind ``"renderer_cells"``: one checksummed JSON file per map, renderer,
sampler, technique options, model options and :func:`model_version`), so a second run on the
same map and sampler builds no model at all.
"""
from __future__ import annotations

import hashlib
import time
from pathlib import Path

import numpy as np

from envfit.advisor._budget import check_renderer_plan, renderer_passes
from envfit.advisor._cache import AdviseCache
from envfit.base import format_bytes
from envfit.defaults import FOOTPRINT_SIDE, MICROFACET_FRAMES_SEED
from envfit.predict import PredictionContext
from envfit.predict import SamplerRule, predict_many
from envfit.predict.renderer import pixel_footprints
from envfit.predict.renderer import band_frames
from envfit.predict.renderer import MicrofacetModel
from envfit.predict.renderer import DiffuseModel

__all__ = ["CachedRendererModel", "model_version", "PREDICTOR", "RENDERER_CACHE_FORMAT"]

#: the predictor of :data:`envfit.predict.PREDICTORS` that predicts a renderer's cells
PREDICTOR = "renderer"
#: the layout of a cached entry of kind "renderer_cells"
RENDERER_CACHE_FORMAT = 1


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


class CachedRendererModel:
    """Predicted RMSE per (strategy, spp rendered), from the cache or the model (built only
    when a cell is missing) and written back after every pass.

    Attributes ``passes`` (model passes run), ``cells_computed``, ``cells_cached`` and
    ``seconds`` (in the model) say what the run cost.
    """

    def __init__(self, envmap, opts, store: AdviseCache, map_key: dict, technique=None):
        self.envmap, self.opts, self.store = envmap, opts, store
        self.technique = technique            # built once for a map (DiffuseModel's)
        self.key = {**map_key, **opts.key(), "model_version": model_version(),
                    "format": RENDERER_CACHE_FORMAT}
        doc = store.load("renderer_cells", self.key, envmap=envmap)     # checked against the map
        self.cells: dict[str, dict] = dict(doc["cells"]) if doc else {}
        self.cells_cached = len(self.cells)
        self.asked: set[str] = set()          # the cells of this run (cached or not)
        self.model: DiffuseModel | None = None
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
            return DiffuseModel(self.envmap, o.record, o.technique_options(), o.model_options(),
                               technique=self.technique)
        m = o.model_options()
        frames = band_frames(max(m.pool, o.normals), (0.0, 90.0), seed=MICROFACET_FRAMES_SEED)
        foot = (None if o.sphere_pixels is None
                else pixel_footprints(*frames, o.sphere_pixels, FOOTPRINT_SIDE,
                                      m.film(o.record)))
        return MicrofacetModel(self.envmap, o.record, o.conductor(), frames,
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
            self.plan = check_renderer_plan(self.envmap, self.opts)   # one line if over budget
            self.model = self._model()
            self.model.quiet = self.opts.quiet
            self.technique = self.model.technique
        rand = self.opts.record.sampler(self.opts.sampler).randomisation
        self.model.progress_label = (
            f"renderer model, {self.stage or 'pass'} {self.passes + 1} (planned ~"
            f"{_duration(self.plan, renderer_passes(rand))} a pass, "
            f"peak ~{format_bytes(self.plan.peak())})")
        res = [p.cell for p in predict_many(
            PREDICTOR, PredictionContext(renderer=self.model),
            [SamplerRule(s, self.opts.sampler, n) for s, n in todo])]
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
        self.store.save("renderer_cells", self.key, {"cells": self.cells})


def _duration(plan, passes: int) -> str:
    """A pass's planned seconds in words (:func:`envfit.advisor._budget.renderer_plan`, of
    ``passes`` passes)."""
    secs = plan.seconds() / passes
    return f"{secs:.0f} s" if secs < 120 else f"{secs / 60:.0f} min"
