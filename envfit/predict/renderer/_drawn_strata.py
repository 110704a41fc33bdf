r"""The renderer model's drawn cells: correlated multi-jittering and orthogonal arrays above
the N their exact models reach, and a shared sequence's runs (blue noise) at every N, as a part
of :class:`._diffuse_model.DiffuseModel`.

The exact models (``randomisation._cmj``, ``._orthogonal``) sum over the N × N fine cells of
the grid, so the model takes them to N = 2^L, at most 1024 (:func:`strata_reach`). Above, a
cell is *drawn* (:class:`DrawnStrata`): Q sets of the sampler's own point sets
(``randomisation._strata_samples``: the same construction and permutation law as the exact
models) for each stream (the emitter's, the BSDF's), the technique's table at the Q·N points
once per pass (Q·N = :data:`STRATA_POINTS`, at least :data:`STRATA_MIN_DRAWS` sets), and per
normal the variance over the sets of each stream's estimate; the streams' permutations are
independent, so their variances add (the cross term is 0, as the exact models have it). The
same sets serve every normal, so the sets' error is added over the normals draw by draw
(:func:`._model_error.draws_error`) and reported with the normals' own.

Between the spp the sampler runs at powers of two (:meth:`DrawnStrata._strata_anchors`; the
search's coarse pass asks for exactly those) a stratified cell is the anchors' local power law
(:func:`geometric`): a search's bracket costs no new draws. A shared sequence's runs
(``randomisation._shared_sequence``) are drawn at every N: a run that straddles aligned
blocks is not between its neighbours (it is a union of smaller nets); its two streams are
the same pixels' runs, so the variance of their sum is drawn, cross term included.

Checked: a drawn cell equals the exact cell at the same N within its reported error
(``tests/test_randomisation_strata_samples.py``), and a renderer's multi-jittered and
orthogonal-array samplers rendered at 121–2048 spp are inside the rendered intervals
(docs/validation.md).
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from envfit.predict.renderer._integrand_tables import (BsdfTable, MapTable, bsdf_values,
                                                       map_values)
from envfit.predict.renderer.randomisation import (ALWAYS_DRAWN, STRATA_SAMPLED, sampled_mse,
                                                   strata_points)

if TYPE_CHECKING:                                   # annotations only (no import cycle)
    from envfit.predict.renderer._cell_request import CellRequest
    from envfit.predict.renderer._diffuse_model import RendererPrediction

__all__ = ["STRATA_POINTS", "STRATA_MIN_DRAWS", "DrawnStrata", "strata_reach",
           "strata_draws", "geometric"]

#: the integrand points a drawn stratified cell evaluates per stream (Q·N: Q = this // N,
#: at least :data:`STRATA_MIN_DRAWS`): correlated multi-jittering and orthogonal arrays above
#: their exact models' reach (:mod:`.randomisation._strata_samples`)
STRATA_POINTS = 1 << 16
#: the fewest draws of a drawn stratified cell
STRATA_MIN_DRAWS = 16


def strata_reach(randomisation: str, level: int) -> int:
    """The largest N the exact correlated multi-jittering and orthogonal-array models take at
    grid ``level`` (the fine cells on the grid, their O(N²) sums at most 1024²); above it the
    renderer model draws their point sets (:mod:`.randomisation._strata_samples`).

    A shared sequence's runs (``shared_sequence``) have no exact model: drawn at every N.

    >>> strata_reach("cmj", 9), strata_reach("orthogonal", 7), strata_reach("owen", 9)
    (512, 128, 0)
    """
    if randomisation in ALWAYS_DRAWN:
        return 0
    return min(1 << int(level), 1024) if randomisation in STRATA_SAMPLED else 0


def strata_draws(n: int) -> int:
    """Q of a drawn stratified cell of N points (:data:`STRATA_POINTS`)."""
    return max(STRATA_MIN_DRAWS, STRATA_POINTS // int(n))


def geometric(n: int, lo: RendererPrediction, hi: RendererPrediction) -> np.ndarray:
    r"""The MSE per channel at N between two predictions, geometrically (a local power law
    :math:`\mathrm{MSE} \propto N^{-\alpha}` through both; linearly where one is 0):
    a drawn stratified cell between its anchors (:meth:`DrawnStrata._strata_anchors`).

    >>> from types import SimpleNamespace as S
    >>> geometric(200, S(spp_rendered=100, mse=np.array([4.0])),
    ...            S(spp_rendered=400, mse=np.array([1.0]))).tolist()
    [2.0]
    """
    a, b = np.asarray(lo.mse, np.float64), np.asarray(hi.mse, np.float64)
    t = math.log(n / lo.spp_rendered) / math.log(hi.spp_rendered / lo.spp_rendered)
    with np.errstate(divide="ignore", invalid="ignore"):
        geo = a * np.power(np.where(a > 0, b / a, 1.0), t)
    return np.where((a > 0) & (b > 0), geo, a + t * (b - a))


class DrawnStrata:
    """The drawn stratified cells of a renderer model (module docstring): the methods
    :class:`._diffuse_model.DiffuseModel` calls for a cell above the exact models' reach. It
    reads the model's ``renderer``, ``technique``, ``options`` (``seed``), ``_tables``,
    ``_fractions`` and ``request``."""

    def _strata_anchors(self, r: CellRequest) -> tuple[int, int]:
        """The spp the sampler runs when asked for the powers of two 2^m, 2^(m+1) around
        ``r.n`` (its rounding of 2^m at most N, of 2^(m+1) above it)."""
        spec, m = self.renderer.sampler(r.sampler), 1
        while spec.spp(2 * m) <= r.n:
            m *= 2
        return spec.spp(m), spec.spp(2 * m)

    #: the model draws correlated multi-jittered and orthogonal-array point sets above their
    #: exact models' reach (:meth:`_strata_cell`)
    draws_strata = True

    def _drawn_strata(self, r: CellRequest) -> bool:
        """Whether ``r`` is a correlated multi-jittered or orthogonal-array cell above its exact
        model's reach (:func:`strata_reach`), whose MSE the model draws."""
        return (self.draws_strata and r.name in STRATA_SAMPLED
                and r.n > strata_reach(r.name, r.level))

    _STREAM_PARTS = {"map": (("e", "map"),), "brdf": (("b", "brdf"),),
                     "mis": (("e", "mis_e"), ("b", "mis_b"))}

    def _strata_cell(self, r: CellRequest, grids: dict):
        """(mse, map part, BSDF part, 2·cross) per channel of a drawn cell at one normal: each
        stream's variance over Q draws of the sampler's point sets
        (:mod:`.randomisation._strata_samples`). Stratified streams' permutations are
        independent, so their variances add; a shared sequence's streams are the same
        pixels' runs (:meth:`_stream_seed`), so the variance is the sum's, its cross term
        measured (:meth:`_shared_cells`, all N of a class at once). The per-draw terms go to
        ``grids`` for :meth:`_draws`."""
        if r.name in ALWAYS_DRAWN:
            return self._shared_cells(r, grids)[r]
        means = {s: self._strata_mean(grids, r, s, part)
                 for s, part in self._STREAM_PARTS[r.strategy]}
        out = {s: sampled_mse(f) for s, f in means.items()}
        grids["strata_draws", r] = sum(z for _, z in out.values())
        zero = np.zeros(1)
        e, b = (out[s][0] * np.ones(1) if s in out else zero for s in ("e", "b"))
        e, b = np.broadcast_arrays(e, b)
        return e + b, e, b, np.zeros_like(e)

    def _shared_cells(self, r: CellRequest, grids: dict) -> dict:
        """The results (as :meth:`_strata_cell`) at one normal of every cell of ``r``'s
        strategy, sampler and class of runs in the pass (:meth:`_plan_drawn`). An N-point
        pixel's run is any N consecutive points of a class run starting at a multiple of
        N (a multiple of the class's spacing): each run of length L holds ⌊L/N⌋ of them end
        to end (:func:`_windows`), so a small N of a long class is drawn as often as a long
        one. Their squared deviations from the mean over all of them, scaled by Q/(Q − 1)
        (Q runs: an unbiased variance where a run holds one window, at most 1/(Q − 1) high
        otherwise), are the MSE; a run's mean of them is its draw's term."""
        key = ("shared cells", r.strategy, r.sampler, dict(r.options)["points"].step(r.n))
        if key in grids:
            return grids[key]
        length = self._run_key(r, "e" if r.strategy != "brdf" else "b")[2]
        cells = [c for c in self._class_cells.get(key[1:], ()) if c.n <= length] or [r]
        cums = {s: self._strata_values(grids, r, s, prefix=True)[part]
                for s, part in self._STREAM_PARTS[r.strategy]}        # (Q, L, C) each
        out, groups = {}, {}
        for c in cells:                         # the cells whose runs hold W windows each
            groups.setdefault(next(iter(cums.values())).shape[1] // c.n, []).append(c)
        for group in groups.values():
            ns = np.array([c.n for c in group])
            f = {s: _windows(v, ns) for s, v in cums.items()}           # (Q, K, W, C)
            q = next(iter(f.values())).shape[0]
            scale = q / (q - 1.0)

            def dev2(x):
                return (x - x.mean(axis=(0, 2), keepdims=True)) ** 2 * scale

            d = dev2(sum(f.values()))
            tot, z = d.mean(axis=(0, 2)), d.mean(axis=(2, 3))            # (K, C), (Q, K)
            ve, vb = (dev2(f[s]).mean(axis=(0, 2)) if s in f else np.zeros_like(tot)
                      for s in ("e", "b"))
            for k, c in enumerate(group):
                grids["strata_draws", c] = z[:, k]
                out[c] = (tot[k], ve[k], vb[k], tot[k] - ve[k] - vb[k])
        grids[key] = out
        return out

    def _stream_seed(self, r: CellRequest, stream: str) -> int:
        """The seed of a stream's draws: a shared sequence's streams draw the same pixels
        (one seed), stratified streams independent sets."""
        return self.options.seed + (stream == "b" and r.name not in ALWAYS_DRAWN)

    def _plan_drawn(self, todo) -> None:
        """A pass's shared-sequence runs: per (request's options, start spacing) the longest N
        asked, the length its runs are drawn to (:meth:`_run_key`); per (strategy, sampler,
        spacing) the cells they serve (:meth:`_shared_cells`)."""
        self._run_lengths, self._class_cells = {}, {}
        for r in todo:
            if self._drawn_strata(r) and r.name in ALWAYS_DRAWN:
                step = dict(r.options)["points"].step(r.n)
                for opts in {r.options, r.options_b}:
                    k = (opts, step)
                    self._run_lengths[k] = max(self._run_lengths.get(k, 0), r.n)
                self._class_cells.setdefault((r.strategy, r.sampler, step), []).append(r)

    def _drawn_brackets(self, reqs) -> list:
        """The requests a shared sequence's cells bring along: every N between the powers of
        two around a requested N (:meth:`_plan_drawn` draws their runs once: the prefixes of
        one class's runs give all of them, so a search's later passes find them cached)."""
        extra = set()
        for r in reqs:
            if (self._drawn_strata(r) and r.name in ALWAYS_DRAWN and r.n & (r.n - 1)
                    and ("bracket", r.strategy, r.sampler, r.n.bit_length()) not in extra):
                extra.add(("bracket", r.strategy, r.sampler, r.n.bit_length()))
                lo = 1 << (r.n.bit_length() - 1)
                extra.update(self.request(r.strategy, r.sampler, n)
                             for n in range(lo + 1, 2 * lo))
        return [x for x in extra if not isinstance(x, tuple)]

    def _run_key(self, r: CellRequest, stream: str) -> tuple:
        """(the table key, Q, the run length L, the runs' spacing) of ``r``'s stream: a
        shared sequence's class of runs (its starts' spacing, :meth:`_plan_drawn`'s length),
        else the cell's own Q point sets of N."""
        opts = r.options if stream == "e" else r.options_b
        if r.name not in ALWAYS_DRAWN:
            return ("strata", r.name, r.n, opts, stream), strata_draws(r.n), r.n, None
        step = dict(opts)["points"].step(r.n)
        length = max(r.n, getattr(self, "_run_lengths", {}).get((opts, step), 0))
        return (("runs", r.name, step, length, opts, stream), strata_draws(length), length,
                step)

    def _strata_mean(self, grids: dict, r: CellRequest, stream: str, part: str) -> np.ndarray:
        """The draws' estimates (Q, C) of one ``part`` of ``stream`` at one normal
        (:meth:`_strata_values`), kept in ``grids`` for the pass's other strategies."""
        key = ("strata mean", part) + self._run_key(r, stream)[:1]
        if key not in grids:
            grids[key] = self._strata_values(grids, r, stream)[part]
        return grids[key]

    def _strata_values(self, grids: dict, r: CellRequest, stream: str, *,
                       prefix: bool = False) -> dict:
        """The draws' estimates (Q, C) of the parts of ``stream`` (``e``: ``map``, ``mis_e``;
        ``b``: ``brdf``, ``mis_b``) at one normal (a footprint's: their mean over its
        normals) at the drawn point sets of ``r``; the points and the technique's table once
        per pass. With ``prefix`` (a shared sequence's runs, which serve every N of their
        class): each part's prefix sums along the runs (Q, L, C), each computed once per
        normal on first use."""
        key, q, length, step = self._run_key(r, stream)
        if key not in grids:
            grids[key] = self._drawn_parts(key, q, length, step, r, stream, grids["normal"])
        parts = grids[key]
        if not prefix:
            return _Means(parts)
        sums = grids.setdefault(("prefix",) + key, {})
        return _PrefixSums(parts, sums)

    def _drawn_parts(self, key, q: int, length: int, step, r: CellRequest, stream: str,
                     normal) -> dict:
        """The parts of ``stream`` at the drawn points of ``key`` at one normal (Q, L, C)."""
        if key not in self._tables:
            opts = dict(r.options if stream == "e" else r.options_b)
            if step is None:
                u = strata_points(r.name, r.n, q, self._stream_seed(r, stream), **opts)
            else:
                u = opts["points"].runs(step, length, q,
                                        np.random.default_rng(self._stream_seed(r, stream)),
                                        opts.get("stream", "light"))
            u = u.reshape(-1, 2)
            self._tables[key] = (MapTable.at(self.technique, u) if stream == "e"
                                 else BsdfTable.at(self.renderer, u))
        table = self._tables[key]
        normals = normal[1] if isinstance(normal, tuple) else [normal]
        fr = self._fractions("mis")
        acc = {}
        for x in normals:
            if stream == "e":
                h, w = map_values(table, x, fr)
                vals = {"map": h, "mis_e": h * w[:, None]}
            else:
                h, w = bsdf_values(self.technique, self.renderer, table, x, fr)
                vals = {"brdf": h, "mis_b": h * w[:, None]}
            for k, v in vals.items():
                acc[k] = v if k not in acc else acc[k] + v
        k = len(normals)
        return {p: (v if k == 1 else v / k).reshape(q, length, -1) for p, v in acc.items()}


def _windows(cums: np.ndarray, ns: np.ndarray) -> np.ndarray:
    """The means (Q, K, W, C) of the W consecutive N-point windows of each run for the K
    values N of ``ns`` (all with ⌊L/N⌋ = W), from the runs' prefix sums (Q, L, C)."""
    ns = np.asarray(ns)
    w = cums.shape[1] // int(ns[0])
    ends = ns[:, None] * np.arange(1, w + 1)[None, :] - 1                # (K, W)
    s_end = cums[:, ends]                                                # (Q, K, W, C)
    s_start = np.concatenate([np.zeros_like(s_end[:, :, :1]), s_end[:, :, :-1]], axis=2)
    return (s_end - s_start) / ns[None, :, None, None]


class _Means(dict):
    """A part's draws' estimates (Q, C): its mean along the draws' points, computed on first
    access (``einsum``'s sum: ``mean(axis=1)``'s numbers, 4x faster over this middle axis)."""

    def __init__(self, parts: dict):
        super().__init__()
        self._parts = parts

    def __missing__(self, part: str) -> np.ndarray:
        v = self._parts[part]
        self[part] = np.einsum("qlc->qc", v) / v.shape[1]
        return self[part]


class _PrefixSums(dict):
    """A part's prefix sums along the runs (Q, L, C), computed on first access and kept in
    ``sums`` (the normal's cache)."""

    def __init__(self, parts: dict, sums: dict):
        super().__init__()
        self._parts, self._sums = parts, sums

    def __missing__(self, part: str) -> np.ndarray:
        if part not in self._sums:
            self._sums[part] = np.cumsum(self._parts[part], axis=1)
        return self._sums[part]
