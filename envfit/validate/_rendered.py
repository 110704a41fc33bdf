r"""``envfit validate MAP --renderer NAME`` (a renderer with a harness,
:func:`rendered_renderers`): the renderer itself renders the sphere of
:mod:`envfit.renderers`, and its measured error is set beside the renderer model's
prediction, cell by cell (sampler × strategy × spp) — the check a renderer engineer runs
before trusting an ``advise`` answer for their renderer.

The steps (:func:`render_validation`):

1. **The model** (:func:`_model`): the renderer's noise model of the map as the renderer reads
   the file — :class:`envfit.predict.renderer.DiffuseModel` over uniform normals for the white
   diffuse sphere (the ``cube`` layout: each pixel in the view nearest its normal, weighted
   1/(n·v)); :class:`envfit.predict.renderer.MicrofacetModel` over frames (normal, view)
   importance-sampled from every rendered pixel for a white rough conductor (the ``disk`` layout: every
   pixel of each view's disk, the view angles an orthographic camera sees), with each pixel's
   footprint (:func:`envfit.predict.renderer.pixel_footprints`).
2. **The renders** (:func:`_session`): the renderer's harness
   (:attr:`envfit.renderers.Renderer.harness`, the renderer's own diffuse, conductor or
   plastic BSDF as its folder says), six orthographic views of ``resolution`` ×
   ``resolution`` pixels; the reference is two renders at
   ``reference_spp`` (cached with ``cache_dir``).
3. **Each cell** (:func:`measure_cell`): the RMSE over the kept pixels against the
   reference, its own variance subtracted, with a bootstrap 95 % interval over pixels
   (:func:`envfit.renderers.sphere_error`); for a conductor also per view-angle band
   (θ_o in 0–30°, 30–60°, 60–80°). A cell is **inside** when the prediction lies in
   [0.8 × low, 1.25 × high] (the acceptance of the real-renderer issues).

Example
-------
>>> opts = RenderValidationOptions("mitsuba3", brdf="ggx", alpha=0.3, spp=(16,))
>>> opts.samplers, opts.strategies
(('independent', 'ldsampler'), ('brdf', 'map', 'mis'))
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

import numpy as np

from envfit.base import ParameterError

__all__ = ["RenderValidationOptions", "RenderValidation", "render_validation", "measure_cell",
           "is_inside", "rendered_summary_lines", "RENDERED_BRDFS", "rendered_renderers"]

#: the BSDFs of the sphere: white diffuse, a white rough conductor (Fresnel 1), a rough
#: plastic (:class:`envfit.shading.microfacet.RoughPlastic`: GGX coat, η = 1.49, diffuse
#: reflectance 0.5) or a principled BSDF (:class:`envfit.shading.microfacet.Principled`)
RENDERED_BRDFS = ("diffuse", "ggx", "beckmann", "roughplastic", "multiggx", "principled")
#: a BSDF in the refusals' words
_BSDF_WORDS = {"multiggx": "Multiscatter GGX (the Principled and Glossy BSDF nodes' default)"}
_BSDF_NOUNS = {"roughplastic": "rough plastic", "principled": "principled BSDF",
               "ggx": "GGX conductor",
               "beckmann": "Beckmann conductor", "multiggx": "Multiscatter GGX conductor"}
#: θ_o bands of a conductor's check (degrees)
BAND_EDGES = ((0.0, 30.0), (30.0, 60.0), (60.0, 80.0))
#: the model's frames by default: a microfacet BSDF's (normal, view), the diffuse normals
MICROFACET_FRAMES, DIFFUSE_FRAMES = 256, 64


def rendered_renderers() -> dict:
    """The renderers ``validate`` renders with (those with a harness), each → its samplers
    rendered by default (:attr:`~envfit.renderers.Renderer.render_samplers`)."""
    from envfit.renderers import RENDERERS
    return {n: r.render_samplers for n, r in RENDERERS.items() if r.render_samplers}


def is_inside(predicted: float, low: float, high: float) -> bool:
    """The acceptance: ``predicted`` in [0.8 × low, 1.25 × high] of the measured interval.

    >>> is_inside(1.0, 1.1, 1.3), is_inside(1.0, 1.3, 1.5)
    (True, False)
    """
    return bool(0.8 * low <= predicted <= 1.25 * high)


def _positive_ints(name: str, values, lo: int) -> tuple:
    out = tuple(values)
    if not out or any(not isinstance(v, (int, np.integer)) or v < lo for v in out):
        raise ParameterError(f"{name} must be integers >= {lo}, got {values!r}")
    return tuple(int(v) for v in out)


@dataclass(frozen=True)
class RenderValidationOptions:
    """What to render and predict.

    Attributes
    ----------
    renderer : a renderer with a harness (a key of :func:`rendered_renderers`).
    brdf : ``"diffuse"``, ``"ggx"`` or ``"beckmann"`` (a white conductor; needs ``alpha``), or
        ``"roughplastic"`` (a renderer whose record's ``microfacet`` lists it: the rough plastic
        with a GGX coat of ``alpha``; modelled under the samplers of
        :data:`envfit.defaults.PLASTIC_SAMPLERS`).
    alpha : the microfacet roughness α (the harness sets the renderer's own roughness
        parameter for it, as the renderer's folder says); None with a BSDF whose roughness
        has a default (:attr:`~envfit.renderers.Renderer.bsdf_params`): that one.
    bsdf_params : the BSDF's own parameters (a principled BSDF's ``metallic``, …), where it
        has them; the rest keep the renderer's defaults.
    samplers : the renderer's samplers by their own names (default :data:`RENDERERS`).
    strategies : among ``brdf``, ``map``, ``mis`` that the renderer renders (default: all of
        them that the record's strategies call ``renderable``).
    spp : samples per pixel of the cells.
    resolution : pixels per side of each of the six views.
    reference_spp : spp of each of the two reference renders.
    frames : the model's frames: a conductor's or plastic's (normal, view) importance-sampled
        from the pixels (default 256: the band values are means over
        the frames in each band, and 64 frames put about 14 in 60–80°, whose sampling error
        read 1.4–1.6× the render on city and forest), the diffuse sphere's normals (default
        64).
    footprint : normals per pixel side in the model (1: the pixel centre); each rendered
        pixel averages the normals it spans (:mod:`envfit.predict.renderer._footprint`).
    max_level : the model's finest grid level (10 resolves nets to 512 spp, 11 to 1024).
    seed : the render seeds, the frames and the bootstrap.
    cache_dir : folder of the reference cache (None: none).
    """

    renderer: str
    brdf: str = "diffuse"
    alpha: float | None = None
    bsdf_params: dict | None = None
    samplers: tuple = ()
    strategies: tuple = ()
    spp: tuple = (16, 64)
    resolution: int = 32
    reference_spp: int = 1024
    frames: int | None = None
    footprint: int = 2
    max_level: int = 9
    seed: int = 0
    cache_dir: str | None = None

    def __post_init__(self):
        from envfit.renderers import RENDERERS, get_renderer
        rendered = rendered_renderers()
        if self.renderer not in rendered:
            raise ParameterError(f"validate renders with {' or '.join(rendered)}; got "
                                 f"{self.renderer!r}")
        if self.brdf not in RENDERED_BRDFS:
            raise ParameterError(f"--brdf with --renderer {self.renderer} must be one of "
                                 f"{', '.join(RENDERED_BRDFS)}; got {self.brdf!r}")
        p = get_renderer(self.renderer)
        owners = [r for r in RENDERERS.values() if self.brdf in r.microfacet]
        if self.microfacet and self.brdf not in p.microfacet and len(owners) == 1:
            raise ParameterError(f"--brdf {self.brdf} is {owners[0].possessive} "
                                 f"{_BSDF_WORDS.get(self.brdf, self.brdf)}: --renderer "
                                 f"{owners[0].name}")
        defaults = p.bsdf_params.get(self.brdf, {})
        if self.alpha is None and "roughness" in defaults:
            object.__setattr__(self, "alpha",
                               p.roughness_of(self.brdf).to_alpha(defaults["roughness"]))
        if (self.brdf == "diffuse") != (self.alpha is None):
            raise ParameterError(f"--roughness goes with a microfacet --brdf "
                                 f"({', '.join(RENDERED_BRDFS[1:])}), as --alpha does (and "
                                 f"they need one of the two unless the BSDF's roughness has a "
                                 f"default)")
        object.__setattr__(self, "bsdf_params", dict(self.bsdf_params or {}))
        if self.bsdf_params and not defaults:
            raise ParameterError(f"--bsdf-param is for a BSDF with parameters of its own, not "
                                 f"--brdf {self.brdf} with --renderer {self.renderer}")
        built = None
        if self.microfacet:         # an unknown parameter, a case not modelled: one line
            built = p.bsdf(self.brdf, self.alpha, **self.bsdf_params)
        samplers = tuple(self.samplers) or rendered[self.renderer]
        for s in samplers:
            p.sampler(s)
        if hasattr(built, "sample_square"):     # two lobes: the lobe choice's samplers
            from envfit.predict.renderer import lobe_choice_modelled
            if not self.samplers:               # the defaults the lobe choice covers
                samplers = tuple(s for s in samplers if lobe_choice_modelled(p.sampler(s)))
            odd = [s for s in samplers if not lobe_choice_modelled(p.sampler(s))]
            if odd:
                ok = [n for n, x in p.samplers.items() if lobe_choice_modelled(x)]
                raise ParameterError(f"{p.possessive} {p.bsdf_names.get(self.brdf, self.brdf)} "
                                     f"with these parameters picks one of two lobes by a "
                                     f"number the {odd[0]} sampler draws in a way envfit does "
                                     f"not model: --samplers {','.join(ok)}")
        modelled = p.microfacet.get(self.brdf) if self.microfacet else None
        odd = [s for s in samplers if modelled is not None and s not in modelled]
        if odd:
            raise ParameterError(f"the {_BSDF_NOUNS.get(self.brdf, self.brdf)} is modelled "
                                 f"for {p.possessive} {', '.join(modelled)} samplers"
                                 f"{p.microfacet_why.get(self.brdf, '')}; got {odd[0]}")
        renderable = tuple(s for s in ("brdf", "map", "mis") if p.strategy(s).renderable)
        strategies = tuple(self.strategies) or renderable
        bad = [s for s in strategies if s not in renderable]
        if bad:
            raise ParameterError(f"--strategies: {self.renderer} renders the strategies "
                                 f"{', '.join(renderable)}; got {', '.join(bad)}")
        if self.frames is None:
            object.__setattr__(self, "frames", MICROFACET_FRAMES if self.microfacet
                               else DIFFUSE_FRAMES)
        object.__setattr__(self, "samplers", samplers)
        object.__setattr__(self, "strategies", strategies)
        object.__setattr__(self, "spp", _positive_ints("spp", self.spp, 1))
        for name, lo in (("resolution", 8), ("reference_spp", 4), ("frames", 6),
                         ("footprint", 1), ("max_level", 4)):
            _positive_ints(name, (getattr(self, name),), lo)
        if self.max_level > 11:
            raise ParameterError(f"max_level must be at most 11, got {self.max_level}")
        if self.footprint > 8:
            raise ParameterError(f"footprint must be at most 8, got {self.footprint}")

    @property
    def microfacet(self) -> bool:
        return self.brdf != "diffuse"

    @property
    def cells(self) -> list:
        """(sampler, strategy, spp) of every cell, in render order."""
        return [(s, st, n) for s in self.samplers for st in self.strategies for n in self.spp]

    def planned(self) -> list:
        """(strategy, sampler, spp the renderer takes) of every cell: the model's plan."""
        from envfit.renderers import get_renderer
        p = get_renderer(self.renderer)
        return [(st, s, int(p.sampler(s).rounding(n))) for s, st, n in self.cells]


@dataclass
class RenderValidation:
    """The rendered check of one map: ``rows`` (one dict per cell: ``sampler``,
    ``strategy``, ``spp``, ``spp_used``, ``measured_rmse``, ``low``, ``high``,
    ``predicted``, ``ratio`` = predicted/measured, ``inside``, ``mean_offset``, ``bands``;
    a conductor's also ``predicted_rel_se``, and per band ``predicted_frames`` and
    ``predicted_rel_se``: the frames' sampling error of the prediction),
    the options, and the seconds of the model, the reference and the renders."""

    map_name: str
    options: RenderValidationOptions
    rows: list = field(default_factory=list)
    model_seconds: float = 0.0
    reference_seconds: float = 0.0
    render_seconds: float = 0.0
    renderer_version: str = ""

    @property
    def inside(self) -> int:
        return sum(bool(r["inside"]) for r in self.rows)

    @property
    def median_ratio(self) -> float:
        return float(np.median([r["ratio"] for r in self.rows])) if self.rows else float("nan")

    def band_summary(self) -> dict:
        """Per band: (cells inside, cells, median predicted/measured)."""
        out = {}
        for lo, hi in BAND_EDGES:
            key = f"{lo:g}-{hi:g}"
            cells = [r["bands"][key] for r in self.rows if key in r.get("bands", {})]
            if cells:
                out[key] = (sum(c["inside"] for c in cells), len(cells),
                            float(np.median([c["predicted"] / c["measured_rmse"]
                                             for c in cells])))
        return out

    def to_dict(self) -> dict:
        return {"map": self.map_name, "options": asdict(self.options), "rows": self.rows,
                "inside": self.inside, "cells": len(self.rows),
                "median_ratio": self.median_ratio,
                "bands": {k: dict(zip(("inside", "cells", "median_ratio"), v))
                          for k, v in self.band_summary().items()},
                "seconds": {"model": self.model_seconds, "reference": self.reference_seconds,
                            "renders": self.render_seconds},
                "renderer_version": self.renderer_version}


def check_renderer(renderer: str) -> str:
    """The renderer's version (its harness's ``version()``); one-line
    :class:`ParameterError` when it is not installed."""
    from envfit.renderers import get_renderer
    return get_renderer(renderer).harness_module().version()


def _model(envmap, options: RenderValidationOptions):
    """The renderer's noise model of the map as the renderer reads its file (step 1)."""
    from envfit.maps import EnvMap
    from envfit.renderers import VIEWS, sphere_geometry
    from envfit.predict.renderer import (MicrofacetModel, DiffuseModel, RendererModelOptions,
                                         pixel_footprints, pixel_frames)
    from envfit.renderers import BOX_FILTER, get_renderer
    env = EnvMap(envmap.data, up="y", name=envmap.name)
    p, level = get_renderer(options.renderer), options.max_level
    if not options.microfacet:                      # the harnesses render the box filter
        return DiffuseModel(env, p, {}, RendererModelOptions(
            normals=options.frames, max_level=level, footprint_side=options.footprint,
            sphere_pixels=options.resolution if options.footprint > 1 else None,
            pixel_filter=BOX_FILTER))
    g = sphere_geometry(options.resolution, "disk")
    n, v, _ = pixel_frames(g, VIEWS, len(VIEWS) * g.kept, seed=options.seed)   # every pixel
    foot = (pixel_footprints(n, v, options.resolution, options.footprint)
            if options.footprint > 1 else None)
    return MicrofacetModel(env, p, p.bsdf(options.brdf, options.alpha, **options.bsdf_params),
                           (n, v),
                           options=RendererModelOptions(max_level=level, pixel_filter=BOX_FILTER),
                           select=options.frames, footprints=foot)


def _session(envmap, options: RenderValidationOptions):
    """The renderer's sphere with the options' BSDF (step 2): its harness's
    ``open_sphere``."""
    from envfit.renderers import get_renderer
    harness = get_renderer(options.renderer).harness_module()
    params = {"bsdf_params": options.bsdf_params} if options.bsdf_params else {}
    return harness.open_sphere(envmap, options.brdf if options.microfacet else None,
                               options.alpha, **params, resolution=options.resolution,
                               reference_spp=options.reference_spp,
                               cache_dir=options.cache_dir)


def measure_cell(sphere, reference, model, cell, rng, geometry) -> dict:
    """One rendered cell (step 3): render ``cell`` = (sampler, strategy, spp) with
    ``sphere``, measure it over ``geometry``'s kept pixels against ``reference`` and, where
    ``model`` predicts bands (a conductor), per view-angle band."""
    from envfit.renderers import sphere_error
    sampler, strategy, spp = cell
    t = time.perf_counter()
    images, _ = sphere.render(strategy, sampler, spp, rng)
    m = sphere_error(images, reference.a, reference.b, geometry, seed=rng)
    used = sphere.spp_used(sampler, spp)
    p = float(model.predict(strategy, sampler, used).rmse)
    row = {"sampler": sampler, "strategy": strategy, "spp": int(spp), "spp_used": int(used),
           "measured_rmse": m.rmse, "low": m.low, "high": m.high, "predicted": p,
           "ratio": p / m.rmse if m.rmse > 0 else float("inf"),
           "inside": is_inside(p, m.low, m.high), "mean_offset": m.mean_offset, "bands": {}}
    if hasattr(model, "predict_bands"):
        theta = np.degrees(np.arccos(np.clip(geometry.z, -1.0, 1.0)))
        spread = model.predict_band_errors(strategy, sampler, used)
        row["predicted_rel_se"] = spread["all"]["rel_se"]
        for band, pb in model.predict_bands(strategy, sampler, used).items():
            lo, hi = (float(x) for x in band.split("-"))
            mask = (theta >= lo) & (theta < hi)
            if np.any(mask & geometry.keep):
                e = sphere_error(images, reference.a, reference.b, geometry, seed=rng,
                                 mask=mask)
                row["bands"][band] = {"measured_rmse": e.rmse, "low": e.low, "high": e.high,
                                      "predicted": float(pb),
                                      "predicted_frames": spread[band]["frames"],
                                      "predicted_rel_se": spread[band]["rel_se"],
                                      "inside": is_inside(pb, e.low, e.high)}
    row["seconds"] = time.perf_counter() - t
    return row


def render_validation(envmap, options: RenderValidationOptions, *, progress=None,
                      on_row=None) -> RenderValidation:
    """Render and predict every cell of ``options`` on ``envmap`` (module docstring).

    ``progress`` (optional) is called with each finished step's name; ``on_row`` with each
    finished cell's row (e.g. to write it). The renderer is imported first: a missing one
    is a one-line :class:`ParameterError` before any work.
    """
    from envfit.renderers import sphere_geometry
    result = RenderValidation(envmap.name or "map", options,
                              renderer_version=check_renderer(options.renderer))
    step = progress or (lambda name: None)
    t = time.perf_counter()
    model = _model(envmap, options)
    model.predict_many(options.planned())
    result.model_seconds = time.perf_counter() - t
    step("model")
    geometry = sphere_geometry(options.resolution, "disk" if options.microfacet else "cube")
    rng = np.random.default_rng([options.seed, 1])
    with _session(envmap, options) as sphere:
        t = time.perf_counter()
        ref = sphere.reference()
        result.reference_seconds = time.perf_counter() - t
        step("reference")
        for cell in options.cells:
            result.rows.append(measure_cell(sphere, ref, model, cell, rng, geometry))
            result.render_seconds += result.rows[-1]["seconds"]
            if on_row is not None:
                on_row(result.rows[-1])
            step("cell")
    return result


def rendered_summary_lines(result: RenderValidation) -> list[str]:
    """The printed answer: what was rendered, the share of cells inside and the median
    ratio, one line per cell, then per view-angle band (a conductor)."""
    o = result.options
    bsdf = ("white diffuse" if not o.microfacet else
            f"rough plastic, GGX alpha {o.alpha:g}, eta 1.49, diffuse 0.5"
            if o.brdf == "roughplastic" else
            f"principled, GGX alpha {o.alpha:g}"
            + "".join(f", {k} {v:g}" for k, v in o.bsdf_params.items())
            + "; the renderer's defaults otherwise"
            if o.brdf == "principled" else
            f"white {'GGX' if o.brdf == 'ggx' else 'Beckmann'} conductor, alpha {o.alpha:g}")
    n = len(result.rows)
    from envfit.renderers import get_renderer
    name = result.renderer_version or get_renderer(o.renderer).display
    lines = [f"{name} rendered the sphere ({bsdf}): "
             f"6 views of {o.resolution}x{o.resolution} pixels, reference 2 x "
             f"{o.reference_spp} spp",
             f"{result.inside} of {n} cells inside [0.8 x low, 1.25 x high] of the measured "
             f"95 % interval; median predicted/measured {result.median_ratio:.3f}",
             f"  {'sampler':16s} {'strategy':8s} {'spp':>5s} {'measured':>10s} "
             f"{'95 % interval':>23s} {'predicted':>10s} {'ratio':>6s} inside"]
    for r in result.rows:
        lines.append(f"  {r['sampler']:16s} {r['strategy']:8s} {r['spp_used']:5d} "
                     f"{r['measured_rmse']:10.4g} [{r['low']:10.4g}, {r['high']:10.4g}] "
                     f"{r['predicted']:10.4g} {r['ratio']:6.3f} "
                     f"{'yes' if r['inside'] else 'NO'}")
    for band, (k, m, med) in result.band_summary().items():
        lines.append(f"view angle {band} deg: {k} of {m} cells inside; median "
                     f"predicted/measured {med:.3f}")
    return lines
