r"""The shared parts of the renderers' records: the environment-map technique protocol, the
renderer and sampler records, the concentric cosine map, the power/balance MIS weights.

A *technique* (:class:`EnvmapTechnique`) is one renderer's environment-map emitter as its
source builds it — Mitsuba 3's style: one object holding the radiance lookup
(:meth:`~EnvmapTechnique.eval`), the sampling warp (:meth:`~EnvmapTechnique.sample`) and the
density (:meth:`~EnvmapTechnique.pdf`) on one shared data structure. Directions are in
envfit's *world* frame of the map's ``up`` (:mod:`envfit.maps._latlong`): the frame in
which :meth:`envfit.maps.EnvMap.lookup` sees file pixel (i, j) at
:math:`\theta = \pi(i+\frac12)/H`, :math:`\phi = 2\pi(j+\frac12)/W`. Each technique states
the renderer's own (native) frame for the same file and the fixed orthogonal matrix
:attr:`EnvmapTechnique.native_to_world` that maps it to envfit's.

A renderer's record (:class:`Renderer`) adds the rest of the renderer's direct-light
estimator: the cosine BSDF sampling map and the renderer's tangent frame, the MIS
heuristic, the integrator settings per strategy, the samplers by their own names (with the
spp each one actually runs and its randomisation tag, :data:`RANDOMISATIONS`), and the scene
text a user pastes (:meth:`Renderer.snippet`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable, Mapping

import numpy as np

from envfit.base import ParameterError
from envfit.base import as_square_points, as_unit_vectors

if TYPE_CHECKING:                         # a field's annotation only
    from envfit.renderers._roughness import RoughnessConvention

__all__ = ["RANDOMISATIONS", "PAIRINGS", "STRATEGY_NAMES", "DirectionSample",
           "EnvmapTechnique", "PermutationLaw", "SamplerSpec", "StrategySetting", "Renderer",
           "square_points", "unit_directions", "concentric_disk", "cosine_hemisphere",
           "power_heuristic", "balance_heuristic", "map_rgb", "SPHERE_VIEWS",
           "SNIPPET_PIXELS", "snippet_pixels", "scene_comment"]

#: randomisation tags of the samplers — the names of the randomisation registry
#: (``envfit.predict.renderer.randomisation.RANDOMISATIONS``, each with its exact predictor;
#: ``digit_permutation`` has none yet):
#: i.i.d. points; r×r (or x×y) jittered strata with fresh jitter; Kensler's correlated
#: multi-jittering; a random XOR (digital) shift of a (0, 2)-net; nested uniform (Owen)
#: scrambling of a Sobol' net; a Cranley–Patterson rotation of a fixed point set; a
#: randomised orthogonal array; runs of one fixed scrambled sequence shared by all pixels
#: (drawn); random digit permutations (Halton: outside the issue's list)
RANDOMISATIONS = ("independent", "jittered", "cmj", "digital_shift", "owen", "cp_shift",
                  "orthogonal", "shared_sequence", "digit_permutation")

#: how the emitter's and the BSDF's 2-D samples of one pixel relate: independently
#: randomised dimensions; the same randomised net in two orders (Mitsuba ``ldsampler``);
#: columns of one randomised orthogonal array (jointly stratified); two point sets moved by
#: one common random shift (envfit's own MIS)
PAIRINGS = ("independent", "same_net_permuted", "joint_array", "shared_shift")

#: the strategies of a direct-light estimate: emitter sampling only, BSDF sampling only, both
STRATEGY_NAMES = ("map", "brdf", "mis")

_TWO_PI = 2.0 * np.pi

#: the six orthographic views of the unit sphere that envfit's renderer measurements render
#: (:data:`envfit.renderers._sphere.VIEWS`, the same tuples: ``tests/
#: test_snippet_render.py``): (axis v, up u); the camera sits at 3v, looks at the origin
#: with image up u, and its image plane covers [-1, 1]² (the sphere fills the film)
SPHERE_VIEWS = (((1, 0, 0), (0, 0, 1)), ((-1, 0, 0), (0, 0, 1)), ((0, 1, 0), (1, 0, 0)),
                ((0, -1, 0), (1, 0, 0)), ((0, 0, 1), (0, 1, 0)), ((0, 0, -1), (0, 1, 0)))
#: the film's pixels across in a snippet when the model took every pixel as a point (no
#: ``--sphere-pixels``): the measurements' default resolution
SNIPPET_PIXELS = 64


def snippet_pixels(sphere_pixels=None) -> int:
    """The film's pixels across in a snippet: ``sphere_pixels`` (the sphere's diameter the
    model assumed) or :data:`SNIPPET_PIXELS`."""
    return SNIPPET_PIXELS if sphere_pixels is None else int(sphere_pixels)


def scene_comment(what: str, sphere_pixels=None, *, view_dependent: bool = False,
                  mark: str = "#", pixel_filter: str = "box pixel filter") -> list[str]:
    """The comment lines on top of a snippet: the scene envfit predicted (``what``: the
    sphere's BSDF), its six views, the film, and what the prediction averages over (uniform
    normals; ``view_dependent``, a microfacet BSDF: every pixel of a view, over uniform
    rotations of the map; ``pixel_filter``: the film's filter in words)."""
    n = snippet_pixels(sphere_pixels)
    film = ([f"{n} x {n} pixels: the sphere {n} pixels across (--sphere-pixels), each pixel's",
             "footprint in the prediction"] if sphere_pixels is not None else
            [f"{n} x {n} pixels; the model took every pixel as a point (a sphere far larger",
             "than its pixels; --sphere-pixels D models a D-pixel sphere)"])
    avg = (["prediction: the RMSE over the sphere's pixels of a view, averaged over uniform",
            "rotations of the map (the envmap's to_world)"] if view_dependent else
           ["prediction: the RMSE over uniform normals, each pixel weighted 1/(n.v) in the",
            "view whose axis is nearest its normal (envfit.renderers)"])
    lines = ["the scene envfit predicted: a unit sphere at the origin,", f"{what},",
             "lit by the map alone (direct light only); six orthographic views on +-x, +-y,",
             f"+-z (camera at 3 v looking at the origin, image [-1, 1]^2), {pixel_filter},",
             *film, *avg]
    return [f"{mark} {ln}" for ln in lines]


@dataclass(frozen=True)
class DirectionSample:
    """Sampled directions (K, 3) and their densities per solid angle (K,); unpacks as
    ``dirs, pdf = technique.sample(u)``."""

    directions: np.ndarray
    pdf: np.ndarray

    def __iter__(self):
        return iter((self.directions, self.pdf))


def square_points(u, name: str = "u") -> np.ndarray:
    """Square points (..., 2) as a float64 (K, 2) array in [0, 1]²; ParameterError otherwise
    (:func:`envfit.base._checks.as_square_points`)."""
    return as_square_points(u, name=name)


def unit_directions(dirs, name: str = "directions") -> np.ndarray:
    """Directions (..., 3) as float64 (K, 3) unit vectors; ParameterError for zero or
    non-finite vectors or a wrong shape (:func:`envfit.base._checks.as_unit_vectors`)."""
    return as_unit_vectors(dirs, name=name)


def map_rgb(envmap) -> np.ndarray:
    """The map's pixels as a float64 (H, W, 3) RGB array, as the renderers load a file: one
    channel is replicated to grey (Mitsuba ``Bitmap::convert`` Y → RGB), a fourth (alpha)
    is dropped; two channels are refused."""
    a = np.asarray(envmap.data, dtype=np.float64)
    if a.ndim == 2:
        a = a[:, :, None]
    c = a.shape[2]
    if c == 1:
        return np.repeat(a, 3, axis=2)
    if c in (3, 4):
        return np.ascontiguousarray(a[:, :, :3])
    raise ParameterError(f"a renderer's environment map has 1, 3 or 4 channels, not {c}")


class EnvmapTechnique:
    """One renderer's environment-map emitter: radiance lookup, sampling warp and density on
    one shared data structure (Mitsuba 3's emitter style).

    Subclasses set :attr:`name`, :attr:`renderer`, :attr:`source` (file:function @ commit)
    and :attr:`native_to_world` (3×3 orthogonal, ``world = M @ native``), and implement
    :meth:`_eval_native`, :meth:`_sample_native` and :meth:`_pdf_native` on directions in
    the renderer's own frame.
    """

    name: str = ""
    renderer: str = ""
    source: str = ""
    native_to_world: np.ndarray = np.eye(3)

    def eval(self, dirs) -> np.ndarray:
        """Radiance (K, 3) (RGB) at world directions (K, 3), as the renderer looks it up."""
        d = unit_directions(dirs) @ self.native_to_world     # rows: M.T @ d
        return self._eval_native(d)

    def eval_unit(self, dirs: np.ndarray) -> np.ndarray:
        """:meth:`eval` at float64 (K, 3) directions already unit to rounding (the model's
        own), without :meth:`eval`'s checks: the hot path of the renderer model."""
        return self._eval_native(dirs @ self.native_to_world)

    def pdf_unit(self, dirs: np.ndarray) -> np.ndarray:
        """:meth:`pdf` at float64 (K, 3) unit directions, unchecked (:meth:`eval_unit`)."""
        return self._pdf_native(dirs @ self.native_to_world)

    def sample(self, u) -> DirectionSample:
        """World directions (K, 3) and their solid-angle pdf (K,) from square points u (K, 2)
        (``u[:, 0]``, ``u[:, 1]`` are the renderer's first and second sample coordinate)."""
        d, pdf = self._sample_native(square_points(u))
        return DirectionSample(d @ self.native_to_world.T, pdf)

    def pdf(self, dirs) -> np.ndarray:
        """The renderer's solid-angle density (K,) at world directions (K, 3)."""
        d = unit_directions(dirs) @ self.native_to_world
        return self._pdf_native(d)

    def sample_radiance(self, u):
        """:meth:`sample` and the radiance (K, 3) the renderer weights each sample with
        (its emitter's value at the sampled point; by default :meth:`eval` there)."""
        s = self.sample(u)
        return s, self.eval(s.directions)

    def _eval_native(self, d: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _sample_native(self, u: np.ndarray):  # pragma: no cover - abstract
        raise NotImplementedError

    def _pdf_native(self, d: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.renderer}>"


def concentric_disk(u) -> np.ndarray:
    r"""Shirley–Chiu concentric square-to-disk map (K, 2): with :math:`a = 2u_0 - 1`,
    :math:`b = 2u_1 - 1`, :math:`r = a,\ \phi = \frac\pi4 b/a` where :math:`a^2 > b^2`,
    else :math:`r = b,\ \phi = \frac\pi2 - \frac\pi4 a/b`; the point :math:`(r\cos\phi,
    r\sin\phi)`, the origin for :math:`a = b = 0`.

    The same formula in all three renderers: Mitsuba 3 ``include/mitsuba/core/warp.h``:
    ``square_to_uniform_disk_concentric`` (Dave Cline's branch-reduced form, which picks the
    ``b`` branch on ``|a| < |b|`` — the same point where ``|a| = |b|``); pbrt-v4
    ``src/pbrt/util/sampling.h``: ``SampleUniformDiskConcentric``; Cycles
    ``src/kernel/sample/mapping.h``: ``sample_uniform_disk``.

    >>> concentric_disk([[1.0, 0.5], [0.5, 1.0]]).round(12).tolist()
    [[1.0, 0.0], [0.0, 1.0]]
    """
    U = square_points(u)
    a, b = 2.0 * U[:, 0] - 1.0, 2.0 * U[:, 1] - 1.0
    use_a = a * a > b * b
    r = np.where(use_a, a, b)
    with np.errstate(invalid="ignore", divide="ignore"):
        phi = np.where(use_a, 0.25 * np.pi * (b / a), 0.5 * np.pi - 0.25 * np.pi * (a / b))
    phi = np.where((a == 0.0) & (b == 0.0), 0.0, phi)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi)])


def cosine_hemisphere(u) -> DirectionSample:
    r"""Cosine-weighted hemisphere directions (K, 3) in the local frame (normal +z) and their
    pdf :math:`\cos\theta/\pi` (K,): the concentric disk point lifted,
    :math:`z = \sqrt{\max(0, 1 - x^2 - y^2)}`.

    Mitsuba 3 ``warp.h``: ``square_to_cosine_hemisphere`` (``safe_sqrt``), pbrt-v4
    ``sampling.h``: ``SampleCosineHemisphere`` (``SafeSqrt``), Cycles ``mapping.h``:
    ``sample_cos_hemisphere`` (``safe_sqrtf``), each after :func:`concentric_disk`.

    >>> d, p = cosine_hemisphere([[0.5, 0.5]])
    >>> d.tolist(), bool(np.isclose(p[0], 1 / np.pi))
    ([[0.0, 0.0, 1.0]], True)
    """
    p = concentric_disk(u)
    z = np.sqrt(np.maximum(1.0 - p[:, 0] ** 2 - p[:, 1] ** 2, 0.0))
    return DirectionSample(np.column_stack([p, z]), z / np.pi)


def power_heuristic(pdf_a, pdf_b, frac_a: float = 1.0, frac_b: float = 1.0) -> np.ndarray:
    r"""Veach's power heuristic (β = 2) weight of technique a,
    :math:`w_a = (\nu_a p_a)^2 / ((\nu_a p_a)^2 + (\nu_b p_b)^2)`, 0 where it is not finite
    (Mitsuba 3 ``src/integrators/direct.cpp``: ``mis_weight`` with ``m_frac_lum``,
    ``m_frac_bsdf``; pbrt-v4 ``sampling.h``: ``PowerHeuristic(nf, fPdf, ng, gPdf)``; Cycles
    ``src/kernel/sample/mis.h``: ``power_heuristic``).

    >>> power_heuristic([1.0, 2.0], [1.0, 0.0]).tolist()
    [0.5, 1.0]
    """
    a = (frac_a * np.asarray(pdf_a, dtype=np.float64)) ** 2
    b = (frac_b * np.asarray(pdf_b, dtype=np.float64)) ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        w = a / (a + b)
    return np.where(np.isfinite(w), w, 0.0)


def balance_heuristic(pdf_a, pdf_b, frac_a: float = 1.0, frac_b: float = 1.0) -> np.ndarray:
    r"""Veach's balance heuristic weight :math:`\nu_a p_a/(\nu_a p_a + \nu_b p_b)` (0 where
    not finite): envfit's own MIS (:func:`envfit.sampling._importance.mis_weights`).

    >>> balance_heuristic([1.0], [3.0]).tolist()
    [0.25]
    """
    a = frac_a * np.asarray(pdf_a, dtype=np.float64)
    b = frac_b * np.asarray(pdf_b, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = a / (a + b)
    return np.where(np.isfinite(w), w, 0.0)


@dataclass(frozen=True)
class PermutationLaw:
    r"""The law of a sampler's hashed permutations, where they are not uniformly random: the
    value of the ``cmj`` randomisation's ``permutations`` option that a sampler's
    :attr:`SamplerSpec.options` give (``envfit.predict.renderer.randomisation``'s ``cmj``).

    Attributes
    ----------
    name : the hash (``"kensler"``)
    pair_table : ``l -> (l², l²)`` array, :math:`\Pr(\sigma(y) = b, \sigma(y') = b')` over the
        sampler's seeds, rows (y, b), columns (y', b')
    note : how the table was made (said in the model's note)
    permute : ``(index, length, seeds) -> σ(index)`` the hash itself (broadcast; uint32
        seeds), by which the renderer model draws the permutations where it samples point sets
        (``envfit.predict.renderer.randomisation``'s ``strata_points``); None: not drawable
    """

    name: str
    pair_table: Callable[[int], np.ndarray]
    note: str = ""
    permute: Callable | None = None


@dataclass(frozen=True)
class SamplerSpec:
    """A renderer's sampler by its own name.

    Attributes
    ----------
    name : the renderer's name (``ldsampler``, ``zsobol``, ``tabulated_sobol``, …)
    randomisation : a tag of :data:`RANDOMISATIONS`
    pairing : a tag of :data:`PAIRINGS` (how the emitter's and the BSDF's 2-D samples relate)
    rounding : spp requested → spp the renderer runs (its own rule, read from its source)
    description : what it does per pixel, with file:function
    default : the renderer's default sampler
    prefix : an Owen-scrambled sequence whose N points, for any N, are (up to a digital
        shift the scramble absorbs) the first N of the sequence: predicted between the powers
        of two (``envfit.predict.renderer._sampled_nets``)
    options : N → the randomisation's options for N points, as (name, value) pairs of the
        randomisation registry (``envfit.predict.renderer.randomisation``): the renderer's
        own strata layout or permutations; None: the registry's plain form (square strata,
        uniform permutations)
    film_points : ``(pixels, n, dims, seed) -> (pixels, n, dims, 2)`` the sampler's own points
        of each pixel in the order it pairs them across dimensions (dimension 0 the film's:
        x right, y down in the pixel),
        for pixels of random seeds; None where that order does not matter (the model takes
        the film's pairing with the techniques as random)
    lobe_points : ``(pixels, n, call, seed) -> (pixels, n)`` the sampler's own 1-D numbers
        of call ``call`` of each pixel, in its order and for the pixels of
        :attr:`film_points` (the same seed); None: a lobe number's order is taken as random
    unmodelled : why envfit does not predict this sampler (a sentence; "" where it does):
        :meth:`Renderer.sampler` refuses it in one line with this reason
    """

    name: str
    randomisation: str
    pairing: str
    rounding: Callable[[int], int]
    description: str
    default: bool = False
    prefix: bool = False
    options: Callable[[int], tuple] | None = None
    film_points: Callable[..., np.ndarray] | None = None
    lobe_points: Callable[..., np.ndarray] | None = None
    unmodelled: str = ""

    def model_options(self, n: int) -> tuple:
        """The randomisation's options for ``n`` points (:attr:`options`; () without)."""
        return () if self.options is None else tuple(self.options(int(n)))

    def __post_init__(self):
        if self.randomisation not in RANDOMISATIONS:
            raise ParameterError(f"unknown randomisation {self.randomisation!r}")
        if self.pairing not in PAIRINGS:
            raise ParameterError(f"unknown pairing {self.pairing!r}")

    def runnable(self, cap: int):
        """Every spp the sampler runs (its rounding of 1…cap) that is at most ``cap``,
        ascending: a ``range`` (lazy, O(1) memory at any cap) where the sampler runs every
        spp as asked, else a list (the roundings to squares, powers and products grow fast
        enough that their counts up to the model's caps are small: 2048 squares to 4^11).

        >>> from envfit.renderers import get_renderer
        >>> get_renderer("mitsuba3").sampler("ldsampler").runnable(300)
        [4, 16, 64, 256]
        >>> get_renderer("mitsuba3").sampler("independent").runnable(10 ** 12)
        range(1, 1000000000001)
        """
        cap = int(cap)
        if self.rounding is int:
            return range(1, cap + 1)
        out, n = set(), 1
        while n <= cap:
            r = self.spp(n)
            if r <= cap:
                out.add(r)
            n = max(n + 1, r) if r > n else n + 1
        return sorted(out)

    def spp(self, requested) -> int:
        """The spp the renderer runs when ``requested`` (an int ≥ 1) is asked for."""
        try:
            n = int(requested)
        except (TypeError, ValueError):
            raise ParameterError(f"spp must be an integer >= 1, got {requested!r}") from None
        if n != requested or n < 1:
            raise ParameterError(f"spp must be an integer >= 1, got {requested!r}")
        return int(self.rounding(n))


@dataclass(frozen=True)
class StrategySetting:
    """How the renderer renders one strategy (``map``, ``brdf`` or ``mis``): whether it can
    (``renderable``), the integrator and its settings, the samples of each technique per
    spp (``emitter_samples``, ``bsdf_samples``), which map density it samples
    (``density``: e.g. ``"compensated"`` for pbrt-v4's path integrator) and, where a sampler's
    pattern depends on it, where the emitter's and the BSDF's first 2-D draws of a sample
    stand among the sampler's draws, counted from the film position's 2-D draw: as the
    dimension at which each starts, each 1-D draw counting one and each 2-D draw two
    (``dimensions``: Mitsuba's ``orthogonal``, whose ``next_2d`` is two ``next_1d``), and as
    the number of the call that makes it (``calls``: Mitsuba's ``ldsampler``, whose
    ``next_1d`` and ``next_2d`` each take one dimension index); None where the order plays
    no part. ``lobe_call``: the call that draws a two-lobe BSDF's lobe number (its
    ``next_1d``), where the sampler orders it (:attr:`SamplerSpec.lobe_points`)."""

    strategy: str
    renderable: bool
    integrator: str
    settings: Mapping[str, object] = field(default_factory=dict)
    emitter_samples: int = 0
    bsdf_samples: int = 0
    density: str = "plain"
    note: str = ""
    dimensions: tuple[int, int] | None = None
    calls: tuple[int, int] | None = None
    lobe_call: int | None = None


_HEURISTICS = {"power": power_heuristic, "balance": balance_heuristic}


@dataclass(frozen=True)
class Renderer:
    """One renderer's direct-light estimator, read from its source.

    Attributes
    ----------
    name : registry key (``mitsuba3``, ``pbrt4``, ``cycles``, ``envfit``)
    renderer : the renderer and the commit read
    technique : factory ``technique(envmap, **options) -> EnvmapTechnique``
    cosine : square points (K, 2) → :class:`DirectionSample` of the diffuse BSDF's sampling
        in the local frame (normal +z)
    tangent_frame : unit normals (K, 3) → (K, 3, 3) frames, rows (tangent, bitangent,
        normal): the renderer's local frame of a shading point (local → world is
        ``local @ frame``)
    heuristic : ``"power"`` or ``"balance"``
    strategies : strategy → :class:`StrategySetting`
    samplers : name → :class:`SamplerSpec`
    snippet_fn : ``(StrategySetting, SamplerSpec, spp, **options) -> str``; its keyword
        options are :meth:`snippet_options`
    source : where each part was read (file:function @ commit)
    display : the renderer's name in sentences ("Mitsuba 3", "pbrt-v4", …)
    negative_radiance : what the renderer does with negative radiance, read from its source
        (why its model refuses a signed map)
    mis_compensation : whether its emitter has Mitsuba's ``mis_compensation`` option
    microfacet : the microfacet BSDFs modelled (``envfit.defaults.MICROFACET_BSDFS`` names)
        → the samplers each is modelled for (None: every sampler)
    microfacet_why : BSDF → why its samplers are limited (a parenthesis in the refusal)
    bsdf_notes : BSDF → a note the advice carries (what the name means in this renderer)
    bsdf_fn : ``(name, alpha, **params) -> BSDF`` — the renderer's microfacet BSDF of that
        ``--brdf`` name as it shades and samples it, built from the techniques of
        :mod:`envfit.shading.microfacet` (:meth:`bsdf`); None: it has none modelled
    bsdf_names : BSDF → its name in the renderer's words, where the ``--brdf`` name is not
        (said when another renderer is asked for it)
    roughness : the :class:`~envfit.renderers.RoughnessConvention` of its microfacet BSDFs
        (user-facing roughness R → α); None where it has none
    bsdf_roughness : BSDF → its own roughness convention, where it is not :attr:`roughness`
        (:meth:`roughness_of`)
    bsdf_params : BSDF → its parameters a user may set (``advise --bsdf-param NAME=VALUE``)
        and their defaults, ``roughness`` among them where it has a default (then
        ``--roughness`` may be left out)
    render_samplers : the samplers ``validate --renderer`` renders by default (empty: the
        renderer does not install here, nothing is rendered)
    harness : the module that renders envfit's measurement with it (``version()``,
        ``open_sphere(envmap, brdf, alpha, **common)``); the renderer's own package is
        imported only when the harness is used
    adaptive : its adaptive sampling, where modelled (None: it has none): its settings
        (``settings(threshold, samples, min_samples)``), its per-pixel test (``error``,
        ``class_a``, ``step``, ``neighbourhood``) and its pattern's points (``points``), read
        by :class:`envfit.predict.renderer._adaptive.AdaptiveModel` (Cycles':
        :mod:`envfit.renderers.cycles._adaptive`)
    pixel_filter : its default pixel filter where it importance-samples it, as the
        :class:`~envfit.renderers.FilmWarp` a sample's film offset follows (the pixel
        footprint of the model's ``sphere_pixels``); None: the box of width 1
    pixel_filter_note : what its default filter is where the model does not take it
        (``pixel_filter`` None), said with its predictions' footprint
    estimator_note : a part of the renderer's noise its model leaves out, said with every
        prediction ("" where none)
    """

    name: str
    renderer: str
    technique: Callable
    cosine: Callable[[np.ndarray], DirectionSample]
    tangent_frame: Callable[[np.ndarray], np.ndarray]
    heuristic: str
    strategies: Mapping[str, StrategySetting]
    samplers: Mapping[str, SamplerSpec]
    snippet_fn: Callable[..., str]
    source: str = ""
    display: str = ""
    negative_radiance: str = "the renderer models are for non-negative maps"
    mis_compensation: bool = False
    microfacet: Mapping[str, tuple[str, ...] | None] = field(default_factory=dict)
    microfacet_why: Mapping[str, str] = field(default_factory=dict)
    bsdf_notes: Mapping[str, str] = field(default_factory=dict)
    bsdf_fn: Callable[..., object] | None = None
    bsdf_names: Mapping[str, str] = field(default_factory=dict)
    roughness: RoughnessConvention | None = None
    bsdf_roughness: Mapping[str, RoughnessConvention] = field(default_factory=dict)
    bsdf_params: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    render_samplers: tuple[str, ...] = ()
    harness: str = ""
    adaptive: object | None = None
    pixel_filter: object | None = None
    pixel_filter_note: str = ""
    estimator_note: str = ""

    def __post_init__(self):
        if self.heuristic not in _HEURISTICS:
            raise ParameterError(f"unknown heuristic {self.heuristic!r}")
        if set(self.strategies) != set(STRATEGY_NAMES):
            raise ParameterError(f"a renderer record sets every strategy of {STRATEGY_NAMES}")
        if sum(s.default for s in self.samplers.values()) != 1:
            raise ParameterError("a renderer record has exactly one default sampler")

    @property
    def default_sampler(self) -> str:
        """The renderer's default sampler (pattern)."""
        return next(n for n, s in self.samplers.items() if s.default)

    @property
    def modelled_samplers(self) -> tuple:
        """The names of the samplers envfit predicts (every one without
        :attr:`SamplerSpec.unmodelled`)."""
        return tuple(n for n, s in self.samplers.items() if not s.unmodelled)

    def sampler(self, name=None) -> SamplerSpec:
        """The sampler called ``name`` (the default for None); ParameterError otherwise,
        and for a sampler envfit does not predict (its :attr:`SamplerSpec.unmodelled`)."""
        key = self.default_sampler if name is None else name
        try:
            spec = self.samplers[key]
        except (KeyError, TypeError):
            raise ParameterError(f"--sampler for {self.name} must be one of "
                                 f"{', '.join(self.modelled_samplers)}; got {name!r}") from None
        if spec.unmodelled:
            ok = self.modelled_samplers
            raise ParameterError(f"no noise model of {self.display}'s {key} sampler: "
                                 f"{spec.unmodelled}; choose --sampler "
                                 f"{', '.join(ok[:-1])} or {ok[-1]}")
        return spec

    def strategy(self, name) -> StrategySetting:
        """The setting of strategy ``name`` (``map``, ``brdf``, ``mis``)."""
        try:
            return self.strategies[name]
        except (KeyError, TypeError):
            raise ParameterError(f"strategy must be one of {', '.join(STRATEGY_NAMES)}; "
                                 f"got {name!r}") from None

    def mis_weights(self, pdf_map, pdf_brdf, strategy: str = "mis"):
        r"""The weights (map, BSDF) of the two techniques at the same directions, as the
        renderer's integrator weights its samples for ``strategy``: the heuristic with the
        sample fractions :math:`n_e/(n_e+n_b)`, :math:`n_b/(n_e+n_b)` (Mitsuba's
        ``m_frac_lum``, ``m_frac_bsdf``); weight 1 for the only technique of ``map`` or
        ``brdf``."""
        s = self.strategy(strategy)
        total = s.emitter_samples + s.bsdf_samples
        fa, fb = s.emitter_samples / total, s.bsdf_samples / total
        h = _HEURISTICS[self.heuristic]
        return h(pdf_map, pdf_brdf, fa, fb), h(pdf_brdf, pdf_map, fb, fa)

    @property
    def possessive(self) -> str:
        """The display name's possessive ("Mitsuba 3's", "Cycles'")."""
        d = self.display or self.name
        return d + ("'" if d.endswith("s") else "'s")

    def snippet_options(self) -> tuple[str, ...]:
        """The keyword options the renderer's snippet takes (``filename`` always)."""
        import inspect
        return tuple(n for n, a in inspect.signature(self.snippet_fn).parameters.items()
                     if a.kind is a.KEYWORD_ONLY)

    def roughness_of(self, name: str):
        """The roughness convention of the microfacet BSDF ``name``: its own
        (:attr:`bsdf_roughness`) or the renderer's (:attr:`roughness`)."""
        return self.bsdf_roughness.get(name, self.roughness)

    def bsdf(self, name: str, alpha: float, **params):
        """The microfacet BSDF ``name`` (a ``--brdf`` name: ``ggx``, ``beckmann``, …) of
        roughness α as this renderer shades and samples it (:attr:`bsdf_fn`; ``params``: its
        η + ik or a plastic's reflectances). A BSDF that one other renderer alone has is
        refused naming that renderer; the renderer's own function refuses the rest.

        >>> from envfit.renderers import get_renderer
        >>> get_renderer("pbrt4").bsdf("ggx", 0.3).shadowing
        'height_correlated'
        """
        if name not in self.microfacet:
            from envfit.renderers._registry import RENDERERS
            owners = [r for r in RENDERERS.values() if name in r.microfacet]
            if len(owners) == 1:
                o = owners[0]
                raise ParameterError(f"--brdf {name} is {o.possessive} "
                                     f"{o.bsdf_names.get(name, name)}: --renderer {o.name}")
        if self.bsdf_fn is None:
            raise ParameterError(f"{self.display or self.name} has no microfacet BSDF")
        return self.bsdf_fn(name, alpha, **params)

    def harness_module(self):
        """The module of :attr:`harness` (ParameterError where the renderer has none)."""
        if not self.harness:
            raise ParameterError(f"envfit renders nothing with {self.display or self.name}")
        import importlib
        return importlib.import_module(self.harness)

    def snippet(self, strategy: str, sampler=None, spp: int = 64, **options) -> str:
        """The scene text a user pastes for ``strategy`` with ``sampler`` at ``spp``
        (rounded as the renderer rounds it); ParameterError for a strategy the renderer
        cannot render. ``options`` go to the renderer's snippet (all take ``filename``;
        Mitsuba 3, pbrt-v4 and Cycles ``sphere_pixels``; Mitsuba also ``form="python"|"xml"``,
        ``mis_compensation`` and ``microfacet``, pbrt-v4 ``up``)."""
        s = self.strategy(strategy)
        if not s.renderable:
            raise ParameterError(f"{self.name} cannot render strategy {strategy!r}: {s.note}")
        spec = self.sampler(sampler)
        return self.snippet_fn(s, spec, spec.spp(spp), **options)
