r"""What ``envfit advise --renderer NAME`` is asked: :class:`RendererAdviseOptions`, checked in
one place before any work (one-line :class:`~envfit.base.ParameterError`, the CLI's exit 2).

The renderer's own names throughout: the renderer (a name of :data:`envfit.renderers.RENDERERS`,
:func:`envfit.renderers.get_renderer`), its sampler (``--sampler``; default the renderer's
default sampler), the strategies it can render (``map`` = emitter sampling only, ``brdf`` =
BSDF sampling only, ``mis`` = both as its integrator combines them; default every strategy the
renderer can render and the noise model can predict). A combination is refused when the
renderer lacks the sampler, cannot render the strategy (its record's
:class:`~envfit.renderers.StrategySetting` says why: e.g. a light-only mode that exists only
in debug builds), or has no exact noise model (e.g. a Halton sampler; envfit's MIS with one
shared shift): the last by asking the model itself
(:func:`envfit.predict.renderer._cell_request.cell_request`, no map; the technique's
options are checked on a 4 × 8 map). The run's target, snippet and cache are options too
(:meth:`RendererAdviseOptions.asking` sets them on checked options).

The largest spp searched (:meth:`RendererAdviseOptions.spp_cap`) is ``max_spp`` (default
65536) or less where the model's grid of level L (M = 2^L cells per side,
``RendererModelOptions.max_level``) resolves fewer points of the sampler: Owen-scrambled nets
and digitally shifted ones are exact on the grid to N = 2^(L−1) (M ≥ 2N) and predicted for
any N above, their power above the grid sampled at Q·N scrambled (shifted) points
(``RendererModelOptions.shifts`` = Q), searched while they are no more than the fine table's
4^(L+1) points, N ≤ 4^(L+1)/Q (4096 at the default level 9, a common default of render
samples; ``sampled=False``: 2^(L−1)); Kensler's correlated multi-jittering and orthogonal
arrays exactly to M ≥ N (and their (N, N) tables: at most 1024; ``sampled=False``), their
point sets drawn above, to :data:`STRATA_CAP` (a microfacet BSDF's frames: the exact reach
only); a Cranley–Patterson shift N ≤ M/8
(:mod:`envfit.predict.renderer.randomisation._cp_shift`); independent and jittered samplers
any N (V and the strata are resolved at every N).

Example
-------
>>> from envfit.renderers import RENDERERS
>>> name = next(n for n, r in RENDERERS.items() if "ldsampler" in r.samplers)
>>> o = RendererAdviseOptions(name.upper(), sampler="ldsampler")      # any case
>>> o.renderer == name, o.sampler, o.strategies, o.default_strategy, o.spp_cap()
(True, 'ldsampler', ('mis', 'map', 'brdf'), 'mis', 4096)
>>> light_only = next(n for n, r in RENDERERS.items() if not r.strategy("map").renderable)
>>> RendererAdviseOptions(light_only, strategies=["map"])   # doctest: +ELLIPSIS
Traceback (most recent call last):
...
envfit.base._errors.ParameterError: ... cannot render strategy 'map' (emitter sampling only): ...
"""
from __future__ import annotations

import copy
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from envfit.base import check_int, check_ints, check_names
from envfit.base import EnvfitError, ParameterError
from envfit.defaults import (FOOTPRINT_SIDE, MICROFACET_BSDFS, MICROFACET_FRAMES_SEED,
                             TWO_LOBE_BSDFS)
from envfit.maps import EnvMap
from envfit.predict.renderer import RendererModelOptions, cell_request, strata_reach
from envfit.predict.renderer.randomisation import ALWAYS_DRAWN, STRATA_SAMPLED
from envfit.renderers import ROUGHNESS_RTOL, STRATEGY_NAMES, get_renderer

__all__ = ["RendererAdviseOptions", "PresetAdviseOptions", "STRATEGY_WORDS", "DEFAULT_MAX_SPP",
           "MAX_SPP", "DEFAULT_LEVEL", "DEFAULT_LEVEL_V", "DEFAULT_NORMALS", "NET_RANDOMISATIONS",
           "spp_cap", "default_level", "SIZED_RANDOMISATIONS",
           "NORMALS_SIZED_RANDOMISATIONS", "AUTO_LEVEL", "AUTO_SHIFTS", "STRATA_CAP",
           "DEFAULT_MODEL_ERROR"]

#: a strategy in words
STRATEGY_WORDS = {"mis": "both techniques (MIS)", "map": "emitter sampling only",
                  "brdf": "BSDF sampling only"}
#: the largest spp searched by default
DEFAULT_MAX_SPP = 65536
#: the largest ``max_spp`` (``--nmax``) taken: spp is a 32-bit int in the renderers (each
#: renderer's sampler or integrator header: ``int samplesPerPixel``,
#: ``NODE_SOCKET_API(int, aa_samples)``, ``uint32_t m_sample_count``)
MAX_SPP = 2 ** 31 - 1
#: the model's finest grid level L (M = 2^L) for the nets and multi-jittering,
#: RendererModelOptions' default
DEFAULT_LEVEL = RendererModelOptions().max_level
#: the default level of the samplers whose model needs only V or the strata (independent,
#: jittered): on city.exr (one renderer, independent, 48 normals) levels 6, 7, 8 and 9 put the
#: 1 % answer at 5968, 5986, 5985, 5985 spp (MIS) and 11755, 11772, 11770, 11765 (emitter
#: only), at 1/16 of level 9's time at level 7
DEFAULT_LEVEL_V = 7
#: randomisations of digital nets: the model takes N = 2^m points only
NET_RANDOMISATIONS = ("digital_shift", "owen", "cp_shift")
#: the model's normals K, RendererModelOptions' default
DEFAULT_NORMALS = RendererModelOptions().normals
#: the frames a conductor's K frames are importance-sampled from: a sharp lobe meets a sun
#: in few frames (rendered, sun-gp-1.5 GGX α = 0.05: a pool of 2048 pixels put 16 of 18 cells
#: inside, every pixel 18 of 18); the proxies cost ~0.3 ms a frame (compiled)
MICROFACET_POOL = 8192
#: the randomisations whose model is sized to its error (:attr:`RendererAdviseOptions.auto`):
#: the nets whose power above the grid is sampled, each estimate with its standard error
SIZED_RANDOMISATIONS = ("digital_shift", "owen")
#: the randomisations whose model is sized in its normals only: no net is sampled above a
#: grid (independent points: the variance; stratified: the strata), the normals are the error
NORMALS_SIZED_RANDOMISATIONS = ("independent", "jittered")
#: the sized model's pilot: grid level and scrambles (Q) — at level 7 a pass costs ~1/14 of
#: level 9's with Q = 256, and the model's error is dominated by its normals (measured,
#: forest.exr, one renderer's Owen-scrambled net, 48 normals: ±5.8 % from the normals, ±2–4 % from Q = 16 scrambles)
AUTO_LEVEL, AUTO_SHIFTS = 7, 16
#: the relative standard error of the predicted RMSE the sized model aims at
DEFAULT_MODEL_ERROR = 0.05
#: the largest spp searched for correlated multi-jittering and orthogonal arrays, whose point
#: sets the model draws above the exact models' reach (``predict.renderer._diffuse_model``)
STRATA_CAP = 4096
#: envfit's own point sets that the model's Cranley-Patterson shift (Sobol' points) is not
_NOT_SOBOL = ("lp", "sf", "bnot")
#: the fields of what a run asks besides the model (:meth:`RendererAdviseOptions.asking`)
_RUN_FIELDS = ("target_rmse", "target_relative", "snippet", "filename", "cache", "cache_dir")
#: the order of the strategies: the renderer's default (both techniques) first
_ORDER = ("mis", "map", "brdf")


def spp_cap(randomisation: str, level: int, max_spp: int,
            shifts: int = RendererModelOptions().shifts, *, sampled: bool = True,
            reach: int | None = None) -> int:
    """The largest spp the model resolves for ``randomisation`` at grid level ``level``
    (module docstring; ``shifts``: Q of a digital shift's sampling; ``sampled=False``: the
    spp its grid resolves without sampling; ``reach``: the sampled nets' largest N where it
    is not the fine table's 4^(L+1)/Q, ``RendererModelOptions.reach``), at most ``max_spp``.

    >>> spp_cap("digital_shift", 9, 65536), spp_cap("owen", 9, 65536), spp_cap("cmj", 9, 65536)
    (4096, 4096, 4096)
    >>> spp_cap("owen", 9, 65536, sampled=False), spp_cap("owen", 10, 65536)
    (256, 16384)
    >>> spp_cap("cp_shift", 9, 65536), spp_cap("digital_shift", 11, 65536)
    (64, 65536)
    >>> spp_cap("cmj", 9, 65536, sampled=False), spp_cap("orthogonal", 7, 65536)
    (512, 4096)
    """
    net = max(1 << (level - 1), (reach or 4 ** (level + 1) // shifts) * sampled)  # above M/2
    strata = STRATA_CAP if sampled else strata_reach("cmj", level)       # drawn above
    top = {"digital_shift": net, "owen": net, "cmj": strata, "orthogonal": strata,
           "shared_sequence": strata,
           "cp_shift": max(1, 1 << max(level - 3, 0)),
           "jittered": 4 ** level}
    return int(min(max_spp, top.get(randomisation, max_spp)))


def default_level(randomisation: str, *, drawn: bool = True) -> int:
    """The model's default grid level for a sampler's randomisation: :data:`DEFAULT_LEVEL_V`
    for ``independent`` and ``jittered``, and for correlated multi-jittering and orthogonal
    arrays where their point sets are drawn above the exact models' reach (``drawn``: the
    diffuse surface and a one-lobe microfacet BSDF; exact to 2^7 spp,
    ``envfit.predict.renderer._drawn_strata.strata_reach``), else :data:`DEFAULT_LEVEL` (a
    two-lobe BSDF's strata: the exact model only, to 2^9 spp).

    >>> default_level("independent"), default_level("owen"), default_level("cmj")
    (7, 9, 7)
    >>> default_level("cmj", drawn=False), default_level("orthogonal", drawn=False)
    (9, 9)
    """
    strata = ("cmj", "orthogonal") if drawn else ()
    return DEFAULT_LEVEL_V if randomisation in ("independent", "jittered", *strata) \
        else DEFAULT_LEVEL


def _or(names) -> str:
    """``a, b or c``."""
    names = list(names)
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} or {names[-1]}"


def _check_microfacet(p, bsdf: str, sampler: str) -> None:
    """One line where renderer ``p`` has no model of the microfacet ``bsdf`` with ``sampler``
    (:attr:`Renderer.microfacet`): the one renderer and its samplers that have one, or the
    renderers with any microfacet BSDF."""
    from envfit.renderers import RENDERERS
    from envfit.shading.microfacet import DISTRIBUTIONS
    samplers = p.microfacet.get(bsdf, ())
    if samplers is None or sampler in samplers:
        return
    owners = [r for r in RENDERERS.values() if bsdf in r.microfacet]
    only = owners[0] if len(owners) == 1 else None
    if only is not None and only.microfacet[bsdf] is not None:
        names = only.microfacet[bsdf]
        raise ParameterError(f"--brdf {bsdf} is {only.possessive} {bsdf}, modelled for its "
                             f"{', '.join(names)} samplers{only.microfacet_why.get(bsdf, '')}: "
                             f"--renderer {only.name} --sampler {'|'.join(names)}")
    if not p.microfacet:
        raise ParameterError(f"{p.display} has no microfacet conductor model; use --renderer "
                             f"{_or(r.name for r in RENDERERS.values() if r.microfacet)}")
    if bsdf not in p.microfacet and len(owners) > 1 and bsdf not in DISTRIBUTIONS:
        names = ", ".join(f"{r.possessive} {r.bsdf_names.get(bsdf, bsdf)}" for r in owners)
        raise ParameterError(f"--brdf {bsdf} is not modelled for {p.display}; it is {names}: "
                             f"--renderer {'|'.join(r.name for r in owners)}")
    # else the renderer's BSDF refuses the distribution itself (Conductor, one line)


def _check_lobe_choice(p, bsdf: str, sampler: str, built) -> None:
    """One line where the ``built`` BSDF picks one of two lobes by a number ``sampler`` draws
    in a way the model does not cover (:func:`envfit.predict.renderer.lobe_choice_modelled`),
    naming the samplers it covers."""
    from envfit.predict.renderer import lobe_choice_modelled
    if not hasattr(built, "sample_square") or lobe_choice_modelled(p.sampler(sampler)):
        return
    ok = [n for n, s in p.samplers.items() if lobe_choice_modelled(s)]
    name = p.bsdf_names.get(bsdf, bsdf)
    raise ParameterError(f"{p.possessive} {name} with these parameters picks one of two "
                         f"lobes by a number the {sampler} sampler draws in a way envfit does "
                         f"not model: --sampler {'|'.join(ok)}")


def checked_roughness(roughness, renderer: str, bsdf: str | None = None) -> float:
    """``--roughness`` in the range of the renderer's roughness convention (of ``bsdf``'s,
    where it has its own: :meth:`~envfit.renderers.Renderer.roughness_of`)
    (:meth:`~envfit.renderers.RoughnessConvention.range`; a value within
    :data:`~envfit.renderers.ROUGHNESS_RTOL` of an end is that end); else one line.

    >>> from envfit.renderers import RENDERERS
    >>> r = next(n for n, p in RENDERERS.items()                    # R = sqrt(alpha)
    ...          if p.roughness and p.roughness.range()[0] == 0.223607)
    >>> checked_roughness(0.2236068, r)                 # within ROUGHNESS_RTOL of the end
    0.223607
    """
    try:
        r = float(roughness)
    except (TypeError, ValueError):
        raise ParameterError(f"--roughness must be a number, got {roughness!r}") from None
    p = get_renderer(renderer)
    convention = p.roughness if bsdf is None else p.roughness_of(bsdf)
    lo, hi = convention.range()
    if lo * (1.0 - ROUGHNESS_RTOL) <= r < lo:
        return lo
    if hi < r <= hi * (1.0 + ROUGHNESS_RTOL):
        return hi
    if not (math.isfinite(r) and lo <= r <= hi):
        raise ParameterError(f"--roughness {r:.12g} is outside {convention.words()}")
    return r


def _owners_envmap() -> str:
    """``X's envmap`` of the renderers whose emitter has ``mis_compensation`` (their records)."""
    from envfit.renderers import RENDERERS
    return _or(f"{r.possessive} envmap" for r in RENDERERS.values() if r.mis_compensation)


def _dummy_map() -> EnvMap:
    """A small non-constant map on which the model's own checks run (no real work)."""
    v = np.linspace(0.2, 1.0, 4 * 8 * 3).reshape(4, 8, 3)
    return EnvMap(v, name="check")


@dataclass(frozen=True)
class RendererAdviseOptions:
    """The renderer advice's parameters, checked and normalised on construction.

    Parameters
    ----------
    renderer : str
        A name of :data:`envfit.renderers.RENDERERS` (case-insensitive).
    sampler : str or None
        The renderer's sampler (its own name); None: the renderer's default.
    strategies : sequence of str or None
        Among ``mis``, ``map``, ``brdf``; None: every one the renderer renders and the model
        predicts with this sampler (``mis`` first when it can).
    spp : sequence of int
        spp listed beside the answer (``--spp``), each ≥ 1 and ≤ ``max_spp``.
    mis_compensation : bool
        The emitter's ``mis_compensation`` (Karlík et al. 2019), where the renderer's
        record has it (:attr:`Renderer.mis_compensation`).
    max_spp : int or None
        The largest spp searched (≥ 1); None: :data:`DEFAULT_MAX_SPP`, or :data:`MAX_SPP`
        for an independent sampler, whose RMSE is exactly σ/√spp at every spp.
    level : int or None
        The model's grid level L (1…11; None: :func:`default_level` of the sampler, or the
        sized model's, :attr:`auto`).
    normals : int or None
        The model's normals K (``RendererModelOptions``; None: :data:`DEFAULT_NORMALS`); for a
        microfacet BSDF the frames (normal, view) of
        :func:`envfit.predict.renderer.band_frames`.
    shifts, reach : int or None
        The sampled nets' Q and largest N (``RendererModelOptions``; None: its defaults, or the
        sized model's).
    model_error : float or None
        The relative standard error of the predicted RMSE the sized model aims at (0 < e <
        1; None: :data:`DEFAULT_MODEL_ERROR`).
    sized : bool or None
        Whether the model is sized (:attr:`auto`; None: decided from the fields above). The
        decision is stored here, so that ``dataclasses.replace`` of sized options stays sized.
    bsdf : str
        ``diffuse`` (white, the default) or a white microfacet conductor ``ggx`` /
        ``beckmann`` as the renderer shades and samples it (where its record's ``microfacet``
        has it; not with ``envfit``).
    roughness : float or None
        With a microfacet ``bsdf``: the renderer's own roughness (α, √α or α² by renderer:
        its record's :attr:`~envfit.renderers.Renderer.roughness`, or the BSDF's own,
        :meth:`~envfit.renderers.Renderer.roughness_of`; None: the BSDF's default where it
        has one, :attr:`~envfit.renderers.Renderer.bsdf_params`), α in
        :data:`~envfit.defaults.ADVISE_ALPHA` (its ``words()``; within
        :data:`~envfit.renderers.ROUGHNESS_RTOL`
        of an end, that end).
    bsdf_params : mapping or None
        The BSDF's own parameters (name → number) where its record has them
        (:attr:`~envfit.renderers.Renderer.bsdf_params`: a principled BSDF's ``metallic``,
        ``specular``, …); the rest keep their defaults.
    sphere_pixels : int or None
        The sphere's diameter on screen in pixels; the prediction then holds the error of
        each pixel's footprint (the normals a pixel spans,
        :func:`envfit.predict.renderer.pixel_footprints`, FOOTPRINT_SIDE squared of them;
        that many times the model's work). Diffuse: each normal's pixel in the axis view
        nearest it (``RendererModelOptions.sphere_pixels``); microfacet: in the frame's view.
        None: every pixel a point (a large object).
    quiet : bool
        No progress bar over the model's normals (frames) in a pass (default; the CLI:
        ``--quiet``).
    target_rmse, target_relative : float or None
        The target: an RMSE, or a fraction (< 1) of the map's mean radiance (at most one is
        read: ``target_rmse`` first; neither: :data:`~envfit.defaults.DEFAULT_TARGET_RELATIVE`).
    snippet : bool
        Also the scene text of the recommendation (:meth:`Renderer.snippet`), reading
        ``filename``.
    cache, cache_dir
        The advisor's on-disk cache of predicted cells
        (:class:`~envfit.advisor._cache.AdviseCache`).

    Raises
    ------
    envfit.base.ParameterError
        An unknown name, a combination the renderer or the model does not have, a bad number.
    """

    renderer: str
    sampler: str | None = None
    strategies: Sequence[str] | None = None
    spp: Sequence[int] = ()
    mis_compensation: bool = False
    max_spp: int | None = None
    level: int | None = None
    normals: int | None = None
    bsdf: str = "diffuse"
    roughness: float | None = None
    bsdf_params: Mapping[str, float] | None = None
    sphere_pixels: int | None = None
    quiet: bool = True
    shifts: int | None = None
    reach: int | None = None
    model_error: float | None = None
    sized: bool | None = None
    target_rmse: float | None = None
    target_relative: float | None = None
    snippet: bool = False
    filename: str = "envmap.exr"
    cache: bool = True
    cache_dir: str | Path | None = None

    def __post_init__(self) -> None:
        p = get_renderer(self.renderer)
        set_ = object.__setattr__
        set_(self, "_notes", [])
        set_(self, "renderer", p.name)
        if self.target_relative is not None and self.target_relative >= 1.0:
            raise ParameterError(f"the relative target (--target-relative) is a fraction of "
                                 f"the mean radiance and must be < 1, got "
                                 f"{self.target_relative!r}")
        set_(self, "sampler", p.sampler(self.sampler).name)
        self._check_bsdf(p)
        if self.mis_compensation and not p.mis_compensation:
            raise ParameterError(f"--mis-compensation is a setting of {_owners_envmap()}, "
                                 f"not of {p.display}")
        set_(self, "mis_compensation", bool(self.mis_compensation))
        if self.max_spp is None:
            exact = p.sampler(self.sampler).randomisation == "independent"
            set_(self, "max_spp", MAX_SPP if exact else DEFAULT_MAX_SPP)
        set_(self, "max_spp", check_int(self.max_spp, "the largest spp (--nmax)", 1))
        if self.max_spp > MAX_SPP:
            raise ParameterError(f"the largest spp (--nmax) must be at most {MAX_SPP} with "
                                 f"--renderer (a renderer's spp is a 32-bit int), got "
                                 f"{self.max_spp}")
        spp = check_ints(list(self.spp), "--spp", 1)
        too_big = [n for n in spp if n > self.max_spp]
        if too_big:
            raise ParameterError(f"--spp {too_big[0]} is above the largest spp searched "
                                 f"({self.max_spp}; --nmax)")
        set_(self, "spp", tuple(dict.fromkeys(spp)))
        spec = p.sampler(self.sampler)
        self._size_model(spec.randomisation)
        model = self.model_options()          # checks level and normals
        set_(self, "level", model.max_level)
        set_(self, "strategies", self._checked_strategies(p))
        cap = self.spp_cap()
        if spec.randomisation in NET_RANDOMISATIONS:
            odd = [n for n in self.spp if spec.spp(n) & (spec.spp(n) - 1)]
            if odd:
                raise ParameterError(f"--spp {odd[0]}: the model predicts {self.sampler} "
                                     f"(a digital net) at powers of two only")
        over = [n for n in self.spp if spec.spp(n) > cap]
        if over:
            raise ParameterError(f"--spp {over[0]}: {self.sampler} runs {spec.spp(over[0])} "
                                 f"spp, beyond the {cap} spp the model resolves for it at "
                                 f"--renderer-level {self.level}")

    def _size_model(self, randomisation: str) -> None:
        """The model's level, normals and sampled nets: as given, else the sized model's
        pilot (:attr:`auto`) or the defaults; ``model_error`` checked."""
        set_ = object.__setattr__
        nets = randomisation in SIZED_RANDOMISATIONS
        drawn = randomisation in STRATA_SAMPLED and randomisation not in ALWAYS_DRAWN \
            and self.draws_strata                     # drawn above the exact reach
        eligible = ((nets or drawn or randomisation in NORMALS_SIZED_RANDOMISATIONS)
                    and self.sphere_pixels is None)
        auto = eligible and (self.level is None and self.normals is None and self.shifts is None
                             and self.reach is None if self.sized is None else bool(self.sized))
        set_(self, "sized", auto)       # kept, so dataclasses.replace keeps the sizing
        if auto and nets:               # the pilot, unless replace() carried its values
            for name, value in (("level", AUTO_LEVEL), ("shifts", AUTO_SHIFTS),
                                ("reach", spp_cap(randomisation, DEFAULT_LEVEL, MAX_SPP))):
                if getattr(self, name) is None:
                    set_(self, name, value)
        if self.level is None:
            set_(self, "level", default_level(randomisation, drawn=self.draws_strata))
        if self.normals is None:
            set_(self, "normals", DEFAULT_NORMALS)
        e = DEFAULT_MODEL_ERROR if self.model_error is None else self.model_error
        if isinstance(e, bool) or not isinstance(e, (int, float)) or not 0.0 < e < 1.0:
            raise ParameterError(f"--renderer-model-error must be a fraction 0 < e < 1, "
                                 f"got {e!r}")
        set_(self, "model_error", float(e))

    @property
    def auto(self) -> bool:
        """Whether the model is sized to :attr:`model_error` (:mod:`._renderer_sizing`):
        Owen-scrambled and digitally shifted nets (on the diffuse surface or a microfacet
        BSDF, a rough plastic's lobe mixtures included), independent and
        stratified samplers (any BSDF), without pixel footprints, with none of ``level``,
        ``normals``, ``shifts``, ``reach`` given (or ``sized`` given);
        ``dataclasses.replace`` keeps it."""
        return self.sized

    def _check_bsdf(self, p) -> None:
        """``bsdf`` diffuse (``roughness`` None) or a microfacet conductor the renderer shades
        (``roughness`` its own parameter: :func:`checked_roughness`)."""
        if self.sphere_pixels is not None:
            object.__setattr__(self, "sphere_pixels",
                               check_int(self.sphere_pixels, "--sphere-pixels", 4))
        params = dict(self.bsdf_params or {})
        object.__setattr__(self, "bsdf_params", params)
        defaults = p.bsdf_params.get(self.bsdf, {})
        if params and not defaults:
            from envfit.renderers import RENDERERS
            owners = sorted({b for r in RENDERERS.values() for b in r.bsdf_params})
            raise ParameterError(f"--bsdf-param is for a BSDF with parameters of its own "
                                 f"(--brdf {_or(owners)}), not --brdf {self.bsdf}")
        if self.bsdf == "diffuse":
            if self.roughness is not None:
                raise ParameterError(f"--roughness is a parameter of --brdf "
                                     f"{_or(MICROFACET_BSDFS)}")
            return
        if self.bsdf not in MICROFACET_BSDFS:
            raise ParameterError(f"with --renderer, --brdf is "
                                 f"{_or(('diffuse',) + MICROFACET_BSDFS)} (the paper's glossy "
                                 f"lobe is no renderer's BSDF); got {self.bsdf!r}")
        _check_microfacet(p, self.bsdf, self.sampler)
        if self.roughness is None and "roughness" in defaults:
            object.__setattr__(self, "roughness", defaults["roughness"])
        if self.roughness is None:
            raise ParameterError(f"--brdf {self.bsdf} needs --roughness (the renderer's own: "
                                 f"{p.roughness.units if p.roughness else 'its roughness'})")
        object.__setattr__(self, "roughness",
                           checked_roughness(self.roughness, p.name, self.bsdf))
        b = self.conductor()                  # the renderer lacks this distribution, or a
        #                                       parameter is unknown or out of range: one line
        _check_lobe_choice(p, self.bsdf, self.sampler, b)

    @property
    def microfacet(self) -> bool:
        return self.bsdf != "diffuse"

    @property
    def draws_strata(self) -> bool:
        """Whether the model draws a multi-jittered or orthogonal sampler's point sets above
        its exact reach (``predict.renderer._drawn_strata``): on the diffuse surface and over a
        one-lobe microfacet BSDF's frames; a two-lobe BSDF's (a rough plastic, a principled
        with two closures) strata stay exact on the grid, where its lobe choice is
        modelled."""
        return not self.microfacet or not hasattr(self.conductor(), "sample_square")

    @property
    def every_spp(self) -> bool:
        """Whether every spp the sampler runs is searched — for a net, also those between
        the powers of two: an Owen-scrambled prefix sampler on the diffuse surface or a
        microfacet conductor without pixel footprints
        (``envfit.predict.renderer._sampled_nets``); else a net's spp are its powers of
        two."""
        spec = self.record.sampler(self.sampler)
        return (spec.randomisation not in NET_RANDOMISATIONS or spec.prefix
                and self.bsdf not in TWO_LOBE_BSDFS and self.sphere_pixels is None)

    def conductor(self):
        """The white conductor (Fresnel 1) as the renderer shades and samples it, the
        renderer's rough plastic (a GGX coat, its defaults η 1.49, diffuse 0.5) or its
        principled BSDF (``bsdf_params``): the record's
        :meth:`~envfit.renderers.Renderer.bsdf` at the α of the BSDF's roughness
        convention."""
        p = self.record
        return p.bsdf(self.bsdf, p.roughness_of(self.bsdf).to_alpha(self.roughness),
                      **self.bsdf_params)

    def model_options(self) -> RendererModelOptions:
        """The :class:`RendererModelOptions` of ``level`` and ``normals`` (pool: its default,
        :data:`MICROFACET_POOL` for a conductor, at least ``normals``; a rough plastic keeps
        the default: its frames' proxies are numpy, 8192 frames took 33 s)."""
        for name in ("level", "normals"):
            check_int(getattr(self, name), f"--renderer-{name}", 1)
        compiled = self.microfacet and self.bsdf not in TWO_LOBE_BSDFS    # proxies: numpy
        base = MICROFACET_POOL if compiled else RendererModelOptions().pool
        pool = max(base, int(self.normals))
        pixels = None if self.microfacet else self.sphere_pixels   # microfacet: per frame
        shifts = RendererModelOptions().shifts if self.shifts is None else self.shifts
        return RendererModelOptions(normals=int(self.normals), pool=pool,
                                  max_level=int(self.level), sphere_pixels=pixels,
                                  footprint_side=FOOTPRINT_SIDE,
                                  shifts=check_int(shifts, "shifts", 4), reach=self.reach)

    def technique_options(self) -> dict:
        """The renderer technique's options (``mis_compensation`` where it has it)."""
        return {"mis_compensation": True} if self.mis_compensation else {}

    def _checked_strategies(self, p) -> tuple[str, ...]:
        """The strategies asked (or every one that works), each renderable and predictable."""
        asked = self.strategies is not None
        names = check_names(list(self.strategies) if asked else list(_ORDER),
                            STRATEGY_NAMES, "strategy (with --renderer: mis, map, brdf)")
        names = sorted(names, key=_ORDER.index)
        if self.technique_options():                # its options, checked (none: nothing to
            p.technique(_dummy_map(), **self.technique_options())   # build, up to 8 M cells)
        light = RendererModelOptions(normals=1, pool=1, max_level=1, pilot_level=1)
        spec = p.sampler(self.sampler)
        if spec.randomisation == "cp_shift" and spec.name in _NOT_SOBOL:
            raise ParameterError(f"no noise model of {p.possessive} {spec.name}: "
                                 f"the model's Cranley-Patterson shift takes Sobol' points; "
                                 f"choose --sampler sobol, random or jitter")
        spp = spec.spp(1)
        ok, first = [], None
        for s in names:
            setting = p.strategy(s)
            why = None
            if not setting.renderable:
                why = (f"{p.display} cannot render strategy {s!r} "
                       f"({STRATEGY_WORDS[s]}): {setting.note.strip()}")
            else:
                try:
                    cell_request(p, light, s, self.sampler, spp)
                except EnvfitError as exc:
                    why = (f"no noise model of {p.possessive} {self.sampler} with "
                           f"strategy {s!r}: {exc}")
            if why is None:
                ok.append(s)
            elif asked:
                raise ParameterError(why)
            first = first or why
            if why is not None and setting.renderable:         # the model's gap: said
                self._notes.append(f"strategy {s} ({STRATEGY_WORDS[s]}) is left out of the "
                                   f"answer: {why}")
        if not ok:
            raise ParameterError(first)
        return tuple(ok)

    @property
    def notes(self) -> list[str]:
        """What the options left out of the answer: each strategy the renderer renders but
        the model does not predict with this sampler, and why (not asked: left out)."""
        return list(self._notes)

    def asking(self, **run) -> "RendererAdviseOptions":
        """These options with other run fields (``target_rmse``, ``target_relative``,
        ``snippet``, ``filename``, ``cache``, ``cache_dir``): nothing else is checked again."""
        bad = sorted(set(run) - set(_RUN_FIELDS))
        if bad:
            raise TypeError(f"not a run field: {', '.join(bad)}")
        new = copy.copy(self)
        for k, v in run.items():
            object.__setattr__(new, k, v)
        if new.target_relative is not None and new.target_relative >= 1.0:
            raise ParameterError(f"the relative target (--target-relative) is a fraction of "
                                 f"the mean radiance and must be < 1, got "
                                 f"{new.target_relative!r}")
        return new

    @property
    def record(self):
        """The renderer's record (:class:`~envfit.renderers.Renderer`)."""
        return get_renderer(self.renderer)

    #: the former name of :attr:`record`
    preset = record

    @property
    def default_strategy(self) -> str:
        """The strategy of the first line: ``mis`` (the renderer's default) when asked."""
        return self.strategies[0]

    def spp_cap(self, *, sampled: bool = True) -> int:
        """The largest spp searched for this sampler (:func:`spp_cap`; ``sampled=False``: the
        largest its grid resolves without sampling, where the search's first pass stops)."""
        spec = self.record.sampler(self.sampler)
        m = self.model_options()
        return spp_cap(spec.randomisation, self.level, self.max_spp, m.shifts,
                       sampled=sampled and self.reaches_above(spec.randomisation),
                       reach=m.reach)

    def reaches_above(self, randomisation: str) -> bool:
        """Whether the model goes above the grid's exact reach for ``randomisation``: nets
        always (their power above sampled), a shared sequence's runs always (drawn at every
        N), strata where :attr:`draws_strata`."""
        return (self.draws_strata or randomisation not in STRATA_SAMPLED
                or randomisation in ALWAYS_DRAWN)

    def key(self) -> dict:
        """What the predictions depend on besides the map (the cache key's part)."""
        m = self.model_options()
        key = {"renderer": self.renderer, "sampler": self.sampler,
               "technique_options": self.technique_options(), "normals": m.normals,
               "pool": m.pool, "max_level": m.max_level, "pilot_level": m.pilot_level,
               "shifts": m.shifts, "reach": m.reach}
        if self.microfacet:                   # the diffuse keys (and caches) unchanged
            key.update(bsdf=self.bsdf, alpha=self.conductor().alpha,
                       frames_seed=MICROFACET_FRAMES_SEED)
            defaults = self.record.bsdf_params.get(self.bsdf)
            if defaults:                                   # the others' keys unchanged
                key["bsdf_params"] = {k: float(v) for k, v in sorted(
                    {**defaults, **self.bsdf_params}.items()) if k != "roughness"}
        if self.sphere_pixels is not None:
            key.update(sphere_pixels=self.sphere_pixels, footprint_side=FOOTPRINT_SIDE)
            film = m.film(self.record)
            if film.table is not None:        # the box's keys (and caches) unchanged
                key["pixel_filter"] = film.name
        return key


#: the former name of :class:`RendererAdviseOptions`
PresetAdviseOptions = RendererAdviseOptions
