r"""The renderer model's drawn stratified cells: correlated multi-jittering and orthogonal
arrays above the N their exact models reach, as a part of :class:`._diffuse_model.DiffuseModel`.

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
search's coarse pass asks for exactly those) a cell is the anchors' local power law
(:func:`geometric`): a search's bracket costs no new draws.

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
from envfit.predict.renderer.randomisation import (STRATA_SAMPLED, sampled_strata_mse,
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

    >>> strata_reach("cmj", 9), strata_reach("orthogonal", 7), strata_reach("owen", 9)
    (512, 128, 0)
    """
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

    def _strata_cell(self, r: CellRequest, grids: dict):
        """(mse, map part, BSDF part, 0) per channel of a drawn stratified cell at one normal:
        each stream's variance over Q draws of the sampler's point sets
        (:mod:`.randomisation._strata_samples`); the streams' permutations are independent, so
        their variances add. The per-draw terms go to ``grids`` for :meth:`_draws`."""
        streams = {"map": (("e", "map"),), "brdf": (("b", "brdf"),),
                   "mis": (("e", "mis_e"), ("b", "mis_b"))}[r.strategy]
        out = {"e": 0.0, "b": 0.0}
        per_draw = 0.0
        for stream, part in streams:
            mse, z = sampled_strata_mse(self._strata_values(grids, r, stream)[part])
            out[stream], per_draw = mse, per_draw + z
        grids["strata_draws", r] = per_draw
        e, b = (np.asarray(out[k]) * np.ones(1) for k in ("e", "b"))
        e, b = np.broadcast_arrays(e, b)
        return e + b, e, b, np.zeros_like(e)

    def _strata_values(self, grids: dict, r: CellRequest, stream: str) -> dict:
        """The parts of ``stream`` (``e``: ``map``, ``mis_e``; ``b``: ``brdf``, ``mis_b``) at
        one normal (a footprint's: their mean over its normals) at the drawn point sets of
        ``r``, (Q, N, C) each; the points and the technique's table once per pass."""
        opts = r.options if stream == "e" else r.options_b
        key = ("strata", r.name, r.n, opts, stream)
        if key in grids:
            return grids[key]
        if key not in self._tables:
            q = strata_draws(r.n)
            u = strata_points(r.name, r.n, q, self.options.seed + (stream == "b"),
                              **dict(opts)).reshape(-1, 2)
            self._tables[key] = (q, MapTable.at(self.technique, u) if stream == "e"
                                 else BsdfTable.at(self.renderer, u))
        q, table = self._tables[key]
        normal = grids["normal"]
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
                acc[k] = acc.get(k, 0.0) + v / len(normals)
        grids[key] = {k: v.reshape(q, r.n, -1) for k, v in acc.items()}
        return grids[key]
