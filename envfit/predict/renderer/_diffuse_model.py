r"""A real renderer's noise on a white diffuse surface, predicted from its record: the
renderer's own estimator (technique, cosine map and frame, MIS weights and sample counts,
:mod:`envfit.renderers`), its sampler's randomisation of the square samples
(:mod:`envfit.predict.renderer.randomisation`), averaged over uniform normals as the sphere
measurement of :mod:`envfit.renderers` averages them.

For a strategy with one emitter and/or one BSDF sample per spp and N = the spp the sampler
runs (its own rounding, :meth:`~envfit.renderers.SamplerSpec.spp`), the pixel value at
normal n is :math:`F = \frac1N\sum_j h_e(u_j) + \frac1N\sum_j h_b(u'_j)` with the warped
integrands of :mod:`._integrand_tables`, and

.. math::  \mathrm{MSE} = \frac13\sum_c \int_{S^2} E(F_c(n) - I_c(n))^2\,\frac{dn}{4\pi}
           \approx \frac13\sum_c\sum_a \varpi_a\, \mathrm{MSE}_c(n_a),

:math:`\mathrm{MSE}_c(n_a)` the exact MSE of the randomisation (``randomised_mse`` for one
technique, ``mis_mse`` for two streams: independent dimensions, or one shared net for a sampler
that gives every dimension the same randomised net) from the
:class:`~envfit.predict.renderer.randomisation.DyadicGrid` of each part. The normals
:math:`n_a` are drawn systematically from a spherical Fibonacci pool
of P normals with probability
:math:`\pi_a = \frac13(\frac1P + \frac{v_e(a)}{\sum v_e} + \frac{v_b(a)}{\sum v_b})`,
:math:`v_e(a) = E_u[h_e^2] - I^2` and :math:`v_b(a) = \int L^2\cos^+/\pi - I^2` the
variances of map and BSDF sampling (summed over channels; both by the map part's own table at
a coarse level, which finds a sun), and weighted :math:`\varpi_a \propto 1/(P\pi_a)` —
unbiased for the pool mean; a sun that makes a few normals dominate is not missed (as
:func:`envfit.predict.warped._axis_proposal.proposal_axes` does for envfit's techniques).

The cell a renderer runs — its spp rounded, its randomisation and the grid level — is
:func:`._cell_request.cell_request`.

Cost (measured, AMD EPYC, 2 cores, idle): a 1024 × 512 map (city.exr), four samplers
(independent, jittered, CMJ, a digital shift) × map/brdf/mis × spp 16, 64, 256 in one
:meth:`DiffuseModel.predict_many`: 21 s with 8 normals, ≈ 2.5 s per normal (tables at level 10:
1 M integrand points per part; the L = 9 Walsh transforms of the digital shift at 256 spp
dominate); with spp 1024 too (tables at level 11, 4 M points) ≈ 10 s per normal. On the shared
machine under load ≈ 20 the same work took 4×.

Reference: Marques, Bouville, Bouatouch (the spectral view of a shading integral's error);
the renderer's integrator and samplers as its folder cites them (``envfit/renderers/<name>``).
"""
from __future__ import annotations

import math
import time
import weakref
from dataclasses import dataclass, field, replace

import numpy as np

from envfit.base import ParameterError
from envfit.base import progress
from envfit.predict.renderer._footprint import (_STREAMS, FootprintSums, PairedFootprint,
                                                footprint_term, nearest_views,
                                                pixel_footprints)
from envfit.predict.renderer._model_error import (draws_error, larger_error, larger_error_parts,
                                                 model_error)
from envfit.predict.renderer._integrand_tables import (BsdfTable, MapTable, bsdf_values,
                                                       map_values, midpoints, mis_parts,
                                                       moment_pyramid)
from envfit.predict.renderer._cell_request import (CellRequest, grid_level, cell_request,
                                                     samples_above)
from envfit.predict.renderer._sampled_nets import SAMPLE_TAG, SampledNets, curve_parts
from envfit.predict.renderer.randomisation import (ALWAYS_DRAWN, DyadicGrid, mis_mse,
                                                   randomised_mse)
from envfit.predict.renderer._drawn_strata import DrawnStrata, geometric
from envfit.theory import spherical_fibonacci_sphere

__all__ = ["RendererModelOptions", "DiffuseModel", "RendererPrediction", "grid_level",
           "samples_above", "cell_request", "systematic_indices"]

@dataclass(frozen=True)
class RendererModelOptions:
    """Settings of :class:`DiffuseModel`.

    Attributes
    ----------
    normals : K, the normals of the importance sample (more: a smaller sampling error of the
        mean over normals).
    pool : P, the spherical Fibonacci normals they are drawn from.
    max_level : the finest grid level (M = 2^max_level); the integrand is tabulated at level
        max_level + 1.
    pilot_level : level of the map-part table that gives the normals' proxies.
    sphere_pixels : None (default: each normal a point), or R: the normals are pixels of the
        sphere renders of :mod:`envfit.renderers`, R pixels across, each in the view
        nearest it (their ``cube`` layout); each pixel's footprint (``footprint_side`` ²
        normals) adds its term (:mod:`._footprint`), and the tables cost footprint_side² times
        as much.
    footprint_side : side of the footprint's grid of normals (default 2).
    pixel_filter : the :class:`~envfit.renderers.FilmWarp` of the renders' pixel filter —
        where a sample lands in its pixel, the footprint's shape; None (default): the
        renderer's default filter (its record's ``pixel_filter``; the box where it has
        none).
    shifts : Q, the random shifts (Owen scrambles) over which a digital shift's (an
        Owen-scrambled net's) power above a grid coarser than 2N is sampled (relative
        standard error ≈ √(2/Q) of that part per normal).
    seed : of those shifts (``numpy.random.default_rng``).
    reach : the largest N of the sampled nets (their table holds Q·reach points per normal);
        None: 4^(max_level+1)/Q, the fine table's size.
    """

    normals: int = 48
    pool: int = 1024
    max_level: int = 9
    pilot_level: int = 6
    sphere_pixels: int | None = None
    footprint_side: int = 2
    shifts: int = 256
    seed: int = 0
    reach: int | None = None
    pixel_filter: object | None = None

    def __post_init__(self):
        for name, lo, hi in (("normals", 1, 4096), ("pool", 1, 1 << 16), ("max_level", 1, 11),
                             ("pilot_level", 1, 10), ("sphere_pixels", 4, 1 << 16),
                             ("footprint_side", 1, 8), ("shifts", 4, 1 << 16),
                             ("seed", 0, 2 ** 63 - 1), ("reach", 1, 1 << 20)):
            v = getattr(self, name)
            if name in ("sphere_pixels", "reach") and v is None:
                continue
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
                raise ParameterError(f"{name} must be an integer from {lo} to {hi}, got {v!r}")
        if self.normals > self.pool:
            raise ParameterError("normals must not exceed pool")
        if self.pixel_filter is not None and not callable(getattr(self.pixel_filter,
                                                                  "variance_scale", None)):
            raise ParameterError("pixel_filter must be a FilmWarp (envfit.renderers) or None")

    def film(self, renderer):
        """The pixel filter's film warp: :attr:`pixel_filter`, else the renderer's default
        (its record's ``pixel_filter``), else the box."""
        from envfit.renderers import film_of
        return film_of(renderer, self.pixel_filter)


@dataclass(frozen=True)
class RendererPrediction:
    """One predicted cell.

    Attributes
    ----------
    rmse : √(mean over channels of the MSE averaged over uniform normals) — what the sphere
        measurement reports.
    mse : the MSE per channel (C,).
    strategy, sampler : as asked.
    spp : spp asked; ``spp_rendered`` : the spp the sampler runs.
    emitter_samples, bsdf_samples : samples of each technique per spp.
    randomisation : the registry name used; ``shared`` : one point set for both streams.
    level : grid level (M = 2^level).
    parts : mean over normals and channels of the map part's MSE, the BSDF part's and the
        cross term 2·C₁₂ (keys ``map``, ``brdf``, ``cross``).
    normals : K.
    model_se : the relative standard error of ``rmse`` from what the model samples — its
        normals and the randomisations above the grid (:func:`._model_error.model_error`);
        None for one normal. ``model_se_parts``: (normals', randomisations') relative errors.
    """

    rmse: float
    mse: np.ndarray
    strategy: str
    sampler: str
    spp: int
    spp_rendered: int
    emitter_samples: int
    bsdf_samples: int
    randomisation: str
    shared: bool
    level: int
    parts: dict = field(default_factory=dict)
    normals: int = 0
    model_se: float | None = None
    model_se_parts: tuple = ()


def _serpentine_pool(m: int) -> np.ndarray:
    """m spherical Fibonacci normals in serpentine order (bands of z, φ alternating), so
    that systematic sampling along the order stratifies the sphere (as
    ``_axis_proposal._fibonacci_axes``)."""
    pts = spherical_fibonacci_sphere(m)
    phi = np.mod(np.arctan2(pts[:, 1], pts[:, 0]), 2.0 * np.pi)
    bands = max(1, round(math.sqrt(m / 2.0)))
    band = np.minimum((0.5 * (1.0 - pts[:, 2]) * bands).astype(int), bands - 1)
    return pts[np.lexsort((np.where(band % 2 == 0, phi, -phi), band))]


def systematic_indices(p: np.ndarray, count: int) -> np.ndarray:
    """``count`` indices drawn from probabilities ``p`` (any scale) by systematic sampling at
    the midpoints ((j + ½)/count of the cumulative distribution).

    >>> systematic_indices(np.array([1.0, 0.0, 3.0]), 4).tolist()
    [0, 2, 2, 2]
    """
    cdf = np.cumsum(p)
    return np.minimum(np.searchsorted(cdf / cdf[-1], (np.arange(count) + 0.5) / count),
                      len(p) - 1)


def _proposal(table: MapTable, pool: np.ndarray, count: int):
    """(normals (K, 3), weights (K,) summing to 1) by systematic sampling of the pool with
    the proxies v_e, v_b of the module docstring."""
    cos = np.clip(pool @ table.directions.T, 0.0, None)                    # (P, Q)
    q = cos.shape[1]
    b2 = (table.base ** 2).sum(axis=1)
    mean2 = (((cos @ table.base) / q) ** 2).sum(axis=1)                     # Σ_c I_c²
    v_e = np.clip((cos ** 2) @ b2 / q - mean2, 0.0, None)
    v_b = np.clip(cos @ (b2 * np.pi * table.pdf) / q - mean2, 0.0, None)
    pi = np.full(len(pool), 1.0 / len(pool))
    for m in (v_e, v_b):
        pi = pi + (m / m.sum() if m.sum() > 0 else 1.0 / len(pool))
    pi /= 3.0
    idx = systematic_indices(pi, count)
    w = 1.0 / (len(pool) * pi[idx])
    return pool[idx], w / w.sum()


#: the :class:`PairedFootprint` of every model alive, by (the sampler's ``film_points`` and
#: ``lobe_points``, N, pixels, seed, dimensions): the same points and what they derive, so
#: that a model made after another (a sized model's final search after its pilot's) reuses
#: them rather than draws them again; an entry goes with the last model that holds it
_PAIRINGS: "weakref.WeakValueDictionary" = weakref.WeakValueDictionary()


class DiffuseModel(DrawnStrata):
    r"""The noise model of one map under one renderer (module docstring).

    Parameters
    ----------
    envmap : EnvMap
        The map, its pixels as the renderer reads the file.
    renderer : Renderer
        From :func:`envfit.renderers.get_renderer`.
    technique_options : dict, optional
        For the renderer's technique factory (e.g. ``mis_compensation`` where the record's
        :attr:`~envfit.renderers.Renderer.mis_compensation` says the emitter has it).
    options : RendererModelOptions, optional
    technique : optional
        The technique already built from this map, renderer and options (another model's
        :attr:`technique`): not built again.

    Examples
    --------
    >>> import numpy as np
    >>> from envfit.maps import EnvMap
    >>> from envfit.renderers import get_renderer
    >>> m = DiffuseModel(EnvMap(np.full((8, 16, 3), 2.0)), get_renderer("mitsuba3"),
    ...                 options=RendererModelOptions(normals=4, pool=16, max_level=3))
    >>> m.predict("brdf", "independent", 16).rmse        # cosine sampling of a constant map
    0.0
    """

    #: the parts kept per footprint normal in a pass (:meth:`_paired`), set by :meth:`_run`
    _keep: frozenset = frozenset()
    #: no progress bar over a pass's normals (frames) when true; its text and unit
    quiet, progress_label, progress_unit = True, "renderer model", "normal"

    def __init__(self, envmap, renderer, technique_options: dict | None = None,
                 options: RendererModelOptions | None = None, *, technique=None):
        self.renderer = renderer
        self.options = options or RendererModelOptions()
        self.technique = (technique if technique is not None else
                          renderer.technique(envmap, **(technique_options or {})))
        pilot = MapTable.build(self.technique, self.options.pilot_level)
        self.normals, self.weights = _proposal(pilot, _serpentine_pool(self.options.pool),
                                               self.options.normals)
        self.film = self.options.film(renderer)
        if self.options.sphere_pixels is not None:
            foot = pixel_footprints(self.normals, nearest_views(self.normals),
                                    self.options.sphere_pixels, self.options.footprint_side,
                                    self.film)
            self.normals = list(zip(self.normals, foot))
        self._tables: dict = {}
        self._cache: dict = {}
        self.seconds = 0.0

    def request(self, strategy: str, sampler: str, spp: int) -> CellRequest:
        """The cell as the renderer runs it: spp rounded, randomisation and its options
        (:func:`cell_request`)."""
        return cell_request(self.renderer, self.options, strategy, sampler, spp)

    def predict(self, strategy: str, sampler: str, spp: int) -> RendererPrediction:
        """The predicted cell (:class:`RendererPrediction`); cached."""
        return self.predict_many([(strategy, sampler, spp)])[0]

    def predict_many(self, cells) -> list[RendererPrediction]:
        """Predictions of many (strategy, sampler, spp) cells in one pass over the normals
        (none where every cell is cached, or lies between powers of two whose predictions
        and prefix variances an earlier pass made: :mod:`._sampled_nets`)."""
        reqs = [self.request(*c) for c in cells]
        between = {r for r in reqs if r not in self._cache and self._is_between(r)}
        anchors = {a for r in between for a in self._anchors(r)}
        todo = list({r for r in reqs if r not in self._cache and r not in between}
                    | {a for a in anchors if a not in self._cache})
        if todo:                                # a shared sequence's whole bracket of N
            todo += [r for r in self._drawn_brackets(todo) if r not in self._cache
                     and r not in todo]
        nets = {r for r in between if not self._geometric(r)}       # prefix variances
        want = {r.strategy: r.shared for r in nets}
        top = max((a.n for r in nets for a in self._anchors(r)), default=0)
        curves = bool(nets) and not self.nets.has_curves(want, top)
        pre = [r for r in todo if self._prefix_net(r)]      # a prefix sampler's pass: its
        if pre:                                             # variances for later N, too
            want.update({r.strategy: r.shared for r in pre})
            top, curves = max([top] + [r.n for r in pre]), True
        if todo or curves:
            t = time.perf_counter()
            self._run(todo, curve_top=top if curves else 0, curve_strategies=want)
            self.seconds += time.perf_counter() - t
        for r in between:
            lo, hi = (self._cache[a] for a in self._anchors(r))
            mse = (geometric(r.n, lo, hi) if self._geometric(r) else
                   self.nets.between(r.strategy, r.shared, r.n, lo.mse, hi.mse))
            f = float(np.mean(mse)) / float(np.mean(lo.mse)) if np.mean(lo.mse) > 0 else 0.0
            self._cache[r] = replace(lo, rmse=float(np.sqrt(np.mean(mse))), mse=mse,
                                     spp=r.spp, spp_rendered=r.n,
                                     parts={k: v * f for k, v in lo.parts.items()},
                                     model_se=larger_error(lo.model_se, hi.model_se),
                                     model_se_parts=larger_error_parts(lo.model_se_parts,
                                                                       hi.model_se_parts))
        return [replace(self._cache[r], spp=r.spp) for r in reqs]

    #: the model answers N between powers of two of a prefix sampler (:mod:`._sampled_nets`)
    between_powers = True
    #: the passes over the normals run so far
    runs = 0

    def _footprinted(self) -> bool:
        """Whether the normals are pixels with a footprint (the grid's tables give its term
        even where every cell of a pass is drawn)."""
        return self.options.sphere_pixels is not None

    def _prefix_net(self, r: CellRequest) -> bool:
        """Whether ``r`` is an Owen-scrambled prefix sampler's, whose N between powers of two
        the model answers from prefix variances (no footprint: its term is not calibrated)."""
        return (r.prefix and r.name == "owen" and self.between_powers
                and self.options.sphere_pixels is None)

    def _geometric_prefix(self, r: CellRequest) -> bool:
        """Whether ``r`` is a prefix sampler's whose N between powers of two is interpolated
        geometrically (no model here; :class:`.MicrofacetModel`'s two-lobe BSDFs)."""
        return False

    def _geometric(self, r: CellRequest) -> bool:
        """Whether ``r``'s N between its anchors is interpolated geometrically
        (:func:`._drawn_strata.geometric`) rather than from prefix variances."""
        return self._drawn_strata(r) or self._geometric_prefix(r)

    def _is_between(self, r: CellRequest) -> bool:
        """Whether ``r`` is a prefix sampler's (:meth:`_prefix_net`) N between powers of two,
        or a drawn stratified cell's (:meth:`_drawn_strata`) between the spp its sampler runs
        at powers of two (:meth:`_strata_anchors`)."""
        if self._drawn_strata(r):
            return r.name not in ALWAYS_DRAWN and r.n not in self._strata_anchors(r)
        return (self._prefix_net(r) or self._geometric_prefix(r)) and r.n & (r.n - 1) != 0

    def _anchors(self, r: CellRequest) -> tuple[CellRequest, CellRequest]:
        """The requests of the powers of two around ``r.n`` (a drawn stratified cell's: of
        :meth:`_strata_anchors`)."""
        if self._drawn_strata(r):
            return tuple(self.request(r.strategy, r.sampler, a)
                         for a in self._strata_anchors(r))
        lo = 1 << (r.n.bit_length() - 1)
        return tuple(replace(r, spp=m, n=m, level=grid_level(r.name, m, self.options.max_level))
                     for m in (lo, 2 * lo))

    @property
    def nets(self) -> SampledNets:
        """The passes' sampled nets (:class:`._sampled_nets.SampledNets`)."""
        if "_nets" not in self.__dict__:
            o = self.options                        # one draw to the sampled spp cap
            self._nets = SampledNets(o.shifts, o.seed,
                                     o.reach or 4 ** (o.max_level + 1) // o.shifts)
        return self._nets

    def _table(self, kind: str, where):
        """The ``map`` or ``bsdf`` table at the midpoints of level ``where`` (an int), or at
        the shifted points of :meth:`_shifts` (``where`` = its N)."""
        key = (kind, where)
        if key not in self._tables:
            u = self._points(where)
            self._tables[key] = (MapTable.at(self.technique, u) if kind == "map"
                                 else BsdfTable.at(self.renderer, u))
        return self._tables[key]

    def _points(self, where) -> np.ndarray:
        """A table's square points: level ``where``'s midpoints or :meth:`_shifts` (*where)."""
        return midpoints(where) if isinstance(where, int) else self.nets.sample(*where).points

    def _fractions(self, strategy: str) -> tuple[float, float]:
        s = self.renderer.strategy(strategy)
        tot = s.emitter_samples + s.bsdf_samples
        return s.emitter_samples / tot, s.bsdf_samples / tot

    def _part_values(self, strategies: set, normal, fine: int) -> dict:
        """The tabulated parts at one normal: ``map`` (h_e alone), ``brdf`` (h_b alone) and
        ``mis_e``, ``mis_b``, ``mis_t`` (weighted, and their sum); for a (normal, footprint)
        pair, their means over the footprint with its ``_var_c`` and ``_var_a``
        (:class:`._footprint.FootprintSums`)."""
        if isinstance(normal, tuple):
            sums = FootprintSums(keep=self._keep if isinstance(fine, int) else (),
                                 scale=self.film.variance_scale(self.options.footprint_side))
            for x in normal[1]:
                sums.add(self._point_parts(strategies, x, fine))
            return sums.parts()
        return self._point_parts(strategies, normal, fine)

    def _point_parts(self, strategies: set, normal, fine: int) -> dict:
        """:meth:`_part_values` at one normal."""
        out = {}
        need_map = bool(strategies & {"map", "mis"})
        need_bsdf = bool(strategies & {"brdf", "mis"})
        fr = self._fractions("mis")
        if need_map:
            out["map"], we = map_values(self._table("map", fine), normal, fr)
        if need_bsdf:
            out["brdf"], wb = bsdf_values(self.technique, self.renderer,
                                          self._table("bsdf", fine), normal, fr)
        if "mis" in strategies:
            out["mis_e"], out["mis_b"], out["mis_t"] = mis_parts(out["map"], we, out["brdf"],
                                                                 wb)
        else:
            if need_map:
                out["mis_e"] = out["map"] * we[:, None]
            if need_bsdf:
                out["mis_b"] = out["brdf"] * wb[:, None]
        return out

    def _run(self, todo: list, curve_top: int = 0, curve_strategies=None) -> None:
        """One pass over the normals (frames) for the requests ``todo``: each one's MSE and
        parts per normal, then :meth:`_store`; with ``curve_top``, the prefix variances of
        ``curve_strategies`` (strategy → shared) to it (:class:`._sampled_nets.SampledNets`)."""
        fine = max([self.options.max_level] + [r.level for r in todo]) + 1  # never coarser
        strategies = {r.strategy for r in todo} | set(curve_strategies or ())
        levels = {r.level for r in todo} or {self.options.max_level}
        self._keep = {p for r in todo if self._paired(r) for p in _STREAMS[r.strategy]}
        self._plan_drawn(todo)
        self.nets.plan([r for r in todo if samples_above(r.name, r.n, r.level)], curve_top,
                       curve_strategies)
        self.runs += 1
        k = len(self.normals)
        per = {r: [None] * k for r in todo}                  # mse (C,) per normal
        draws = {r: 0.0 for r in todo}                       # Σ_a w_a (sampled, per draw)
        grid_cells = any(not self._drawn_strata(r) for r in todo) or (  # not all drawn, or
            bool(todo) and self._footprinted())                         # their footprints
        parts = {r: np.zeros((k, 3)) for r in todo}          # map, brdf, cross per normal
        for i, normal in enumerate(progress(self.normals, total=k, desc=self.progress_label,
                                            quiet=self.quiet, unit=self.progress_unit)):
            vals = self._part_values(strategies, normal, fine) if grid_cells else {}
            grids: dict = {"normal": normal, "strategies": strategies}
            for r in todo:
                res = self._cell(r, vals, grids, fine, levels)
                per[r][i] = np.asarray(res[0], dtype=np.float64)
                parts[r][i] = [float(np.mean(x)) for x in res[1:]]
                draws[r] = draws[r] + float(self.weights[i]) * self._draws(r, grids)
            if curve_top:
                self.nets.add_curves(float(self.weights[i]),
                                     self._sampled_values(grids, "owen", strategies))
        self.nets.finish_curves()
        for key in [k for k in self._tables if k[0] == "strata"]:
            del self._tables[key]                   # a drawn cell's tables serve one pass
        for r in todo:
            self._store(r, np.stack(per[r]), parts[r], draws_error(np.atleast_1d(draws[r])))

    def _sampled_values(self, grids: dict, tag: str, strategies, n: int = 0) -> dict:
        """The parts at one normal at the pass's table of ``tag`` (at least N points;
        computed once per normal, kept in ``grids``)."""
        top = max(int(n), self.nets.top)
        if ("sampled", tag, top) not in grids:
            grids["sampled", tag, top] = self._part_values(set(strategies), grids["normal"],
                                                           (tag, top))
        return grids["sampled", tag, top]

    def _store(self, r: CellRequest, mse_k: np.ndarray, parts_k: np.ndarray,
               shift_se: float = 0.0) -> None:
        """The prediction of ``r`` from its MSE (K, C) and parts (K, 3) per normal: the
        weighted means, and the model's error with the sampled randomisations' standard error
        ``shift_se`` (:mod:`._model_error`)."""
        mse = np.clip(self.weights @ mse_k, 0.0, None)
        a = self.weights @ parts_k
        s = self.renderer.strategy(r.strategy)
        self._cache[r] = RendererPrediction(
            float(np.sqrt(np.mean(mse))), mse, r.strategy, r.sampler, r.spp, r.n,
            s.emitter_samples, s.bsdf_samples, r.name, r.shared, r.level,
            {"map": float(a[0]), "brdf": float(a[1]), "cross": float(a[2])}, len(self.normals),
            *model_error(self.weights, mse_k.mean(axis=1), shift_se, parts=True))

    def _cell(self, r: CellRequest, vals: dict, grids: dict, fine: int, levels):
        """(mse, map part, BSDF part, 2·cross) per channel of one request at one normal (or
        frame): the randomised parts, plus the pixel footprint's term when ``vals`` has one
        (:func:`._footprint.footprint_term`)."""
        res = self._randomised_cell(r, vals, grids, fine, levels)
        if "_normals" in vals and self._paired(r):
            extra = self._paired_extra(r, vals)
        else:
            extra = footprint_term(r.strategy, r.name, r.n, vals)
        return (res[0] + extra,) + tuple(res[1:])

    def _paired_extra(self, r: CellRequest, vals: dict) -> np.ndarray:
        """The MSE (C,) the film adds to ``r`` at one frame under a paired film
        (:meth:`_paired`): :meth:`._footprint.PairedFootprint.extra` of its streams."""
        return self._pairing(r).extra(vals["_normals"], r.strategy, self._calls(r),
                                      means=vals)[0]

    def _paired(self, r: CellRequest) -> bool:
        """Whether the film's pairing with the techniques is simulated over the sampler's own
        points (its record's ``film_points``: :class:`._footprint.PairedFootprint`) rather than
        taken as random (:func:`._footprint.footprint_term`)."""
        spec = self.renderer.sampler(r.sampler)
        return (r.name == "digital_shift" and spec.pairing == "same_net_permuted"
                and spec.film_points is not None)

    def _calls(self, r: CellRequest) -> tuple[int, int]:
        """The sampler calls of the emitter's and the BSDF's draws of ``r``'s strategy
        (:attr:`envfit.renderers.StrategySetting.calls`; where the record has none, the
        emitter's first and the BSDF's after every emitter sample)."""
        s = self.renderer.strategy(r.strategy)
        return s.calls if s.calls is not None else (1, 1 + s.emitter_samples)

    def _pairing(self, r: CellRequest) -> PairedFootprint:
        """The :class:`._footprint.PairedFootprint` of cell ``r``'s sampler at N spp: its own
        film points, in every dimension to any strategy's last draw (:meth:`_pairing_dims`),
        for :meth:`paired_pixels` pixels, seeded by ``options.seed``; the same pixels as
        another model's alive with the same sampler points, N, pixels, seed and dimensions
        (:data:`_PAIRINGS`)."""
        n, dims = r.n, self._pairing_dims()
        key = ("paired", r.sampler, n, dims)
        if key not in self._tables:
            spec = self.renderer.sampler(r.sampler)
            pixels = self.paired_pixels(n)
            shared = (spec.film_points, spec.lobe_points, n, pixels, self.options.seed, dims)
            pairing = _PAIRINGS.get(shared)
            if pairing is None:
                pairing = PairedFootprint(n, pixels, self.options.seed, spec.film_points,
                                          dims, spec.lobe_points)
                _PAIRINGS[shared] = pairing
            self._tables[key] = pairing
        return self._tables[key]

    def paired_pixels(self, n: int) -> int:
        r"""The pixels :meth:`_pairing` simulates at N spp: :math:`\max(Q, S/N)` with
        :math:`S = \min(2^{14} Q, 2^{20})` samples (Q = ``options.shifts``): their spread
        over Q groups is part of the model's error (:meth:`_draws`), which then falls as
        :math:`1/\sqrt Q` as the sampled randomisations' does — what a sized model's pilot
        (Q = 16: 2^18 samples) assumes of its final model (Q = 64: 2^20;
        :func:`envfit.advisor._renderer_sizing.predicted_error`).

        >>> from envfit.maps import EnvMap
        >>> from envfit.renderers import get_renderer
        >>> m = DiffuseModel(EnvMap(np.ones((8, 16, 3))), get_renderer("mitsuba3"),
        ...                  options=RendererModelOptions(shifts=16, normals=4))
        >>> m.paired_pixels(1), m.paired_pixels(1024), m.paired_pixels(1 << 20)
        (262144, 256, 16)
        """
        q = int(self.options.shifts)
        return max(q, min(q << 14, 1 << 20) // int(n))

    def _pairing_dims(self) -> int:
        """The dimensions of :meth:`_pairing`'s points: to the last 2-D draw of any strategy
        of the renderer (:meth:`_calls`; a lobe's number is the record's ``lobe_points``,
        not these points), so that every strategy's cells at N read one draw of them (a
        sampler's ``film_points`` of fewer dimensions are these points' first ones:
        :attr:`envfit.renderers.SamplerSpec.film_points`)."""
        dims = 3
        for name in self.renderer.strategies:
            s = self.renderer.strategy(name)
            calls = s.calls if s.calls is not None else (1, 1 + s.emitter_samples)
            dims = max(dims, max(calls) + 1)
        return dims

    def _randomised_cell(self, r: CellRequest, vals: dict, grids: dict, fine: int, levels):
        """:meth:`_cell` without the footprint: the tables randomised as the sampler does."""
        def grid(part):
            key = (part, r.level)
            if key not in grids:
                if part not in grids:
                    grids[part] = moment_pyramid(vals[part], fine, levels)
                a, b = grids[part][r.level]
                grids[key] = DyadicGrid.from_arrays(a, np.maximum(b, a * a))
            if samples_above(r.name, r.n, r.level) and (r.name, "sobol", r.n) not in \
                    grids[key].sampled:
                grids[key] = self._with_sampled(grids, key, part, r)
            return grids[key]

        if self._drawn_strata(r):
            return self._strata_cell(r, grids)
        opts = dict(r.options)
        if r.strategy in ("map", "brdf"):
            res = randomised_mse(r.name, grid(r.strategy), r.n,
                                 **(opts if r.strategy == "map" else dict(r.options_b)))
            z = np.zeros_like(res.mse)
            parts = (res.mse, z, z) if r.strategy == "map" else (z, res.mse, z)
            return (res.mse,) + parts
        m = mis_mse(r.name, grid("mis_e"), grid("mis_b"), r.n, shared=r.shared,
                    total=grid("mis_t") if r.shared else None,
                    second_options=dict(r.options_b), **opts)
        return m.mse, m.first.mse, m.second.mse, 2.0 * m.cross

    def _draws(self, r: CellRequest, grids: dict):
        """The sampled power above the grids of ``r`` at this normal per draw, the channels'
        mean (Q,), or 0 where nothing is sampled (a two-lobe BSDF's stratified stream); plus
        a two-lobe BSDF's drawn lobe order (``grids["order_draws", r]``, where it has one)."""
        order = grids.get(("order_draws", r), 0.0)
        if ("strata_draws", r) in grids:
            return grids["strata_draws", r] + order
        if not samples_above(r.name, r.n, r.level):
            return order
        tag, out = SAMPLE_TAG[r.name], order
        for part in curve_parts(r.strategy, r.shared):
            if ("above", part, r.level, tag, max(r.n, self.nets.top)) in grids:
                out = out + self.nets.draws(tag, r.level, r.n, grids, part).mean(axis=1)
        return out

    def _with_sampled(self, grids: dict, key, part: str, r: CellRequest) -> DyadicGrid:
        """The grid ``grids[key]`` with its power above sampled at the randomised points of
        r.n: the prefix of the pass's table (:meth:`._sampled_nets.SampledNets.above`)."""
        tag = SAMPLE_TAG[r.name]
        vals = self._sampled_values(grids, tag, {r.strategy} | grids.get("strategies", set()),
                                    r.n)
        above, se = self.nets.above(tag, r.level, r.n, grids[key].mean, vals[part], grids,
                                    part)
        return grids[key].with_sampled_above(r.name, "sobol", r.n, above, se)


#: the former names (of the time the renderers were called "presets")
PresetModel, PresetModelOptions, PresetPrediction = (DiffuseModel, RendererModelOptions,
                                                     RendererPrediction)
