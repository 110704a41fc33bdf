r"""A real renderer's noise on a rough conductor (GGX or Beckmann), predicted per *frame*
(normal n, view ω_o): the view-dependent counterpart of
:class:`~envfit.predict.renderer._diffuse_model.DiffuseModel` (issue 25).

A microfacet lobe is not zonal: the integrand of one pixel depends on the frame (n, ω_o), not on
n alone. For one frame and one spp of the renderer's ``direct`` estimator, the two warped
integrands on the unit square are

.. math:: h_e(u) = \frac{L(\omega(u))\,f(\omega_o, \omega(u))\cos\theta(u)}{p_e(\omega(u))}\,
          w_e(\omega(u)), \qquad
          h_b(u) = L(\omega_b(u))\,\frac{f\cos}{p_b}(u)\,w_b(\omega_b(u)),

ω(u) the emitter's warp (the renderer record's technique), :math:`\omega_b(u)` the
renderer's visible-normal warp and :math:`f\cos/p_b` its sample weight
(:class:`envfit.shading.microfacet.Conductor`: F·G1(ω_o, m) with separable G), :math:`w_e, w_b`
the integrator's MIS weights with :math:`p_b` the BSDF's solid-angle pdf (1 for the only
technique of ``map`` or ``brdf``). They are tabulated at the midpoints of the finest grid
level and handed to the same randomisations as the diffuse model (independent, jittered,
CMJ, digital shift, Owen, and MIS's two streams), so every sampler the diffuse model predicts
is predicted here too.

The average over frames is a weighted mean of the per-frame MSE: the frames and weights are
the caller's — the pixels of a render (:func:`~envfit.predict.renderer.pixel_frames`: the kept pixels of
:mod:`envfit.renderers`' six views, weighted as its RMSE weights them), or frames
with the view at a polar angle θ_o in a band and the map's orientation uniform
(:func:`~envfit.predict.renderer.band_frames`: θ_o with density ∝ cos θ_o sin θ_o, what an orthographic camera sees of
a sphere).

A rendered pixel averages its footprint: the film position is two more dimensions of the
estimator, paired with the techniques' at random, or, for a sampler with its own
``film_points`` (:attr:`envfit.renderers.SamplerSpec.film_points`), in the order the sampler
gives them. Given each frame's footprint normals
(:func:`pixel_footprints`), the model randomises the footprint's mean integrand and adds the
interaction's share (:mod:`._footprint`: Var c/(N − 1), or simulated over the sampler's
own points with each footprint normal's table) — what a sharp lobe near the limb of a small
sphere adds.

References: E. Heitz, "Sampling the GGX distribution of visible normals", JCGT 7(4) (2018);
the renderer's conductor and integrator as its folder cites them (``envfit/renderers/<name>``).
"""
from __future__ import annotations

import math

import numpy as np

from envfit.base import ParameterError
from envfit.predict.renderer._microfacet_kernels import (compiled_conductor,
                                                        conductor_eval_pdf, conductor_proxies,
                                                        PARTS, accumulate_parts)
from envfit.predict.renderer._vndf_kernels import compiled_sampling, conductor_sample
from envfit.predict.renderer._principled_kernels import two_lobe_kernels
from envfit.predict.renderer._bands import BANDS, STRATA, band_key, band_spread, in_stratum
from envfit.predict.renderer._footprint import _unit, with_variances
from envfit.predict.renderer._lobe_parts import LobeChoice, lobe_choice_modelled
from envfit.predict.renderer._integrand_tables import MapTable
from envfit.predict.renderer.randomisation import ALWAYS_DRAWN, STRATIFIED_1D, strata_points
from envfit.predict.renderer._diffuse_model import (DiffuseModel, RendererModelOptions,
                                                   systematic_indices)

__all__ = ["MicrofacetModel", "BANDS"]

_CHUNK = 1 << 18


class MicrofacetModel(LobeChoice, DiffuseModel):
    r"""The noise model of one map and one rough conductor under one renderer, over
    given frames (module docstring).

    Parameters
    ----------
    envmap : EnvMap
        The map, its pixels as the renderer reads the file.
    renderer : Renderer
        From :func:`envfit.renderers.get_renderer` (its technique, tangent frame, MIS
        heuristic, samplers).
    conductor : envfit.shading.microfacet.Conductor or RoughPlastic
        The BSDF as the same renderer shades and samples it (its record's
        :meth:`~envfit.renderers.Renderer.bsdf`; a rough plastic's BSDF sampling,
        whose lobe takes a third random number: :mod:`._lobe_parts`, :meth:`request`).
    frames : tuple of arrays
        (normals (K, 3), views (K, 3)), world directions; ``weights`` (K,) optional (default
        equal).
    technique_options : dict, optional
    options : RendererModelOptions, optional
        ``max_level`` (the finest grid level) and ``pilot_level`` are read; the normals'
        options are not (the frames are given).
    select : int, optional
        Treat ``frames`` as a pool and keep about this many (at least ``select // 6`` per
        view-angle band present), importance-sampled by the variances of the two techniques
        at each frame (:meth:`_select`); None: every frame.
    footprints : array (K, J, 3), optional
        For rendered pixels (:func:`pixel_footprints`): the normals over each frame's pixel,
        which the renderer's film samples average over. Adds the pixel-footprint term
        (:mod:`._footprint`); J times the tables' work. None: each
        frame is a point (an object of many pixels).
    technique : optional
        The technique already built from this map, renderer and options (another model's
        :attr:`technique`): not built again.

    Examples
    --------
    >>> import numpy as np
    >>> from envfit.maps import EnvMap
    >>> from envfit.renderers import get_renderer
    >>> from envfit.predict.renderer import band_frames
    >>> env = EnvMap(np.full((8, 16, 3), 2.0))
    >>> r = get_renderer("mitsuba3")
    >>> m = MicrofacetModel(env, r, r.bsdf("ggx", 0.3), band_frames(4, seed=0),
    ...                     options=RendererModelOptions(max_level=4))
    >>> round(m.predict("brdf", "independent", 16).rmse, 6) > 0    # G1 varies with m
    True
    """

    progress_unit = "frame"

    def __init__(self, envmap, renderer, conductor, frames, weights=None,
                 technique_options: dict | None = None,
                 options: RendererModelOptions | None = None, select: int | None = None,
                 footprints=None, technique=None):
        normals, views = (np.asarray(f, dtype=np.float64).reshape(-1, 3) for f in frames)
        if len(normals) != len(views) or len(normals) == 0:
            raise ParameterError("frames must be (normals, views) of the same length >= 1")
        w = np.ones(len(normals)) if weights is None else np.asarray(weights, np.float64)
        if w.shape != (len(normals),) or not np.all(w >= 0) or w.sum() <= 0:
            raise ParameterError("weights must be one non-negative number per frame")
        self.renderer, self.conductor = renderer, conductor
        self.options = options or RendererModelOptions()
        self.film = self.options.film(renderer)        # the footprints' pixel filter
        self.technique = (technique if technique is not None      # another model's: reused
                          else renderer.technique(envmap, **(technique_options or {})))
        foot = None
        if footprints is not None:
            foot = np.asarray(footprints, dtype=np.float64)
            if foot.ndim != 3 or foot.shape[0] != len(normals) or foot.shape[2] != 3:
                raise ParameterError("footprints must be (K, J, 3): J normals per frame")
        if select is not None and select < len(normals):
            idx, w = self._select(normals, views, w, int(select))
            normals, views = normals[idx], views[idx]
            foot = None if foot is None else foot[idx]
        self.footprints = foot
        self.normals = list(zip(_unit(normals), _unit(views)))
        if foot is not None:
            self.normals = [(n, v, f) for (n, v), f in zip(self.normals, _unit(foot))]
        self.weights = w / w.sum()
        self.theta = np.degrees(np.arccos(np.clip(np.sum(_unit(normals) * _unit(views), axis=1),
                                                  -1.0, 1.0)))
        self._tables: dict = {}
        self._cache: dict = {}
        self._bands: dict = {}
        self._band_errors: dict = {}
        self.seconds = 0.0

    def _select(self, normals, views, w, count: int):
        r"""``count`` frames of the pool, stratified by the view-angle strata
        (:data:`~envfit.predict.renderer._bands.STRATA`: each at least ``count // 6`` frames,
        the rest by the pool's weight in it) and importance-sampled within each stratum by
        systematic sampling with probability :math:`\pi_a \propto w_a(\frac13 +
        \frac{v_e(a)}{3\sum w v_e} + \frac{v_b(a)}{3\sum w v_b})` (sums over the stratum),
        :math:`v_e, v_b` the variances of emitter and visible-normal sampling at the frame on
        the map part's pilot table (:attr:`RendererModelOptions.pilot_level`); weights
        :math:`w_a/\pi_a`, scaled to sum to the pool's weight in the stratum (the ratio
        estimator of each stratum's mean, Cochran, *Sampling Techniques*, 3rd ed. (1977),
        Sec. 6.10, the "separate" estimator): each band's value is its frames' weighted mean
        and the whole sphere's is the bands' combination with the pool's band weights (not
        weights that a few frames of a sharp lobe put far from them), and a frame whose lobe
        catches a sun is not missed (as the diffuse model's normals)."""
        v_e, v_b = self._proxies(normals, views)
        pw = w / w.sum()
        theta = np.degrees(np.arccos(np.clip(np.sum(_unit(normals) * _unit(views), axis=1),
                                             -1.0, 1.0)))
        strata = [np.flatnonzero(in_stratum(theta, a, b)) for a, b in STRATA]
        strata = [s for s in strata if len(s) and pw[s].sum() > 0]
        floor = max(1, count // 6)
        alloc = [max(floor, int(round(count * pw[s].sum()))) for s in strata]
        idx, wt = [], []
        for s, k in zip(strata, alloc):
            p = pw[s] / 3.0
            for m in (v_e[s], v_b[s]):
                tot = float(pw[s] @ m)
                p = p + (pw[s] * m / tot if tot > 0 else pw[s]) / 3.0
            p = p / p.sum()
            j = systematic_indices(p, k)
            idx.append(s[j])
            raw = pw[s][j] / p[j]
            wt.append(raw * (pw[s].sum() / raw.sum()))
        return np.concatenate(idx), np.concatenate(wt)

    def _proxies(self, normals, views):
        """(v_e, v_b) per frame on the pilot table (:meth:`_select`): compiled for a white
        conductor (:func:`conductor_proxies`), a rough plastic and a principled BSDF
        (:func:`two_lobe_kernels`), else numpy over blocks of frames."""
        tab = MapTable.build(self.technique, self.options.pilot_level)
        frames = np.asarray(self.renderer.tangent_frame(_unit(normals)))
        wis = np.einsum("kij,kj->ki", frames, _unit(views))
        lobes = two_lobe_kernels(self.conductor)
        fast = (conductor_proxies if compiled_conductor(self.conductor)
                else lobes[2] if lobes else None)
        if fast is not None:
            v = fast(self.conductor, wis, frames, tab.directions, tab.base, tab.pdf)
            s2 = np.array([self._scale(w) for w in wis]) ** 2          # energy scale²
            return v[:, 0] * s2, v[:, 1] * s2
        b2 = ((np.pi * tab.base) ** 2).sum(axis=1)                        # Σ_c (L/p_e)²
        v_e, v_b = np.zeros(len(normals)), np.zeros(len(normals))
        size, block = len(tab.directions), max(1, _CHUNK // len(tab.directions))
        for a in range(0, len(frames), block):
            f, w = frames[a:a + block], wis[a:a + block]
            loc = np.einsum("kij,pj->kpi", f, tab.directions).reshape(-1, 3)
            wi = np.repeat(w, size, axis=0)
            fc = self.conductor.eval(wi, loc).reshape(len(f), size)
            pb = self.conductor.pdf(wi, loc).reshape(len(f), size)
            mean2 = (np.einsum("pc,kp->kc", np.pi * tab.base, fc) / size) ** 2
            v_e[a:a + block] = np.maximum(0.0, (b2 * fc * fc).mean(axis=1) - mean2.sum(axis=1))
            with np.errstate(divide="ignore", invalid="ignore"):
                second = np.where(pb > 0, b2 * tab.pdf * fc * fc / pb, 0.0)
            v_b[a:a + block] = np.maximum(0.0, second.mean(axis=1) - mean2.sum(axis=1))
        return v_e, v_b

    def request(self, strategy: str, sampler: str, spp: int):
        """:meth:`DiffuseModel.request`; a BSDF whose sampling takes a lobe choice (a rough
        plastic) is modelled, when it is sampled, for the samplers whose 1-D number is i.i.d.
        or stratified (:mod:`._lobe_parts`; an Owen-scrambled net's coordinate only where the
        sampler's record gives its points, :attr:`envfit.renderers.SamplerSpec.lobe_points`),
        not ``orthogonal``."""
        r = super().request(strategy, sampler, spp)
        if self._two_lobes() and strategy != "map" and not self._lobe_modelled(r.sampler):
            ok = [n for n in self.renderer.samplers if self._lobe_modelled(n)]
            ok = " and ".join([", ".join(ok[:-1]), ok[-1]] if len(ok) > 1 else ok)
            raise ParameterError(f"the {self.conductor.__class__.__name__} BSDF's {strategy} "
                                 f"is modelled for the {ok} samplers (its lobe choice is a "
                                 f"number {sampler} draws in a way not modelled); got {sampler}")
        return r

    def _lobe_modelled(self, sampler: str) -> bool:
        """Whether a two-lobe BSDF's lobe choice is modelled under ``sampler``
        (:func:`._lobe_parts.lobe_choice_modelled`)."""
        return lobe_choice_modelled(self.renderer.sampler(sampler))

    def _geometric_prefix(self, r) -> bool:
        """A two-lobe BSDF under a prefix (Owen-scrambled) sampler: its N between powers of two
        is interpolated geometrically between them (its 3-D prefix variances are not
        computed)."""
        return self._two_lobes() and r.prefix and r.name == "owen"

    @property
    def between_powers(self) -> bool:
        """A conductor's N between powers of two is calibrated like the diffuse surface's
        (:mod:`._sampled_nets`: the prefix variance is the integrand's, whatever the lobe); a
        rough plastic's lobe choice is not sampled, so not its."""
        return not self._two_lobes()

    def _run(self, todo: list, **kw) -> None:
        """:meth:`DiffuseModel._run`, with the lobes' tables when a request needs them."""
        self._lobes = self._lobe_requests(todo)
        self._pass_todo = tuple(todo)                   # a stream's order partner's pass
        self._lobes_only = self._lobes and self.footprints is None and all(
            r.name in STRATIFIED_1D for r in todo if r.strategy != "map")
        super()._run(todo, **kw)

    def _footprinted(self) -> bool:
        return self.footprints is not None

    def _drawn_strata(self, r) -> bool:
        """:meth:`DrawnStrata._drawn_strata` for a one-lobe BSDF: its multi-jittered and
        orthogonal-array cells above the exact models' reach are drawn at each frame
        (:meth:`_drawn_parts`); a shared sequence's runs stay on the grid (``shared_sequence``
        of the grid's prefix sums), and a two-lobe BSDF's cells too (its lobe choice is
        modelled on the grid: :mod:`._lobe_parts`)."""
        return (not self._two_lobes() and r.name not in ALWAYS_DRAWN
                and super()._drawn_strata(r))

    def _drawn_parts(self, key, q: int, length: int, step, r, stream: str, frame) -> dict:
        """:meth:`DrawnStrata._drawn_parts` at one frame (normal, view[, footprint normals]):
        the stream's parts (``e``: ``map``, ``mis_e``; ``b``: ``brdf``, ``mis_b``; Q, N, C) at
        its drawn point sets — the technique's table (``e``) or the BSDF's square points
        (``b``) at them, made once per pass — by :meth:`_sides` as on the grid's tables,
        averaged over a footprint's normals."""
        kind = "map" if stream == "e" else "bsdf"
        if (kind, key) not in self._tables:
            opts = dict(r.options if stream == "e" else r.options_b)
            u = strata_points(r.name, r.n, q, self._stream_seed(r, stream),
                              **opts).reshape(-1, 2)
            self._tables[kind, key] = MapTable.at(self.technique, u) if kind == "map" else u
        normals = frame[2] if len(frame) == 3 else [frame[0]]
        acc = self._accumulated({"map"} if kind == "map" else {"brdf"}, normals, frame[1],
                                key)[0] / len(normals)
        parts = ("map", "mis_e") if kind == "map" else ("brdf", "mis_b")
        return {p: acc[PARTS.index(p)].reshape(q, length, -1) for p in parts}

    def _randomised_cell(self, r, vals: dict, grids: dict, fine: int, levels):
        """:meth:`DiffuseModel._randomised_cell`; a two-lobe BSDF's stream under a stratified
        1-D sampler by :meth:`_lobe_cell`."""
        if self._two_lobes() and r.strategy != "map" and r.name in STRATIFIED_1D:
            return self._lobe_cell(r, vals, grids, fine, levels)
        return super()._randomised_cell(r, vals, grids, fine, levels)

    def predict_bands(self, strategy: str, sampler: str, spp: int) -> dict:
        """The predicted RMSE per view-angle band of :data:`BANDS` ({"0-30": rmse, …}; a band
        with no frame is absent): the weighted mean MSE of the frames whose θ_o lies in it."""
        self.predict(strategy, sampler, spp)
        return dict(self._bands[self._banded(self.request(strategy, sampler, spp))])

    def predict_band_errors(self, strategy: str, sampler: str, spp: int) -> dict:
        """Per view-angle stratum (the bands of :meth:`predict_bands` and ``"80-90"``), and
        ``"all"`` for the whole sphere: ``{"frames", "weight", "rmse", "interval",
        "rel_se"}`` (:func:`~envfit.predict.renderer._bands.band_spread`: the frames in it,
        its share of the weight, its RMSE, the frames' bootstrap interval of it and relative
        standard deviation, None below :data:`~envfit.defaults.BAND_MIN_FRAMES` frames)."""
        self.predict(strategy, sampler, spp)
        return {k: dict(v) for k, v in
                self._band_errors[self._banded(self.request(strategy, sampler, spp))].items()}

    def _banded(self, r):
        r"""``r``, its strata made first if it lies between powers of two (no pass makes
        them): each stratum's share of the whole MSE interpolated between the two exact
        powers of two 2^m < N < 2^(m+1), :math:`(1-t)s(2^m) + t\,s(2^{m+1})` with
        :math:`t = \log_2 N - m`, times the whole's calibrated MSE (:mod:`._sampled_nets`);
        exact at both powers. Its interval is the lower power's scaled, its ``rel_se`` the
        larger of the two."""
        if r in self._band_errors or not self._is_between(r):
            return r
        lo, hi = self._anchors(r)
        t = float(np.log2(r.n / lo.n))
        whole = self._cache[r].rmse ** 2
        out = {}
        for k, a in self._band_errors[lo].items():
            b = self._band_errors[hi].get(k)
            if b is None or not self._cache[lo].rmse > 0 or not self._cache[hi].rmse > 0:
                continue
            share = ((1 - t) * a["rmse"] ** 2 / self._cache[lo].rmse ** 2
                     + t * b["rmse"] ** 2 / self._cache[hi].rmse ** 2)
            rmse = float(np.sqrt(whole * share))
            f = rmse / a["rmse"] if a["rmse"] > 0 else 0.0
            iv = a["interval"]
            out[k] = {**a, "rmse": rmse, "interval": None if iv is None else [x * f for x in iv],
                      "rel_se": (None if a["rel_se"] is None or b["rel_se"] is None
                                 else max(a["rel_se"], b["rel_se"]))}
        self._band_errors[r] = out
        self._bands[r] = {band_key(x, y): out[band_key(x, y)]["rmse"]
                          for x, y in BANDS if band_key(x, y) in out}
        return r

    def _store(self, r, mse_k: np.ndarray, parts_k: np.ndarray, shift_se: float = 0.0) -> None:
        """As :meth:`DiffuseModel._store`, and per view-angle stratum and ``"all"`` its RMSE,
        weight, frames and bootstrap interval
        (:func:`~envfit.predict.renderer._bands.band_spread`: the whole sphere is the bands'
        weighted combination)."""
        super()._store(r, mse_k, parts_k, shift_se)
        spread = band_spread(self.theta, self.weights, mse_k)
        self._bands[r] = {band_key(lo, hi): spread[band_key(lo, hi)]["rmse"]
                          for lo, hi in BANDS if band_key(lo, hi) in spread}
        self._band_errors[r] = spread

    def _table(self, kind: str, where):
        """The map table, or the BSDF's square points, at the midpoints of level ``where``
        (an int) or at the randomised points of :meth:`DiffuseModel._shifts` (``where`` =
        ("shift", N) or ("owen", N))."""
        key = (kind, where)
        if key not in self._tables:
            u = self._points(where)
            self._tables[key] = MapTable.at(self.technique, u) if kind == "map" else u
        return self._tables[key]

    def _technique_values(self, local: np.ndarray, rows: np.ndarray, weight: np.ndarray):
        """(radiance, map pdf) at the BSDF samples ``local`` (the frame's ``rows``): the
        technique's own compiled ``eval_pdf`` (where it has one), skipping the
        samples of weight 0; else its numpy eval and pdf."""
        lookup = getattr(self.technique, "eval_pdf", None)
        if lookup is not None:
            return lookup(local, rows, weight)
        d = local @ rows
        rad, pdf = [], []
        for i in range(0, len(d), _CHUNK):
            rad.append(self.technique.eval_unit(d[i:i + _CHUNK]))
            pdf.append(self.technique.pdf_unit(d[i:i + _CHUNK]))
        return np.concatenate(rad), np.concatenate(pdf)

    def _sample(self, wi, u, level: int | None = None):
        """(ω_o, weight, pdf) of the conductor's sampling for the view ``wi`` at the table's
        points ``u``: compiled for a white conductor, a rough plastic and a principled BSDF
        (the lobe from u_x), numpy otherwise; where the weight is 0, ω_o is the pole and the pdf 0 (the parts are
        0 there). ``level``: ``u`` is the midpoint grid of that level (Beckmann's warp by
        rows and columns, :func:`conductor_sample`)."""
        if compiled_sampling(self.conductor):               # the kernels: single scatter
            wo, weight, pdf = conductor_sample(self.conductor, wi, u, level)
            return wo, weight * self._scale(wi), pdf
        lobes = two_lobe_kernels(self.conductor)
        if lobes:
            return lobes[1](self.conductor, wi, u)
        square = getattr(self.conductor, "sample_square", self.conductor.sample)
        s = square(np.broadcast_to(wi, (len(u), 3)), u)     # a plastic's lobe from u_x
        dead = s.weight <= 0
        return (np.where(dead[:, None], [0.0, 0.0, 1.0], s.wo), s.weight,
                np.where(dead, 0.0, s.pdf))

    def _scale(self, wi) -> float:
        """The conductor's energy scale at the local view ``wi`` (a multiple-scattering GGX;
        1 otherwise), which the compiled single-scatter kernels leave out."""
        scale = getattr(self.conductor, "energy_scale", None)
        return 1.0 if scale is None else float(scale(min(max(float(wi[2]), 0.0), 1.0)))

    def _eval_pdf(self, wi, dirs, rows):
        """(f·cos, pdf) of the conductor at the world light directions ``dirs`` for the view
        ``wi``, in the frame whose axes are ``rows``: compiled for a white conductor, a rough
        plastic and a principled BSDF, numpy otherwise."""
        if compiled_conductor(self.conductor):
            fc, pdf = conductor_eval_pdf(self.conductor, wi, dirs, rows)
            return fc * self._scale(wi), pdf
        lobes = two_lobe_kernels(self.conductor)
        if lobes:
            return lobes[0](self.conductor, wi, dirs, rows)
        loc = dirs @ rows.T
        wis = np.broadcast_to(wi, loc.shape)
        return self.conductor.eval(wis, loc), self.conductor.pdf(wis, loc)

    def _footprint_parts(self, strategies: set, frame, fine: int) -> dict:
        """The parts of a frame with a pixel footprint (normal, view, J normals over the
        pixel): the mean tables (:mod:`._footprint`), and ``_var_c``, ``_var_a`` per part from
        the fused kernel's sums (as :class:`._footprint.FootprintSums` computes them)."""
        normal, view, foot = frame
        kept = {} if self._keep and isinstance(fine, int) else None     # not the shifted
        acc, sums = self._accumulated(strategies, foot, view, fine, kept)
        j, size = len(foot), acc.shape[1]
        acc /= j                                                      # the mean table g-bar
        gbar = self._named(acc, strategies)
        idx = {p: PARTS.index(p) for p in gbar}
        out = with_variances(gbar, {p: sums[:, i, 0] / size for p, i in idx.items()},
                             {p: sums[:, i, 1].sum(axis=0) / (j * size) for p, i in idx.items()},
                             self.film.variance_scale(math.isqrt(j)))
        lobes = self._lobe_values(strategies, foot, view, fine, kept)
        if kept:
            out["_normals"] = kept
        return {**out, **lobes}

    def _paired_extra(self, r, vals: dict) -> np.ndarray:
        """:meth:`DiffuseModel._paired_extra`; a two-lobe BSDF's stream with its lobe choice
        (:meth:`_lobe_extra`)."""
        if self._two_lobes() and r.strategy != "map" and r.name in STRATIFIED_1D:
            return self._lobe_extra(r, vals)
        return super()._paired_extra(r, vals)

    @staticmethod
    def _named(acc: np.ndarray, strategies: set) -> dict:
        """The parts of ``acc`` (:data:`PARTS` order) that ``strategies`` use, by name."""
        names = set()
        if strategies & {"map", "mis"}:
            names.add("map")
        if strategies & {"brdf", "mis"}:
            names.add("brdf")
        if "mis" in strategies:
            names.update(("mis_e", "mis_b", "mis_t"))
        return {p: acc[i] for i, p in enumerate(PARTS) if p in names}

    def _accumulated(self, strategies: set, normals, view, fine: int, kept=None):
        """The parts summed over ``normals`` (5, P, 3) for one ``view``, and each normal's
        sums of g and g² over the table (J, 5, 2, 3): :func:`accumulate_parts`; with a dict
        ``kept``, each normal's parts of ``self._keep`` appended to ``kept[part]``."""
        acc, sums = None, []
        for k, normal in enumerate(normals):
            map_side, bsdf_side = self._sides(strategies, normal, view, fine)
            if acc is None:
                size = len((map_side or bsdf_side)[2])
                acc = (np.zeros((len(PARTS), size, 3)) if kept is None
                       else self._per_normal((len(normals), len(PARTS), size, 3)))
            sums.append(accumulate_parts(acc if kept is None else acc[k], map_side, bsdf_side,
                                         self._fractions("mis"), self.renderer.heuristic))
        if kept is not None:
            kept.update({p: acc[:, PARTS.index(p)] for p in self._keep})    # (J, P, C) views
            acc = acc.sum(axis=0)
        return acc, np.stack(sums)

    def _per_normal(self, shape: tuple) -> np.ndarray:
        """A zeroed buffer of each footprint normal's parts, reused frame after frame (a
        frame's kept tables are read before the next frame's are written): fresh 0.5 GB
        arrays per frame cost more in page faults than the paired term itself."""
        buf = getattr(self, "_buffer", None)
        if buf is None or buf.shape != shape:
            buf = self._buffer = np.zeros(shape)
        else:
            buf.fill(0.0)
        return buf

    def _sides(self, strategies: set, normal, view, fine: int):
        """The two techniques' values at one normal for one view: the map side (base, f·cos,
        conductor pdf, map pdf at the map table's directions) and the BSDF side (radiance,
        weight, conductor pdf, map pdf at the BSDF table's samples), each None when no
        strategy of ``strategies`` uses it."""
        rows = np.asarray(self.renderer.tangent_frame(normal.reshape(1, 3))[0])  # t, b, n
        wi = rows @ view
        map_side = bsdf_side = None
        if strategies & {"map", "mis"}:
            tab = self._table("map", fine)
            fc, pb = self._eval_pdf(wi, tab.directions, rows)
            map_side = (tab.base, fc, pb, tab.pdf)
        if strategies & {"brdf", "mis"} and not self._lobes_only:
            wo, weight, pdf = self._sample(wi, self._table("bsdf", fine),
                                           fine if isinstance(fine, int) else None)
            rad, pe = self._technique_values(wo, rows, weight)
            bsdf_side = (rad, weight, pdf, pe)
        return map_side, bsdf_side

    def _part_values(self, strategies: set, frame, fine: int) -> dict:
        """The tabulated parts at one frame: ``map``, ``brdf``, ``mis_e``, ``mis_b``,
        ``mis_t`` (as the diffuse model's); a frame with a footprint through
        :meth:`_footprint_parts`."""
        if len(frame) == 3:
            return self._footprint_parts(strategies, frame, fine)
        normal, view = frame
        lobes = self._lobe_values(strategies, [normal], view, fine)
        if self._lobes_only and not strategies & {"map", "mis"}:
            return lobes                                # no side of the mixture is read
        return {**self._named(self._accumulated(strategies, [normal], view, fine)[0], strategies),
                **lobes}
