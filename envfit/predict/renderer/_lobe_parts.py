r"""A two-lobe BSDF (a rough plastic, :class:`envfit.shading.microfacet.RoughPlastic`, or a
principled BSDF, :class:`~envfit.shading.microfacet.Principled`) under a QMC sampler: the
tables and the cell of :class:`~envfit.predict.renderer.MicrofacetModel` for a BSDF stream
whose lobe is picked by a 1-D number of its own.

Under the ``independent`` sampler the lobe number and the direction's two are one uniform
point of the square (the BSDF's ``sample_square``: the i.i.d. estimator has the same
variance). Under a sampler whose randomisation is one of
:data:`~envfit.predict.renderer.randomisation.STRATIFIED_1D` the lobe number is a
stratified 1-D dimension paired at random with the 2-D points, and the error is
:func:`~envfit.predict.renderer.randomisation.lobe_choice_mse` of the two lobes' tables:
:math:`a(u)`, the BSDF sample's value (radiance · f·cos / mixture pdf, times its MIS weight
for ``mis``) when the first lobe (the one ``sample1`` < p picks: the plastic's specular, the
principled BSDF's diffuse) draws ω from u, :math:`b(u)` when the other one does, and p the
frame's first-lobe probability (``lobe_probability`` at the view's cosine). A frame with
a pixel footprint averages the tables and p over its normals (p varies little across a
pixel); its footprint term stays that of the one-square parts. An orthogonal-array sampler
draws the lobe number from a column of its array, not at random: not modelled.
"""
from __future__ import annotations

import numba
import numpy as np

from envfit.predict.renderer._footprint import paired_extra
from envfit.predict.renderer._microfacet_kernels import bsdf_parts
from envfit.predict.renderer._principled_kernels import two_lobe_kernels
from envfit.predict.renderer._cell_request import samples_above
from envfit.predict.renderer._integrand_tables import moment_pyramid
from envfit.predict.renderer._sampled_nets import SAMPLE_TAG
from envfit.predict.renderer.randomisation import (STRATIFIED_1D, DyadicGrid,
                                                   lobe_choice_mis, lobe_choice_mse)

__all__ = ["LobeChoice", "lobe_choice_modelled"]


def lobe_choice_modelled(spec) -> bool:
    """Whether a two-lobe BSDF's lobe choice is modelled under the sampler ``spec``
    (a :class:`envfit.renderers.SamplerSpec`): i.i.d., a stratified 1-D number in a random
    order, or an Owen-scrambled net's coordinate whose points the record gives
    (``lobe_points``)."""
    return (spec.randomisation in ("independent",) + STRATIFIED_1D
            and (spec.randomisation != "owen" or spec.lobe_points is not None))


@numba.njit(cache=True, parallel=True)
def _order_sums(lobes, e, cells, cells_e, numbers, p, total, out):  # pragma: no cover
    """Per group g of the pixels (``out`` (Q, C): the R pixels in Q consecutive groups of
    ⌊R/Q⌋, the rest left out) the sum over its pixels of (F − I)² − (F_u − I)² per channel:
    F the pixel's mean of lobe a (``lobes[0]``, where the lobe number ``numbers[0]`` < p) or b
    (``lobes[1]``) at its samples' ``cells``, plus the emitter table ``e`` at ``cells_e``
    where it has one column per sample (MIS; ``cells_e`` (0, 0) without), F_u the same with
    the shuffled numbers ``numbers[1]``; I = ``total``."""
    a, b, lobe, mixed = lobes[0], lobes[1], numbers[0], numbers[1]
    r, n = cells.shape
    q, c = out.shape
    size = r // q
    with_e = cells_e.shape[1] == n
    for g in numba.prange(q):
        for k in range(g * size, (g + 1) * size):
            for ch in range(c):
                f, fu = 0.0, 0.0
                for j in range(n):
                    i = cells[k, j]
                    va, vb = a[i, ch], b[i, ch]
                    base = e[cells_e[k, j], ch] if with_e else 0.0
                    f += base + (va if lobe[k, j] < p else vb)
                    fu += base + (va if mixed[k, j] < p else vb)
                x, y = f / n - total[ch], fu / n - total[ch]
                out[g, ch] += x * x - y * y


@numba.njit(cache=True, parallel=True)
def _order_sums_rgb(ab, e, cells, cells_e, numbers, consts, out):  # pragma: no cover
    """:func:`_order_sums` for three channels, each sample's cell read once for all of them:
    ``ab`` (P, 6) lobe a's channels then lobe b's at each cell, ``cells`` (and ``cells_e``)
    int32, ``consts`` = (p, inv, I₀, I₁, I₂) with ``inv`` = 1/N where N is a power of two
    (F·(1/N) is then F/N exactly), else 0 (F/N). The same sums in the same order: equal to
    :func:`_order_sums` bit for bit (its 0 + value where there is no emitter table is the
    value: a sum from +0 is never −0)."""
    lobe, mixed = numbers[0], numbers[1]
    r, n = cells.shape
    q = out.shape[0]
    size = r // q
    with_e = cells_e.shape[1] == n
    p, inv, t0, t1, t2 = consts[0], consts[1], consts[2], consts[3], consts[4]
    for g in numba.prange(q):
        o0, o1, o2 = 0.0, 0.0, 0.0
        for k in range(g * size, (g + 1) * size):
            f0, f1, f2, u0, u1, u2 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
            if with_e:
                for j in range(n):
                    i, ie = cells[k, j], cells_e[k, j]
                    sa, sm = lobe[k, j] < p, mixed[k, j] < p
                    a0, a1, a2 = ab[i, 0], ab[i, 1], ab[i, 2]
                    b0, b1, b2 = ab[i, 3], ab[i, 4], ab[i, 5]
                    e0, e1, e2 = e[ie, 0], e[ie, 1], e[ie, 2]
                    f0 += e0 + (a0 if sa else b0)
                    f1 += e1 + (a1 if sa else b1)
                    f2 += e2 + (a2 if sa else b2)
                    u0 += e0 + (a0 if sm else b0)
                    u1 += e1 + (a1 if sm else b1)
                    u2 += e2 + (a2 if sm else b2)
            else:
                for j in range(n):
                    i = cells[k, j]
                    sa, sm = lobe[k, j] < p, mixed[k, j] < p
                    a0, a1, a2 = ab[i, 0], ab[i, 1], ab[i, 2]
                    b0, b1, b2 = ab[i, 3], ab[i, 4], ab[i, 5]
                    f0 += a0 if sa else b0
                    f1 += a1 if sa else b1
                    f2 += a2 if sa else b2
                    u0 += a0 if sm else b0
                    u1 += a1 if sm else b1
                    u2 += a2 if sm else b2
            if inv > 0.0:
                f0, f1, f2, u0, u1, u2 = f0 * inv, f1 * inv, f2 * inv, u0 * inv, u1 * inv, u2 * inv
            else:
                f0, f1, f2, u0, u1, u2 = f0 / n, f1 / n, f2 / n, u0 / n, u1 / n, u2 / n
            x, y = f0 - t0, u0 - t0
            o0 += x * x - y * y
            x, y = f1 - t1, u1 - t1
            o1 += x * x - y * y
            x, y = f2 - t2, u2 - t2
            o2 += x * x - y * y
        out[g, 0] += o0
        out[g, 1] += o1
        out[g, 2] += o2


@numba.njit(cache=True, parallel=True)
def _order_sums_pair(ab2, cells, numbers, consts, out):  # pragma: no cover
    """:func:`_order_sums_rgb` of two streams at once that share their cells and lobe numbers
    (a BSDF's ``brdf`` and ``mis`` streams drawn alike, no emitter table): ``ab2`` (P, 12) the
    first stream's lobes a and b then the second's, ``consts`` = (p, inv, the first's I (3),
    the second's (3)), ``out`` (2, Q, 3). Each stream's sums in its own order: equal to
    :func:`_order_sums_rgb` of each bit for bit, one read of a cell for both."""
    lobe, mixed = numbers[0], numbers[1]
    r, n = cells.shape
    q = out.shape[1]
    size = r // q
    p, inv = consts[0], consts[1]
    for g in numba.prange(q):
        o = np.zeros(6)
        for k in range(g * size, (g + 1) * size):
            f0, f1, f2, u0, u1, u2 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
            h0, h1, h2, v0, v1, v2 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
            for j in range(n):
                i = cells[k, j]
                sa, sm = lobe[k, j] < p, mixed[k, j] < p
                f0 += ab2[i, 0] if sa else ab2[i, 3]
                f1 += ab2[i, 1] if sa else ab2[i, 4]
                f2 += ab2[i, 2] if sa else ab2[i, 5]
                u0 += ab2[i, 0] if sm else ab2[i, 3]
                u1 += ab2[i, 1] if sm else ab2[i, 4]
                u2 += ab2[i, 2] if sm else ab2[i, 5]
                h0 += ab2[i, 6] if sa else ab2[i, 9]
                h1 += ab2[i, 7] if sa else ab2[i, 10]
                h2 += ab2[i, 8] if sa else ab2[i, 11]
                v0 += ab2[i, 6] if sm else ab2[i, 9]
                v1 += ab2[i, 7] if sm else ab2[i, 10]
                v2 += ab2[i, 8] if sm else ab2[i, 11]
            sums = (f0, f1, f2, h0, h1, h2)
            mixes = (u0, u1, u2, v0, v1, v2)
            for c in range(6):
                fc, uc = sums[c], mixes[c]
                if inv > 0.0:
                    fc, uc = fc * inv, uc * inv
                else:
                    fc, uc = fc / n, uc / n
                x, y = fc - consts[2 + c], uc - consts[2 + c]
                o[c] += x * x - y * y
        for c in range(6):
            out[c // 3, g, c % 3] += o[c]


def _moments(vals: dict, fine: int, level: int, names: tuple, top: int | None = None) -> tuple:
    """({name: A}, {(name, name'): B}, {name: Walsh}) of the tables ``names`` of one frame at
    ``level``: the cell means of each, the cell means of each product of two (squares
    included), the Walsh coefficients of each one's centred means — one pyramid per table
    and one transform per table at level ``top`` (≥ ``level``; default ``level``), memoised
    in ``vals``, from which every linear combination's grid follows (:func:`_combined_grid`).
    A coarser level's coefficients are the top's first 2^level × 2^level (the cell means of
    a grid determine exactly its coefficients below M: :mod:`.randomisation._walsh`; equal
    to a transform of the coarser means to rounding)."""
    key = ("_moments", level, names)
    if key not in vals:
        pyramid = ("_pyramid", names)
        pairs = [(i, j) for i in range(len(names)) for j in range(i + 1, len(names))]
        if pyramid not in vals:                     # every level in one pass from the finest
            tabs = [np.asarray(vals[k], dtype=np.float64) for k in names]
            stack = np.concatenate(tabs + [tabs[i] * tabs[j] for i, j in pairs], axis=1)
            vals[pyramid] = moment_pyramid(stack, fine, range(fine))
        a, b = vals[pyramid][level]
        c = np.asarray(vals[names[0]]).shape[1]
        means = {k: a[i * c:(i + 1) * c] for i, k in enumerate(names)}
        second = {(k, k): b[i * c:(i + 1) * c] for i, k in enumerate(names)}
        for q, (i, j) in enumerate(pairs):
            at = (len(names) + q) * c
            second[names[i], names[j]] = a[at:at + c]
        top = level if top is None or top < level else top
        if top == level:
            walsh = {k: DyadicGrid.from_arrays(m, np.maximum(second[k, k], m * m)).walsh
                     for k, m in means.items()}
        else:
            m = 1 << level
            walsh = {k: np.ascontiguousarray(w[:, :m, :m])
                     for k, w in _moments(vals, fine, top, names, top)[2].items()}
        vals[key] = (means, second, walsh)
    return vals[key]


def _combined_grid(vals: dict, fine: int, level: int, coeffs: dict,
                   top: int | None = None) -> DyadicGrid:
    r"""The :class:`DyadicGrid` at ``level`` of :math:`\sum_k c_k t_k` over one frame's tables
    :math:`t_k` (``coeffs`` {name: c}) from their :func:`_moments`: means and Walsh
    coefficients linear, cell means of the square :math:`\sum_{k,l} c_k c_l\,
    \overline{t_k t_l}` — what a pyramid and a transform of the combined table give (to
    rounding), without either; the Walsh coefficients from a transform at level ``top``
    (:func:`_moments`)."""
    names = tuple(sorted(vals_key for vals_key in coeffs))
    group = tuple(sorted(k for k in _GROUPS[names[0]]))
    means, second, walsh = _moments(vals, fine, level, group, top)
    a = sum(coeffs[k] * means[k] for k in names)
    b = 0.0
    for i, k in enumerate(group):
        for l in group[i:]:
            if k in coeffs and l in coeffs:
                b = b + (1.0 if k == l else 2.0) * coeffs[k] * coeffs[l] * second[k, l]
    g = DyadicGrid.from_arrays(a, np.maximum(b, a * a))
    g.__dict__["walsh"] = sum(coeffs[k] * walsh[k] for k in names)
    return g


def _order_tables(vals: dict, prefix: str) -> dict:
    """What :meth:`LobeChoice._order_excess` reads of one frame's tables, made once per frame
    (memoised in ``vals``) for every N: for a lobe ``prefix`` (``brdf_``, ``mis_b``) the two
    lobes side by side (``ab`` (P, 2C)) and their means; for ``mis_e`` the emitter's table
    ``e`` and its mean."""
    key = ("_order tables", prefix)
    if key not in vals:
        if prefix == "mis_e":
            e = np.ascontiguousarray(vals["mis_e"], dtype=np.float64)
            vals[key] = {"e": e, "e mean": e.mean(axis=0)}
        else:
            a, b = vals[f"{prefix}a"], vals[f"{prefix}b"]
            vals[key] = {"a mean": a.mean(axis=0), "b mean": b.mean(axis=0),
                         "ab": np.concatenate([a, b], axis=1).astype(np.float64, order="C")}
    return vals[key]


def _pair_table(vals: dict, first: str, second: str) -> np.ndarray:
    """(P, 12): the two lobe prefixes' ``ab`` tables side by side (:func:`_order_sums_pair`),
    made once per frame."""
    key = ("_order pair table", first, second)
    if key not in vals:
        vals[key] = np.concatenate([_order_tables(vals, first)["ab"],
                                    _order_tables(vals, second)["ab"]], axis=1)
    return vals[key]


#: the tables a combination mixes: the BSDF stream's two lobes, with the emitter's for MIS
_GROUPS = {k: g for g in (("brdf_a", "brdf_b"), ("mis_ba", "mis_bb", "mis_e")) for k in g}

_LOBES = (("a", 0.0), ("b", 1.0))             # sample1: 0 < p (the first lobe), 1 ≥ p


class LobeChoice:
    """The lobe-choice part of :class:`~envfit.predict.renderer.MicrofacetModel` (module
    docstring): ``_lobes`` says whether the pass in progress needs the lobes' tables."""

    _lobes = False
    #: the pass's BSDF-sampling requests are all lobe cells, without footprints: the mixture's
    #: BSDF side (``MicrofacetModel._sides``) is read by none, so not taken
    _lobes_only = False

    def _two_lobes(self) -> bool:
        return hasattr(self.conductor, "sample_square")

    def _lobe_requests(self, todo) -> bool:
        """Whether any request of ``todo`` is a two-lobe BSDF's stream under a stratified 1-D
        sampler."""
        return self._two_lobes() and any(r.strategy != "map" and r.name in STRATIFIED_1D
                                         for r in todo)

    def _sample_lobe(self, wi, u, u1: float):
        """(ω_o, weight, pdf) of the BSDF's sampling in one lobe (``sample1`` = ``u1``):
        compiled for a rough plastic and a principled BSDF (:func:`two_lobe_kernels`), numpy
        otherwise."""
        lobes = two_lobe_kernels(self.conductor)
        if lobes:
            return lobes[1](self.conductor, wi, u, u1)
        s = self.conductor.sample(np.broadcast_to(wi, (len(u), 3)), u, u1=np.full(len(u), u1))
        dead = s.weight <= 0
        return (np.where(dead[:, None], [0.0, 0.0, 1.0], s.wo), s.weight,
                np.where(dead, 0.0, s.pdf))

    def _lobe_values(self, strategies: set, normals, view, fine: int, kept=None) -> dict:
        """``brdf_a``, ``brdf_b``, ``mis_ba``, ``mis_bb`` (P, 3): each lobe's BSDF part and
        MIS-weighted part averaged over ``normals``, and ``_p``, the mean first-lobe
        probability; {} when no request of the pass needs them. With a dict ``kept`` (a
        footprint's paired film, :meth:`_lobe_extra`), each normal's parts (J, P, 3) are
        filed there under the same names."""
        if not (self._lobes and strategies & {"brdf", "mis"}):
            return {}
        u = self._table("bsdf", fine)
        out, ps = {}, []
        for name, u1 in _LOBES:
            acc = np.empty((2, len(normals), len(u), 3))          # brdf, mis_b per normal
            for k, normal in enumerate(normals):
                rows = np.asarray(self.renderer.tangent_frame(normal.reshape(1, 3))[0])
                wi = rows @ view
                wo, weight, pdf = self._sample_lobe(wi, u, u1)
                rad, pe = self._technique_values(wo, rows, weight)
                bsdf_parts((rad, weight, pdf, pe), self._fractions("mis"),
                           self.renderer.heuristic, acc[0, k], acc[1, k])
                if name == "a":
                    ps.append(float(self.conductor.lobe_probability(np.array([max(wi[2], 0.0)]))[0]
                                    if wi[2] > 0 else 0.0))
            for per, key in ((acc[0], f"brdf_{name}"), (acc[1], f"mis_b{name}")):
                out[key] = per[0] + 0.0 if len(per) == 1 else per.mean(axis=0)   # (0 + x)/1
                if kept is not None:
                    kept[key] = per
        out["_p"] = float(np.mean(ps))
        return out

    def _lobe_extra(self, r, vals: dict) -> np.ndarray:
        """The MSE (C,) a pixel footprint adds to a two-lobe BSDF's ``brdf`` or ``mis``
        stream under a paired film (:class:`._footprint.PairedFootprint`, as
        :meth:`DiffuseModel._cell` for one lobe), simulated over the sampler's own film and
        technique points: each BSDF sample takes lobe a where its stratified 1-D number
        (:meth:`~._footprint.PairedFootprint.lobe_numbers`) is below the frame's p, its value
        then the lobe's table at its cell (:func:`._footprint.paired_extra` over the two
        tables side by side), where :func:`._footprint.footprint_term` would take them as
        randomly paired (on city at 1024 spp, 2 × 2 normals a pixel, the plastic's MIS
        moved +3 %: docs/validation.md)."""
        kept, p = vals["_normals"], vals["_p"]
        pairing = self._pairing(r)
        e_call, b_call = self._calls(r)
        prefix = "brdf_" if r.strategy == "brdf" else "mis_b"
        a, b = kept[f"{prefix}a"], kept[f"{prefix}b"]
        size = a.shape[1]
        lobe = pairing.lobe_numbers(self.renderer.strategy(r.strategy).lobe_call)
        cells = pairing.cells(b_call, size) + size * (lobe >= p)
        mean = p * a.mean(axis=(0, 1)) + (1.0 - p) * b.mean(axis=(0, 1))
        streams = [(np.concatenate([a, b], axis=1), cells, mean)]
        if r.strategy == "mis":
            e = kept["mis_e"]
            streams.insert(0, (e, pairing.cells(e_call, e.shape[1]), None))
        side = int(round(np.sqrt(a.shape[0])))
        return paired_extra(streams, pairing.weights(side))[0]

    def _lobe_cell(self, r, vals: dict, grids: dict, fine: int, levels=()):
        """(mse, emitter part, BSDF part, 2·cross) per channel of a two-lobe BSDF's request
        under a stratified 1-D sampler (:func:`lobe_choice_mse`, :func:`lobe_choice_mis`).
        Where the net's power above the grid is sampled (N > M/2: :func:`samples_above`), each
        combination of the lobes' tables gets its own, from the same combination of the lobes'
        values at the pass's sampled points (:meth:`_lobe_above`). The Walsh transforms are
        made once per table at the largest of the pass's ``levels`` (:func:`_moments`)."""
        sampled = samples_above(r.name, r.n, r.level)
        sv = (self._sampled_values(grids, SAMPLE_TAG[r.name], {r.strategy} | grids.get(
            "strategies", set()), r.n) if sampled else None)
        p = vals["_p"]
        top = max([r.level, *levels])

        def grid(coeffs: dict, part):
            key = ("_combined", r.level, top, tuple(sorted(coeffs.items())))
            if key not in vals:                     # the same grid for every N at the level
                vals[key] = _combined_grid(vals, fine, r.level, coeffs, top)
            g = vals[key]
            if not sampled:
                return g
            return self._lobe_above(r, g, lambda: sum(c * sv[k] for k, c in coeffs.items()),
                                    grids, part)

        def grid_of(prefix, base=None, part=None):
            def of(x, y):
                coeffs = {f"{prefix}a": x, f"{prefix}b": y}
                if base is not None:
                    coeffs[base] = 1.0
                near = part is not None and abs(x - p) * r.n < 1.0   # the drawn count's K
                return grid(coeffs, (part, x, y, near))
            return of

        opts, opts_b = dict(r.options), dict(r.options_b)
        excess = self._order_excess(r, vals, grids)
        if r.strategy == "brdf":
            mse = lobe_choice_mse(r.name, grid_of("brdf_", part="brdf"), r.n, p, **opts_b)
            z = np.zeros_like(mse)
            return mse + excess, z, mse + excess, z
        mse, e, b, cross = lobe_choice_mis(
            r.name, grid({"mis_e": 1.0}, ("mis_e", 1.0, 0.0, True)),
            grid_of("mis_b", part="mis_b"), r.n, p, shared=r.shared, options=opts,
            options_b=opts_b, total_of=grid_of("mis_b", "mis_e", part="mis_t"))
        return mse + excess, e, b + excess, 2.0 * cross

    def _order_excess(self, r, vals: dict, grids: dict) -> np.ndarray:
        r"""The MSE (C,) the sampler's own order of the lobe numbers adds to the random order
        :func:`lobe_choice_mse` takes, where its record gives that order
        (:attr:`envfit.renderers.SamplerSpec.lobe_points` and the strategy's ``lobe_call``;
        0 otherwise): over the pixels of :meth:`_pairing`, the estimator on the lobes' tables
        at each sample's cell with the sampler's lobe numbers, F, and with each pixel's
        numbers shuffled, F_u (the same points): mean :math:`(F - I)^2 - (F_u - I)^2`, the
        emitter's stream included for MIS where the sampler pairs its points with the BSDF's
        (they are ordered alike too; under the ``independent`` pairing its error is
        independent of the BSDF stream's and cancels in the difference, so it is left out:
        a 3-D request's third coordinate, :attr:`SamplerSpec.lobe_points`). The pixels in
        Q = ``options.shifts`` groups, each group's mean (the channels' mean) is filed as a
        draw (``grids["order_draws", r]``): the same pixels at every frame, so their spread
        is part of the model's error (:meth:`DiffuseModel._draws`)."""
        spec = self.renderer.sampler(r.sampler)
        call = self.renderer.strategy(r.strategy).lobe_call
        prefix = "brdf_" if r.strategy == "brdf" else "mis_b"
        a, b = vals[f"{prefix}a"], vals[f"{prefix}b"]
        if spec.lobe_points is None or call is None:
            return np.zeros(a.shape[1])
        if r.n == 1:                # one number a pixel: its shuffle is itself, F_u = F
            pixels = self.paired_pixels(1)                            # :meth:`_pairing`'s
            grids["order_draws", r] = np.zeros(max(2, min(int(self.options.shifts), pixels)))
            return np.zeros(a.shape[1])
        pairing = self._pairing(r)
        e_call, b_call = self._calls(r)
        size, p = len(a), vals["_p"]
        numbers = self._lobe_numbers(pairing, call, r.n)
        q = max(2, min(int(self.options.shifts), numbers.shape[1]))
        per = numbers.shape[1] // q
        with_e = r.strategy == "mis" and spec.pairing != "independent"
        out = grids.pop(("order sums", r), None)               # made with another stream's
        partner = (None if out is not None or with_e or a.shape[1] != 3
                   else self._order_partner(r, vals))
        if partner is not None:
            other = "brdf_" if partner.strategy == "brdf" else "mis_b"
            out = np.zeros((2, q, 3))
            totals = [p * t["a mean"] + (1.0 - p) * t["b mean"]
                      for t in (_order_tables(vals, prefix), _order_tables(vals, other))]
            n = numbers.shape[2]
            consts = np.array([p, 1.0 / n if n & (n - 1) == 0 else 0.0, *totals[0],
                               *totals[1]], np.float64)
            _order_sums_pair(_pair_table(vals, prefix, other),
                             pairing.cells(b_call, size, np.int32), numbers, consts, out)
            grids["order sums", partner] = out[1]
            out = out[0]
        elif out is None:
            tabs = _order_tables(vals, prefix)
            total = p * tabs["a mean"] + (1.0 - p) * tabs["b mean"]
            cells = pairing.cells(b_call, size, np.int32)
            if with_e:
                tab_e = _order_tables(vals, "mis_e")
                e, e_mean = tab_e["e"], tab_e["e mean"]
                cells_e = pairing.cells(e_call, len(e), np.int32)
                total = total + e_mean
            else:
                e, cells_e = np.zeros((1, a.shape[1])), np.zeros((0, 0), np.int32)
            out = np.zeros((q, a.shape[1]))
            total = np.asarray(total, dtype=np.float64)
            if a.shape[1] == 3:
                n = numbers.shape[2]
                consts = np.array([p, 1.0 / n if n & (n - 1) == 0 else 0.0, *total],
                                  np.float64)
                _order_sums_rgb(tabs["ab"], e, cells, cells_e, numbers, consts, out)
            else:
                lobes = np.ascontiguousarray(np.stack([a, b]), dtype=np.float64)
                _order_sums(lobes, e, cells.astype(np.int64), cells_e.astype(np.int64),
                            numbers, float(p), total, out)
        grids["order_draws", r] = out.mean(axis=1) / per
        return out.sum(axis=0) / (q * per)

    def _lobe_numbers(self, pairing, call: int, n: int) -> np.ndarray:
        """(2, R, N): the pixels' lobe numbers of ``call`` in the sampler's order and each
        pixel's shuffled (seeded by ``options.seed`` and N), kept with the pairing."""
        key = ("lobe numbers and shuffled", call)
        if key not in pairing.memo:                 # the same numbers, each pixel's shuffled
            lobe = pairing.lobe_numbers(call)
            mixed = np.random.default_rng([self.options.seed, n, 0x0DE]).permuted(lobe, axis=1)
            pairing.memo[key] = np.ascontiguousarray(np.stack([lobe, mixed]), dtype=np.float64)
        return pairing.memo[key]

    def _order_partner(self, r, vals: dict):
        """The pass's request of the other BSDF stream (``brdf`` for ``mis``, and back) whose
        order excess reads the same cells and lobe numbers as ``r``'s without an emitter
        table (:func:`_order_sums_pair`), or None."""
        spec = self.renderer.sampler(r.sampler)
        mine = self.renderer.strategy(r.strategy)
        for o in getattr(self, "_pass_todo", ()):
            if (o.strategy in ("brdf", "mis") and o.strategy != r.strategy and o.n == r.n
                    and o.sampler == r.sampler and o.name == r.name
                    and self.renderer.strategy(o.strategy).lobe_call == mine.lobe_call
                    and self._calls(o)[1] == self._calls(r)[1]
                    and (o.strategy != "mis" or spec.pairing == "independent")
                    and all(k in vals for k in (("brdf_a", "brdf_b") if o.strategy == "brdf"
                                                 else ("mis_ba", "mis_bb")))):
                return o
        return None

    def _lobe_above(self, r, g: DyadicGrid, values, grids: dict, key) -> DyadicGrid:
        """``g`` with its power above the grid sampled from ``values`` (or a function that
        gives them, called where the estimate is not memoised) at the pass's sampled
        points (:meth:`~._sampled_nets.SampledNets.above`, memoised per combination ``key`` =
        (part, x, y, near)); the combination nearest the lobe's probability (``near``) is also
        filed under its part's name, whose draws give the model's error
        (:meth:`DiffuseModel._draws`)."""
        tag, part, near = SAMPLE_TAG[r.name], key[0], key[3]
        name = f"lobe {key[0]} {key[1]!r} {key[2]!r}"
        above, se = self.nets.above(tag, r.level, r.n, g.mean, values, grids, name)
        if near:
            top = max(r.n, self.nets.top)
            grids["above", part, r.level, tag, top] = grids["above", name, r.level, tag, top]
        return g.with_sampled_above(r.name, "sobol", r.n, above, se)
