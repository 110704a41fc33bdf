r"""Rendering the sphere of :mod:`._sphere` with Mitsuba 3 (``scalar_rgb``), and its measured
shading error.

The scene, one per (sampler, ``mis_compensation``), holds the map, the sphere and six
sensors (:data:`._sphere.VIEWS`):

* ``envmap`` from the map written to a temporary EXR (atomically, a distinct folder per
  :class:`Mitsuba3Sphere`; removed on :meth:`Mitsuba3Sphere.close`). Mitsuba reads the file in
  its own lat-long convention (``src/emitters/envmap.cpp``: ``uv_to_direction``,
  ``eval_spectrum``: rows on the poles, θ = π y/(H − 1), φ texel-centred, +y up, the same
  orientation as envfit's ``up="y"``: :class:`envfit.maps.convention` ``"mitsuba3"``), and
  samples it with its piecewise-bilinear ``Hierarchical2D`` density (``rebuild_distribution``;
  ``mis_compensation`` subtracts the mean luminance first, Karlík et al. 2019);
* ``sphere`` (radius 1 at the origin, an exact analytic shape) with the ``diffuse`` BSDF of
  reflectance 1 (``src/bsdfs/diffuse.cpp``: cosine sampling by the concentric map,
  ``include/mitsuba/core/warp.h``: ``square_to_cosine_hemisphere``);
* six ``orthographic`` sensors (``src/sensors/orthographic.cpp``: the image plane covers
  [−1, 1]² of the camera frame; ``look_at`` from 3v with the view's up, so image right is
  u × v), an ``hdrfilm`` of R × R RGB pixels with the ``box`` filter, and the sampler by its
  Mitsuba name (:data:`SAMPLERS`) with ``sample_count`` = spp and a seed per render.

The integrator is the strategy's in the record (:func:`strategy_integrator`): ``path`` at
its defaults for ``mis`` (``src/integrators/path.cpp``: ``PathIntegrator::sample``, the power
heuristic), ``direct`` (``src/integrators/direct.cpp``: ``DirectIntegrator::sample``) with
``emitter_samples``/``bsdf_samples`` 1/0 for ``map`` and 0/1 for ``brdf``. The reference is two
renders with the ``independent`` sampler and MIS at ``reference_spp``, cached on disk
(:func:`._reference.cached_reference`), shared by every strategy and sampler of the map.

Example
-------
>>> import numpy as np
>>> from envfit.maps import EnvMap
>>> with Mitsuba3Sphere(EnvMap(np.full((8, 16, 3), 0.5)), Mitsuba3Options(resolution=8)) as r:
...     imgs, secs = r.render("brdf", "independent", 4, seed=1)
>>> imgs.shape, round(float(imgs[:, 4, 4].max()), 6)     # BSDF sampling of a constant map: exact
((6, 8, 8, 3), 0.5)
"""
from __future__ import annotations

import shutil
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from envfit.base import ParameterError
from envfit.maps import EnvMap, save_envmap
from envfit.renderers._reference import ReferencePair, cached_reference, map_digest
from envfit.renderers._sphere import (VIEWS, SphereMeasurement, check_strategy,
                                              measurement, sphere_error, sphere_geometry,
                                              view_seeds)

__all__ = ["SAMPLERS", "MITSUBA_SAMPLERS", "strategy_integrator", "Mitsuba3Options",
           "Mitsuba3Sphere", "import_mitsuba", "mitsuba_normals", "roughconductor_bsdf",
           "roughplastic_bsdf", "principled_bsdf", "version", "open_sphere"]

#: Mitsuba 3's sampler plugins measured here
SAMPLERS = ("independent", "stratified", "multijitter", "ldsampler", "orthogonal")
MITSUBA_SAMPLERS = SAMPLERS
#: the variant used: the LLVM variants abort in this machine's LLVM 14/15 code generator
VARIANT = "scalar_rgb"


def strategy_integrator(strategy: str) -> dict:
    """The ``mi.load_dict`` dict of ``strategy``'s integrator: its type and settings in the
    record (:data:`envfit.renderers.mitsuba3.MITSUBA3`), e.g. ``{"type": "path"}`` for
    ``mis``."""
    from envfit.renderers import get_renderer
    s = get_renderer("mitsuba3").strategy(check_strategy(strategy))
    return {"type": s.integrator, **s.settings}


def import_mitsuba():
    """The ``mitsuba`` module with the ``scalar_rgb`` variant set; :class:`ParameterError`
    (one line) if Mitsuba 3 is not installed."""
    try:
        import mitsuba as mi
    except ImportError:
        raise ParameterError("Mitsuba 3 is not installed: pip install mitsuba (or "
                             "pip install 'envfit[test]')") from None
    if mi.variant() != VARIANT:
        mi.set_variant(VARIANT)
    return mi


@dataclass(frozen=True)
class Mitsuba3Options:
    """Settings of the Mitsuba 3 sphere renders.

    Attributes
    ----------
    resolution : pixels per side of each view.
    reference_spp : spp of each of the two reference renders (MIS).
    reference_seed : seed of the reference renders' seeds.
    reference_sampler : the sampler of the reference renders (default ``independent``; any
        of :data:`SAMPLERS` is unbiased and two seeds are two independent randomisations, so
        ``ldsampler`` gives a far less noisy reference at the same spp).
    mis_compensation : the ``envmap`` plugin's ``mis_compensation`` for the renders under
        test (the reference never uses it: it does not change the expectation).
    cache_dir : folder of the reference cache (None: no cache).
    """

    resolution: int = 64
    reference_spp: int = 4096
    reference_seed: int = 20240
    reference_sampler: str = "independent"
    mis_compensation: bool = False
    cache_dir: str | None = None
    bsdf: tuple | None = None

    def __post_init__(self):
        if self.bsdf is not None and (not isinstance(self.bsdf, tuple) or dict(self.bsdf).get(
                "type") not in ("roughconductor", "roughplastic", "principled")):
            raise ParameterError("bsdf must be None (white diffuse), roughconductor_bsdf(...), "
                                 "roughplastic_bsdf(...) or principled_bsdf(...)")
        for name, lo in (("resolution", 4), ("reference_spp", 1)):
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)) or v < lo:
                raise ParameterError(f"{name} must be an integer >= {lo}, got {v!r}")
        _check_sampler(self.reference_sampler)


def roughconductor_bsdf(distribution: str = "ggx", alpha: float = 0.1) -> tuple:
    """The sphere's BSDF for :attr:`Mitsuba3Options.bsdf`: Mitsuba 3's ``roughconductor``
    with ``material="none"`` (Fresnel = 1, a white conductor: the map alone sets the error),
    visible-normal sampling (its default), as sorted (key, value) pairs (hashable).

    >>> dict(roughconductor_bsdf("beckmann", 0.3))["alpha"]
    0.3
    """
    if distribution not in ("ggx", "beckmann"):
        raise ParameterError(f"distribution must be ggx or beckmann, got {distribution!r}")
    return tuple(sorted({"type": "roughconductor", "distribution": distribution,
                         "alpha": float(alpha), "material": "none",
                         "sample_visible": True}.items()))


def roughplastic_bsdf(distribution: str = "ggx", alpha: float = 0.1,
                      diffuse_reflectance: float = 0.5) -> tuple:
    """The sphere's BSDF for :attr:`Mitsuba3Options.bsdf`: Mitsuba 3's ``roughplastic``
    (its defaults otherwise: ``int_ior`` 1.49, ``ext_ior`` 1.000277, specular reflectance 1,
    ``nonlinear`` false, visible-normal sampling), as sorted (key, value) pairs; envfit's
    :class:`envfit.shading.microfacet.RoughPlastic` is the same BSDF.

    >>> dict(roughplastic_bsdf("ggx", 0.2))["diffuse_reflectance"]
    0.5
    """
    if distribution not in ("ggx", "beckmann"):
        raise ParameterError(f"distribution must be ggx or beckmann, got {distribution!r}")
    return tuple(sorted({"type": "roughplastic", "distribution": distribution,
                         "alpha": float(alpha),
                         "diffuse_reflectance": float(diffuse_reflectance),
                         "sample_visible": True}.items()))


def principled_bsdf(roughness: float = 0.5, **params) -> tuple:
    """The sphere's BSDF for :attr:`Mitsuba3Options.bsdf`: Mitsuba 3's ``principled`` with
    ``roughness`` and ``params`` (among ``PRINCIPLED_PARAMS``: a grey ``base_color``,
    ``metallic``, ``specular``, …; the plugin's defaults otherwise), as sorted (key, value)
    pairs; envfit's :class:`envfit.shading.microfacet.Principled` is the same BSDF.

    >>> dict(principled_bsdf(0.3, metallic=1.0))["metallic"]
    1.0
    """
    from envfit.renderers.mitsuba3._bsdf import PRINCIPLED_PARAMS, bsdf
    bsdf("principled", float(roughness) ** 2, **params)     # the same checks: one line
    return tuple(sorted({"type": "principled", "roughness": float(roughness),
                         **{k: float(v) for k, v in params.items()
                            if k in PRINCIPLED_PARAMS}}.items()))


def _sensor(mi, view, resolution: int, sampler: str) -> dict:
    v = np.asarray(view.axis)
    return {"type": "orthographic",
            "to_world": mi.ScalarTransform4f().look_at(origin=(3.0 * v).tolist(),
                                                       target=[0, 0, 0], up=list(view.up)),
            "film": {"type": "hdrfilm", "width": resolution, "height": resolution,
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": sampler, "sample_count": 4}}


def _check_sampler(sampler: str) -> str:
    if sampler not in SAMPLERS:
        raise ParameterError(f"Mitsuba 3 sampler must be one of {', '.join(SAMPLERS)}; "
                             f"got {sampler!r}")
    return sampler


def _check_spp(spp) -> int:
    if not isinstance(spp, (int, np.integer)) or spp < 1:
        raise ParameterError(f"spp must be an integer >= 1, got {spp!r}")
    return int(spp)


class Mitsuba3Sphere:
    """The sphere of :mod:`._sphere` in Mitsuba 3 on one map (module docstring); a context
    manager (the temporary map file is removed on exit).

    Parameters
    ----------
    envmap : the map (written as it is: Mitsuba reads it in its own convention, module
        docstring); one channel is repeated to RGB.
    options : :class:`Mitsuba3Options`.
    """

    renderer = "mitsuba3"

    def __init__(self, envmap: EnvMap, options: Mitsuba3Options | None = None):
        self.mi = import_mitsuba()
        self.options = options or Mitsuba3Options()
        data = np.asarray(envmap.data, dtype=np.float32)
        if data.shape[2] == 1:
            data = np.repeat(data, 3, axis=2)
        elif data.shape[2] != 3:
            raise ParameterError(f"Mitsuba renders RGB maps; this one has {data.shape[2]} channels")
        self.envmap = EnvMap(data, up=envmap.up, name=envmap.name)
        self.digest = map_digest(self.envmap)
        self.geometry = sphere_geometry(self.options.resolution)
        self._dir = Path(tempfile.mkdtemp(prefix="envfit-mitsuba3-"))
        self._path = save_envmap(self._dir / f"map-{self.digest[:16]}.exr", self.envmap)
        self._scenes: dict = {}
        self._integrators: dict = {}

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self) -> None:
        """Remove the temporary map file."""
        shutil.rmtree(self._dir, ignore_errors=True)
        self._scenes.clear()

    def _scene(self, sampler: str, compensation: bool):
        key = (sampler, bool(compensation))
        if key not in self._scenes:
            mi = self.mi
            bsdf = dict(self.options.bsdf) if self.options.bsdf else \
                {"type": "diffuse", "reflectance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}
            d = {"type": "scene",
                 "sphere": {"type": "sphere", "bsdf": bsdf},
                 "env": {"type": "envmap", "filename": str(self._path),
                         "mis_compensation": bool(compensation)}}
            for k, view in enumerate(VIEWS):
                d[f"sensor{k}"] = _sensor(mi, view, self.options.resolution, sampler)
            self._scenes[key] = mi.load_dict(d)
        return self._scenes[key]

    def _integrator(self, strategy: str):
        if strategy not in self._integrators:
            self._integrators[strategy] = self.mi.load_dict(strategy_integrator(strategy))
        return self._integrators[strategy]

    def spp_used(self, sampler: str, spp: int) -> int:
        """The sample count Mitsuba's ``sampler`` actually takes for ``spp`` (it rounds, e.g.
        ``ldsampler`` to a power of two, ``orthogonal`` to p² with p prime): the record's
        rounding, read from Mitsuba's ``set_sample_count`` and tested against it
        (``tests/test_presets_mitsuba3.py``), so that Mitsuba never warns that it rounds."""
        from envfit.renderers import get_renderer
        return get_renderer("mitsuba3").sampler(_check_sampler(sampler)).spp(_check_spp(spp))

    def render(self, strategy: str, sampler: str, spp: int, seed, *,
               compensation: bool | None = None) -> tuple[np.ndarray, list[float]]:
        """The six views (6, R, R, 3) and the seconds of each render; ``seed`` (an int or a
        Generator) draws one random seed per view (:func:`._sphere.view_seeds`)."""
        check_strategy(strategy)
        spp = self.spp_used(sampler, spp)               # as the sampler rounds it: no warning
        comp = self.options.mis_compensation if compensation is None else compensation
        scene = self._scene(_check_sampler(sampler), comp)
        integ = self._integrator(strategy)
        images, secs = [], []
        for k, s in enumerate(view_seeds(seed)):
            t = time.perf_counter()
            img = self.mi.render(scene, sensor=k, integrator=integ, spp=spp, seed=s)
            images.append(np.array(img, dtype=np.float64))
            secs.append(time.perf_counter() - t)
        return np.stack(images), secs

    def reference(self) -> ReferencePair:
        """The two reference renders (MIS, ``reference_sampler``, ``reference_spp``), from
        the cache when present."""
        o = self.options
        key = {"renderer": self.renderer, "version": self.mi.__version__, "variant": VARIANT,
               "map": self.digest, "spp": o.reference_spp, "resolution": o.resolution,
               "seed": o.reference_seed, "strategy": "mis", "sampler": o.reference_sampler}
        if o.bsdf:                      # keys of the diffuse sphere's references unchanged
            key["bsdf"] = dict(o.bsdf)

        def render():
            rng = np.random.default_rng(o.reference_seed)
            a, ta = self.render("mis", o.reference_sampler, o.reference_spp, rng,
                                compensation=False)
            b, tb = self.render("mis", o.reference_sampler, o.reference_spp, rng,
                                compensation=False)
            return a, b, sum(ta) + sum(tb)

        return cached_reference(key, render, o.cache_dir)

    def measure(self, strategy: str, sampler: str, spp: int, *, seed=0,
                reference: ReferencePair | None = None) -> SphereMeasurement:
        """The measured RMSE over normals of one configuration (:class:`SphereMeasurement`)
        against :meth:`reference` (or the given pair); ``seed`` draws the render seeds and
        the bootstrap."""
        ref = self.reference() if reference is None else reference
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        imgs, secs = self.render(strategy, sampler, spp, rng)
        err = sphere_error(imgs, ref.a, ref.b, self.geometry, seed=rng)
        opts = {"mis_compensation": bool(self.options.mis_compensation), "variant": VARIANT,
                "integrator": strategy_integrator(strategy)["type"], "filter": "box"}
        return measurement(err, spp=spp, renderer=self.renderer, sampler=sampler,
                           strategy=strategy, reference_spp=self.options.reference_spp,
                           view_seconds=secs, resolution=self.options.resolution,
                           spp_used=self.spp_used(sampler, spp), options=opts)


def mitsuba_normals(resolution: int, spp: int = 16) -> np.ndarray:
    """World normals (6, R, R, 3) of the sphere per pixel of each view, rendered by Mitsuba's
    ``aov`` integrator (``nn:sh_normal``, box filter: the pixel's mean normal), for checking
    :func:`._sphere.view_normals`; background pixels are 0."""
    mi = import_mitsuba()
    out = []
    for view in VIEWS:
        scene = mi.load_dict({"type": "scene", "sphere": {"type": "sphere"},
                              "sensor": _sensor(mi, view, int(resolution), "independent"),
                              "integrator": {"type": "aov", "aovs": "nn:sh_normal"}})
        out.append(np.array(mi.render(scene, spp=int(spp), seed=1), dtype=np.float64)[..., :3])
    return np.stack(out)


def options_dict(options: Mitsuba3Options) -> dict:
    """The options as a plain dict (for JSON)."""
    return asdict(options)


# The harness protocol (``Renderer.harness``): what ``validate --renderer`` calls.

def version() -> str:
    """Mitsuba's version and variant; one-line ParameterError where it is not installed."""
    return f"Mitsuba {import_mitsuba().__version__} ({VARIANT})"


def open_sphere(envmap, brdf: str | None, alpha: float | None, bsdf_params=None,
                **common) -> "Mitsuba3Sphere":
    """The sphere of envfit's measurement with ``brdf`` (None: white diffuse; ``ggx``,
    ``beckmann``: a white rough conductor; ``roughplastic``: a GGX rough plastic;
    ``principled``: the principled BSDF with ``bsdf_params``) of roughness ``alpha``;
    ``common``: :class:`Mitsuba3Options`' resolution, reference_spp, cache_dir. The
    reference renders with ``ldsampler``."""
    from envfit.renderers.mitsuba3._bsdf import PRINCIPLED_ROUGHNESS
    bsdf = (None if brdf is None else
            roughplastic_bsdf("ggx", alpha) if brdf == "roughplastic" else
            principled_bsdf(PRINCIPLED_ROUGHNESS.from_alpha(alpha), **(bsdf_params or {}))
            if brdf == "principled" else roughconductor_bsdf(brdf, alpha))
    return Mitsuba3Sphere(envmap, Mitsuba3Options(**common, bsdf=bsdf,
                                                  reference_sampler="ldsampler"))
