r"""Every default number and name list of envfit, defined once and imported, never re-typed.

The base layer (``tests/test_architecture.py``): imports only :mod:`envfit.theory`, so every
sub-package may import it. theory keeps its own defaults (theory never imports envfit); the
ones both share are taken from there (:data:`DEFAULT_SHININESS` is
:data:`envfit.theory._brdf.PAPER_SHININESS`).

Vocabularies (registries; a module checking a name imports these):

* point sets: :data:`envfit.theory._pointsets.POINTSETS` (the registry), :data:`ALL_POINTSETS`
  its names in registry order (also the seed index of ``envfit validate``'s cells);
* BRDFs: :data:`BRDFS` (:data:`envfit.theory._brdf.BRDFS`); weightings: :data:`WEIGHTINGS`
  (:data:`envfit.theory._weights.WEIGHTINGS`);
* renderer strategies: :data:`envfit.sampling._rules.STRATEGIES`; lat-long conventions:
  :data:`envfit.maps._conventions.CONVENTIONS`; value scales: :data:`envfit.maps._scales.SCALES`
  (those registries carry behaviour and stay with it).

>>> DEFAULT_SHININESS, RENDERER_GRID, ADVISE_SPECTRUM_AXES, VALIDATE_SPECTRUM_AXES
(30.0, 512, 32, 256)
>>> DEFAULT_POINTSETS
('sf', 'sobol', 'lp', 'random', 'jitter')
"""
from __future__ import annotations

from envfit.theory import BRDFS, PAPER_SHININESS
from envfit.theory import POINTSETS
from envfit.theory import WEIGHTINGS

__all__ = ["BRDFS", "WEIGHTINGS", "ALL_POINTSETS", "DEFAULT_POINTSETS", "DEFAULT_SHININESS",
           "RENDERER_GRID", "ADVISE_SPECTRUM_AXES", "VALIDATE_SPECTRUM_AXES",
           "QUICK_RENDERER_GRID", "QUICK_SPECTRUM_AXES", "REFERENCE_SPECTRUM_AXES",
           "ADVISE_RENDERER_POINTSETS", "VALIDATE_RENDERER_POINTSETS", "VALIDATE_N", "QUICK_N",
           "RENDERER_AXES_START", "RENDERER_MAX_AXES", "UPS", "SOLVERS", "FIT_METHODS",
           "EXECUTORS", "PREDICTOR_CHOICES", "MICROFACET_BSDFS", "MICROFACET_FRAMES_SEED",
           "FOOTPRINT_SIDE", "BAND_MIN_FRAMES", "BAND_BOOTSTRAP_RESAMPLES", "BAND_BOOTSTRAP_SEED",
           "ADVISE_ALPHA", "MICROFACET_BSDF_WORDS", "TWO_LOBE_BSDFS"]

# ----------------------------------------------------------------------------- vocabularies

#: the microfacet BSDFs a renderer's model shades (``envfit advise --renderer R --brdf``): white
#: conductors (:class:`envfit.shading.microfacet.Conductor`), Mitsuba 3's rough plastic
#: (:class:`envfit.shading.microfacet.RoughPlastic`, a GGX coat) and principled BSDF
#: (:class:`envfit.shading.microfacet.Principled`; Cycles': its metallic closure, an F82
#: :class:`~envfit.shading.microfacet.Conductor`)
MICROFACET_BSDFS = ("ggx", "beckmann", "roughplastic", "multiggx", "principled")
#: the microfacet BSDFs of two lobes, one picked per BSDF sample by a number of its own
#: (their frames' proxies are numpy; a net is searched at its powers of two)
TWO_LOBE_BSDFS = ("roughplastic", "principled")
#: each of :data:`MICROFACET_BSDFS` in words (``advise --help``; the same keys, in order)
MICROFACET_BSDF_WORDS = {"ggx": "white GGX conductor; Mitsuba 3, pbrt-v4, Cycles",
                         "beckmann": "white Beckmann conductor; Mitsuba 3, Cycles",
                         "roughplastic": "Mitsuba 3's roughplastic",
                         "multiggx": "Cycles' Multiscatter GGX",
                         "principled": "Mitsuba 3's principled, Cycles' Principled BSDF (metallic "
                                       "1); --bsdf-param NAME=VALUE"}
#: the microfacet alpha the advice's model takes (``advise --renderer R --roughness``, in
#: each renderer's own units: its record's roughness convention,
#: :meth:`envfit.renderers.RoughnessConvention.range`)
ADVISE_ALPHA = (0.05, 1.0)
#: the renderer answer's target when none is given: 1 % of the map's mean radiance
DEFAULT_TARGET_RELATIVE = 0.01
#: a strategy other than the renderer's default is recommended when the default needs at least
#: this many times as many samples traced per pixel to meet the target
SWITCH_FACTOR = 10
#: Mitsuba 3's samplers under which the rough plastic's BSDF sampling is modelled (its lobe
#: choice is a 1-D number: i.i.d., or stratified in a random order;
#: :mod:`envfit.predict.renderer._lobe_parts`): not ``orthogonal``
PLASTIC_SAMPLERS = ("independent", "stratified", "multijitter", "ldsampler")
#: the seed of the advice's frames (normal, view) for a microfacet BSDF
#: (:func:`envfit.predict.renderer.band_frames`): fixed, so that an answer is reproducible
MICROFACET_FRAMES_SEED = 20251
#: the pixel footprint of ``advise --sphere-pixels``: side × side normals over each pixel
#: (:func:`envfit.predict.renderer.pixel_footprints`; the model's tables cost side² times)
FOOTPRINT_SIDE = 2
#: the fewest frames behind a view-angle band's interval (and each band's, behind the whole
#: sphere's): below it ``advise`` withholds the band (:mod:`envfit.predict.renderer._bands`).
#: Simulated (``tests/test_advise_bands.py``), the expanded percentile bootstrap of a mean of
#: K i.i.d. draws covers it 0.93-0.96 of the time at K = 8 (normal, gamma(2) draws), 0.85 at
#: K = 4; ``--renderer-normals`` 48 (the default) gives each band at least 48 // 6 = 8 frames
BAND_MIN_FRAMES = 8
#: the bootstrap's resamples of the frames per band and its generator's seed (reproducible)
BAND_BOOTSTRAP_RESAMPLES = 2000
BAND_BOOTSTRAP_SEED = 20252

#: the accepted values of ``up``, the world axis that row 0 of a map touches
#: (:mod:`envfit.maps._latlong`; ``--up``)
UPS = ("y", "z", "x")
#: the interpolator's linear solvers (:class:`envfit.sobolev._interpolation.SobolevInterpolator`;
#: ``table2 --solver``)
SOLVERS = ("auto", "cholesky", "iterative")
#: the smoothness fit's criteria (:func:`envfit.fit._smoothness.fit_smoothness`; ``--fit-method``)
FIT_METHODS = ("likelihood", "loo", "holdout")
#: the batch executors (:mod:`envfit.batch._executor`; ``--executor``)
EXECUTORS = ("local", "dask")
#: which prediction sizes N/L in ``advise``: "auto" (the choice rule of
#: :mod:`envfit.advisor._choice`), or one of them forced: "bandlimited" (b′), "spectral" (c)
PREDICTOR_CHOICES = ("auto", "bandlimited", "spectral")

#: the paper's six point sets (Sec. 7.1) in the registry's order (theory.pointsets.POINTSETS):
#: sf, sobol, lp, bnot, random, jitter; the order is also ``validate``'s seed index of a set
ALL_POINTSETS = tuple(POINTSETS)
#: the point sets of ``advise`` and of ``validate --quick``: all but BNOT, whose
#: optimal-transport construction alone costs ≈ 10 s at N = 1024 and ≈ 15 s per realisation
#: at N = 4096 (:mod:`envfit.validate._pipeline`'s costs; BNOT only when asked for)
DEFAULT_POINTSETS = tuple(p for p in ALL_POINTSETS if p != "bnot")

# ----------------------------------------------------------------------------- the lobe

#: the glossy exponent n when none is given: the paper's n = 30 (Table 1, Secs. 7–8), used by
#: every glossy lobe of envfit (CLI ``--shininess``, the estimators, the renderer techniques)
DEFAULT_SHININESS = PAPER_SHININESS

# ----------------------------------------------------------------------------- renderer model

#: the warped spectra's grid G of the renderer prediction (``advise`` and ``validate
#: --renderer``): the box B = G/4, exact for QMC to N ≈ (G/8)² = 4096; measured on city.exr
#: (table in :mod:`envfit.advisor._rule_rows`): a coarser grid under-predicts MIS with QMC
#: points by 10–40 % at N ≈ 256–4096
RENDERER_GRID = 512
#: axes of the spectra's importance sample over the sphere for ``advise``: on city.exr 32
#: axes gave 0.96–1.08 of the 512/64 reference at every N for less than half its CPU time
#: (:mod:`envfit.advisor._rule_rows`)
ADVISE_SPECTRUM_AXES = 32
#: the same for ``validate --renderer``: on the s0 = 1.3 sun + GP map, glossy BRDF sampling
#: with sf at N = 1024 was predicted 0.219 from 64 axes, 0.153 from 256 and 0.161 from 1024
#: against a measured 0.157 [0.154, 0.161] (docs/guides/validate.md)
VALIDATE_SPECTRUM_AXES = 256
#: ``validate --renderer --quick``: grid 256 with 32 axes (the quick preset's cost cut; the
#: quick N are 16 and 256)
QUICK_RENDERER_GRID = 256
QUICK_SPECTRUM_AXES = 32
#: the axes of a warped spectrum when a caller gives none (:func:`warped_spectrum`,
#: :func:`renderer_model`): the reference resolution of those measurements (grid 512, 64 axes)
REFERENCE_SPECTRUM_AXES = 64
#: the renderer rules' point sets: ``advise`` lists QMC first (sobol, sf, random);
#: ``validate --renderer`` plain Monte Carlo first (random, sobol, sf); the orders are the
#: tables' row orders
ADVISE_RENDERER_POINTSETS = ("sobol", "sf", "random")
VALIDATE_RENDERER_POINTSETS = ("random", "sobol", "sf")

#: the renderer rules' adaptive measurement (``advise --check`` and ``validate --renderer
#: --quick``): axes to start with and at most (the full ``validate --renderer``: 500 → 16000)
RENDERER_AXES_START = 250
RENDERER_MAX_AXES = 4000

# ----------------------------------------------------------------------------- N ranges

#: ``envfit validate``'s sample counts: N = 16 … 4096 (powers of two; the paper's Figs. 4–6)
VALIDATE_N = tuple(2 ** k for k in range(4, 13))
#: ``validate --quick``: N = 16 … 1024
QUICK_N = tuple(2 ** k for k in range(4, 11))
