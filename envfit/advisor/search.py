r"""The advisor's searches: the smallest N of a quadrature rule (doubling, then bisection) and
the smallest SH/HSH degree L, each giving one :class:`~envfit.advisor.result.AdviceRow`.

N: doubling from ``nmin`` until :math:`\hat R(N) \le` target, then bisection between the
last failing and the first passing N (:func:`smallest_n`): at most ~2 log₂(N) evaluations,
each a point of the rule's curve in the cache (its map-independent
:func:`~envfit.advisor.prediction.rule_terms`, and at the chosen N the plain wce²). For a
non-monotone prediction the answer is a crossing, :math:`\hat R(N) \le \text{target} <
\hat R(N-1)`. OSW is searched up to ``min(nmax, osw_nmax)`` (an N×N solve per N); beyond the
range a row says that the target is not reached instead of failing.

L: the first L of the band-limited truncation curve at or below the target (SH with τ,
HSH without, see :mod:`envfit.advisor.advise`), the curve doubled from L = 32 up to
``min(H − 2, LMAX_SEARCH)``; SH truncation at L = H − 1 keeps every degree the map holds and
is exact.

Example
-------
>>> smallest_n(lambda n: 1.0 / n, 0.01, 4, 1000)[0]
100
"""
from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from envfit.advisor.cache import AdviseCache
from envfit.advisor.model import MapModel
from envfit.advisor.options import AdviseOptions
from envfit.advisor.prediction import (
    rule_plain_wce2,
    rule_terms,
    seed_list,
)
from envfit.advisor.result import AdviceRow, sort_rows
from envfit.base.errors import ParameterError
from envfit.base.progress import progress_bar
from envfit.predict.bandlimited import bandlimited_rmse
from envfit.shading.spectra import band_e2, sh_truncation_curve_transfer
from envfit.theory.errors import TheoryParameterError
from envfit.theory.truncation import truncation_error_curve

__all__ = ["smallest_n", "search_quadrature", "search_truncation", "search_rules", "LMAX_SEARCH"]

#: largest L searched for a truncation (also bounded by the band limit H − 1)
LMAX_SEARCH = 512


def smallest_n(predict: Callable[[int], float], target: float, nmin: int,
               nmax: int) -> tuple[int | None, dict[int, float]]:
    r"""Smallest N in [nmin, nmax] with ``predict(N) <= target`` for a decreasing ``predict``.

    Doubling from ``nmin`` (nmin, 2·nmin, …, then nmax itself) until a passing N, then
    bisection between the last failing and the first passing N. Returns (N or None when
    even ``nmax`` fails, {N: predict(N)} of every evaluated N). For a non-monotone
    ``predict`` the answer is a crossing: predict(N) ≤ target < predict(N − 1).

    >>> smallest_n(lambda n: 1.0 / n, 0.01, 4, 1000)[0]
    100
    >>> smallest_n(lambda n: 1.0 / n, 1e-4, 4, 1000)[0] is None
    True
    """
    nmin, nmax = int(nmin), int(nmax)
    seen: dict[int, float] = {}

    def ok(n: int) -> bool:
        if n not in seen:
            seen[n] = float(predict(n))
        return seen[n] <= target

    if ok(nmin):
        return nmin, seen
    lo, hi = nmin, min(2 * nmin, nmax)
    while not ok(hi):
        if hi >= nmax:
            return None, seen
        lo, hi = hi, min(2 * hi, nmax)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if ok(mid):
            hi = mid
        else:
            lo = mid
    return hi, seen


class _RuleCurve:
    """The cached curve of one rule, N → its terms, with the points computed in this run
    (``new``, merged into the cache at the end) and their count (``evaluations``)."""

    def __init__(self, pointset, weights, wf, model: MapModel, opts: AdviseOptions,
                 store: AdviseCache):
        self.pointset, self.weights, self.wf, self.model = pointset, weights, wf, model
        self.seeds = seed_list(pointset, opts.seed, opts.seeds)
        self.workers, self.store = opts.workers, store
        self.key = {"s": model.s_rounded, "brdf": opts.brdf, "shininess": opts.shininess,
                    "pointset": pointset, "weights": weights, "seeds": self.seeds,
                    "band_lmax": model.band_lmax}
        self.points = store.load_curve(self.key)
        self.new: dict[int, dict] = {}
        self.evaluations = 0

    def terms(self, n: int) -> dict:
        """The map-independent terms at N, from the curve or computed."""
        t = self.points.get(n)
        if t is None or len(t.get("power", ())) != self.model.band_lmax + 1:
            t = {**(t or {}), **rule_terms(self.pointset, n, self.wf, self.model.s_rounded,
                                           self.weights, self.seeds, self.model.band_lmax)}
            self.points[n] = self.new[n] = t
            self.evaluations += 1
        return t

    def with_plain(self, n: int) -> dict:
        """The terms at an evaluated N with the plain wce² (Eq. 41) added when missing."""
        t = self.points[n]
        if "e2_plain" not in t:
            t = {**t, "e2_plain": rule_plain_wce2(self.pointset, n, self.wf,
                                                  self.model.s_rounded, self.weights,
                                                  self.seeds, self.workers)}
            self.points[n] = self.new[n] = t
        return t

    def predict(self, n: int) -> float:
        """The prediction (b') at N on the map."""
        t = self.terms(n)
        m = self.model
        return bandlimited_rmse(m.sigma, band_e2(t["power"], m.dw), t["dev2"],
                              m.mean_rms * m.mean_rms)

    def save(self) -> None:
        """Merge the points computed in this run into the cache."""
        self.store.merge_curve(self.key, self.new)


def search_quadrature(pointset: str, weights: str, wf, model: MapModel, opts: AdviseOptions,
                      store: AdviseCache) -> AdviceRow:
    """Smallest N of one rule on the map (``wf`` the lobe); the curve's cached points hold the
    map-independent terms, weighted here by the map's :math:`a_l(s')\\tau_l` (``model.dw``)."""
    curve = _RuleCurve(pointset, weights, wf, model, opts, store)
    upper = opts.nmax if weights == "equal" else opts.osw_upper
    row = AdviceRow(method="quadrature", pointset=pointset, weights=weights,
                    realisations=max(1, len(curve.seeds)), searched_max=upper)
    try:
        n, seen = smallest_n(curve.predict, model.target, opts.nmin, upper)
    except (TheoryParameterError, ParameterError) as exc:
        curve.save()
        row.note = f"failed: {exc}"
        row.recommendable = False
        return row
    if n is None:
        t = curve.points[upper]
        row.predicted_rmse = seen[upper]
        row.wce_bandlimited = math.sqrt(band_e2(t["power"], model.dw))
        row.weight_sum = t["weight_sum"]
        why = (" (OSW: an NxN solve per N; raise --osw-nmax)"
               if weights == "osw" and upper < opts.nmax else "")
        row.note = f"target not reached for N <= {upper}{why}"
        row.recommendable = False
    else:
        t = curve.with_plain(n)
        row.n = row.cost = n
        row.predicted_rmse = seen[n]
        row.wce_bandlimited = math.sqrt(band_e2(t["power"], model.dw))
        row.wce = math.sqrt(t["e2_plain"])
        row.predicted_rmse_plain = model.sigma * row.wce
        row.weight_sum = t["weight_sum"]
    row.evaluations = curve.evaluations
    if len(curve.seeds) > 1:
        row.note = (row.note + "; " if row.note else "") + \
            f"mean over {len(curve.seeds)} realisations"
    curve.save()
    return row


def _truncation_curve(basis: str, wf, model: MapModel) -> tuple[np.ndarray, np.ndarray, int]:
    """The band-limited truncation curve E'(L), L = 0…Lmax, doubled from Lmax = 32 until a
    degree has σ'·E ≤ target or Lmax is the top; (E, the passing degrees, Lmax)."""
    s, band_lmax = model.s_rounded, model.band_lmax
    top = min(band_lmax - 1, LMAX_SEARCH)
    lmax = min(32, top)
    while True:
        if basis == "sh":
            E = sh_truncation_curve_transfer(wf, s, lmax, band_lmax, model.tau)
        else:
            E = truncation_error_curve(wf, s, lmax, basis, lmax=band_lmax)
        ok = np.nonzero(model.sigma * E <= model.target)[0]
        if ok.size or lmax >= top:
            return E, ok, lmax
        lmax = min(2 * lmax, top)


def search_truncation(basis: str, wf, model: MapModel, brdf: str) -> AdviceRow:
    """Smallest L: SH by :func:`~envfit.shading.spectra.sh_truncation_curve_transfer` (with τ),
    HSH by ``truncation_error_curve(..., lmax=H-1)`` (no τ; see :mod:`envfit.advisor.advise`)."""
    s, sigma, band_lmax = model.s_rounded, model.sigma, model.band_lmax
    row = AdviceRow(method=basis)
    E, ok, lmax = _truncation_curve(basis, wf, model)
    if ok.size:
        L, eb = int(ok[0]), float(E[int(ok[0])])
    elif basis == "sh" and band_lmax - 1 <= LMAX_SEARCH:
        L, eb = band_lmax, 0.0                # every degree the map holds is kept: exact
    else:
        L, eb = None, float(E[-1])
    row.searched_max = lmax if L is None else None
    row.wce_bandlimited = eb
    row.predicted_rmse = sigma * eb
    if L is not None:
        row.L = L
        row.cost = (L + 1) ** 2
        plain = float(truncation_error_curve(wf, s, L, basis)[L])
        row.wce = plain
        row.predicted_rmse_plain = sigma * plain
    else:
        row.note = f"target not reached for L <= {lmax}"
        row.recommendable = False
    if basis == "hsh" and brdf == "diffuse":
        row.recommendable = False
        row.note = (row.note + "; " if row.note else "") + \
            "diffuse HSH is exact from L = 1 (the projection is the integral): not recommended"
    return row


def search_rules(wf, model: MapModel, opts: AdviseOptions, store: AdviseCache) -> list[AdviceRow]:
    """One row per point set × weighting and per basis, sorted by cost
    (:func:`~envfit.advisor.result.sort_rows`), with a progress bar unless ``opts.quiet``."""
    jobs = [("quadrature", ps, w) for ps in opts.pointsets for w in opts.weights] + \
           [(b, None, None) for b in opts.bases]
    rows: list[AdviceRow] = []
    bar = progress_bar(len(jobs), desc="advise", quiet=opts.quiet, unit="rule")
    try:
        for method, ps, w in jobs:
            if hasattr(bar, "set_postfix_str"):
                bar.set_postfix_str(f"{ps}/{w}" if ps else method)
            if method == "quadrature":
                rows.append(search_quadrature(ps, w, wf, model, opts, store))
            else:
                rows.append(search_truncation(method, wf, model, opts.brdf))
            bar.update(1)
    finally:
        bar.close()
    return sort_rows(rows)
