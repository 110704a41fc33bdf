r"""The advisor's searches: the smallest N of a quadrature rule (doubling, then bisection) and
the smallest SH/HSH degree L, each giving one :class:`~envfit.advisor._result.AdviceRow`.

N: ``nmax`` first (a decreasing prediction that misses the target there misses it
everywhere: one evaluation), then doubling from ``nmin`` until :math:`\hat R(N) \le`
target and bisection between the last failing and the first passing N (:func:`smallest_n`):
at most ~2 log₂(N) + 1 evaluations,
each a point of the rule's curve in the cache (its map-independent
:func:`~envfit.advisor._prediction.rule_terms`, and at the chosen N the plain wce²). For a
non-monotone prediction the answer is a crossing, :math:`\hat R(N) \le \text{target} <
\hat R(N-1)`. OSW is searched up to ``min(nmax, osw_nmax)`` (an N×N solve per N); beyond the
range a row says that the target is not reached instead of failing.

L: the first L at or below the target of the row's predictor — SH: (b') (band-limited
curve with τ; at L = H − 1 every degree of the model is kept: 0) or (c) (the map's own power
above L to 2H − 1, :func:`envfit.predict._spectral.spectral_truncation_curve`), both for every
L at once (O(H)); HSH: (b') only (no τ, see :mod:`envfit.advisor._advise`), the curve doubled
from L = 32 up to ``min(H − 2, LMAX_SEARCH)``.

Which predictor sizes a row, and the second search when (b') and (c) disagree:
:mod:`envfit.advisor._choice`.

Example
-------
>>> smallest_n(lambda n: 1.0 / n, 0.01, 4, 1000)[0]
100
"""
from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from envfit.advisor._cache import AdviseCache
from envfit.advisor._choice import disagree, disagreement_line, first_predictor, ratio
from envfit.advisor._model import MapModel
from envfit.advisor._options import AdviseOptions
from envfit.advisor._prediction import rule_plain_wce2, rule_terms, seed_list, terms_rule
from envfit.advisor._result import AdviceRow, sort_rows
from envfit.base import ParameterError
from envfit.base import progress_bar
from envfit.predict import QuadratureRule, predict
from envfit.predict import spectral_truncation_curve
from envfit.shading import sh_truncation_curve_transfer
from envfit.theory import TheoryParameterError
from envfit.theory import truncation_error_curve

__all__ = ["smallest_n", "search_quadrature", "search_truncation", "search_rules", "LMAX_SEARCH"]

#: largest L searched for a truncation (also bounded by the band limit H − 1)
LMAX_SEARCH = 512


def smallest_n(predict: Callable[[int], float], target: float, nmin: int,
               nmax: int) -> tuple[int | None, dict[int, float]]:
    r"""Smallest N in [nmin, nmax] with ``predict(N) <= target`` for a decreasing ``predict``.

    ``nmax`` first: if it misses the target, so does every smaller N of a decreasing
    ``predict``, and the answer (None) costs one evaluation instead of the ~log₂(nmax/nmin)
    of the doubling (the costliest ones: the error power at N = 65536 is ~1–2 s on a
    1024×512 map). Otherwise doubling from ``nmin`` (nmin, 2·nmin, …, then nmax itself,
    already evaluated) until a passing N, then bisection between the last failing and the
    first passing N: the same N as without the first evaluation. Returns (N or None when
    ``nmax`` fails, {N: predict(N)} of every evaluated N). The search *assumes* ``predict``
    decreases with N; for a non-monotone one the answer is a crossing, predict(N) ≤ target <
    predict(N − 1), and a target that only some N < nmax reach while ``nmax`` misses it is
    reported as not reached.

    >>> smallest_n(lambda n: 1.0 / n, 0.01, 4, 1000)[0]
    100
    >>> smallest_n(lambda n: 1.0 / n, 1e-4, 4, 1000)      # one evaluation: nmax misses
    (None, {1000: 0.001})
    """
    nmin, nmax = int(nmin), int(nmax)
    seen: dict[int, float] = {}

    def ok(n: int) -> bool:
        if n not in seen:
            seen[n] = float(predict(n))
        return seen[n] <= target

    if not ok(nmax):                    # the largest N misses: so does every N (decreasing)
        return None, seen
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
    (``new``, merged into the cache at the end) and their count (``evaluations``); the terms'
    error power runs to ``model.spectral_lmax`` = 2H − 1 (prediction (c) with its tail)."""

    def __init__(self, pointset, weights, wf, model: MapModel, opts: AdviseOptions,
                 store: AdviseCache, bar=None):
        self.pointset, self.weights, self.wf, self.model = pointset, weights, wf, model
        self.bar = bar
        self.seeds = seed_list(pointset, opts.seed, opts.seeds)
        self.workers, self.store = opts.workers, store
        self.key = {"s": model.s_rounded, "brdf": opts.brdf, "shininess": opts.shininess,
                    "pointset": pointset, "weights": weights, "seeds": self.seeds,
                    "band_lmax": model.band_lmax, "spectral_lmax": model.spectral_lmax}
        self.points = store.load_curve(self.key)
        self.new: dict[int, dict] = {}
        self.evaluations = 0
        self.ctx, self.ctx_band = model.context(), model.context(band=True)

    def terms(self, n: int) -> dict:
        """The map-independent terms at N, from the curve or computed."""
        t = self.points.get(n)
        if t is None or len(t.get("power", ())) != self.model.spectral_lmax + 1:
            if self.bar is not None:
                self.bar.set_postfix_str(f"{self.pointset}/{self.weights} N = {n}")
            t = {**(t or {}), **rule_terms(self.pointset, n, self.wf, self.model.s_rounded,
                                           self.weights, self.seeds, self.model.spectral_lmax)}
            self.points[n] = self.new[n] = t
            self.evaluations += 1
        return t

    def with_plain(self, n: int) -> dict:
        """The terms at an evaluated N with the plain wce² (Eq. 41) added when missing."""
        t = self.terms(n)
        if "e2_plain" not in t:
            t = {**t, "e2_plain": rule_plain_wce2(self.pointset, n, self.wf,
                                                  self.model.s_rounded, self.weights,
                                                  self.seeds, self.workers)}
            self.points[n] = self.new[n] = t
        return t

    def bandlimited(self, n: int) -> float:
        """The prediction (b') at N on the map (:func:`envfit.predict.predict`)."""
        return predict("bandlimited", self.ctx, terms_rule(n, self.terms(n))).rmse

    def spectral(self, n: int, band: bool = False) -> float:
        """The prediction (c) at N on the map, with its tail to 2H − 1 (``band``: to H − 1)."""
        ctx = self.ctx_band if band else self.ctx
        return predict("spectral", ctx, terms_rule(n, self.terms(n))).rmse

    def predictor(self, name: str) -> Callable[[int], float]:
        """N → the prediction named ``name`` ("bandlimited" or "spectral")."""
        return self.spectral if name == "spectral" else self.bandlimited

    def save(self) -> None:
        """Merge the points computed in this run into the cache."""
        self.store.merge_curve(self.key, self.new)


def _choose_n(curve: _RuleCurve, label: str, model: MapModel, opts: AdviseOptions,
              upper: int) -> tuple[int | None, str, str]:
    """The smallest N by the first predictor (:func:`~envfit.advisor._choice.first_predictor`),
    searched again by (c) when (b') was first and the two disagree at its N
    (:mod:`envfit.advisor._choice`): (N or None, the predictor used, the warning or "")."""
    name = first_predictor(opts.predictor, opts.scale)
    n, _ = smallest_n(curve.predictor(name), model.target, opts.nmin, upper)
    at = upper if n is None else n
    warning = ""
    if opts.predictor == "auto" and disagree(curve.bandlimited(at), curve.spectral(at)):
        warning = disagreement_line(label, ratio(curve.bandlimited(at), curve.spectral(at)),
                                    f"N = {at}")
        if name == "bandlimited":
            name = "spectral"
            n, _ = smallest_n(curve.spectral, model.target, opts.nmin, upper)
    return n, name, warning


def _fill_quadrature(row: AdviceRow, curve: _RuleCurve, n: int | None, upper: int,
                     model: MapModel, opts: AdviseOptions) -> None:
    """The row's numbers at its N (or at ``upper`` when the target is not reached)."""
    at = upper if n is None else n
    t = curve.with_plain(n) if n is not None else curve.terms(upper)
    row.predicted_rmse = curve.bandlimited(at)
    row.predicted_rmse_spectral = curve.spectral(at)
    row.predicted_rmse_spectral_band = curve.spectral(at, band=True)
    row.spectral_lmax = model.spectral_lmax
    row.spectral_ratio = ratio(row.predicted_rmse, row.predicted_rmse_spectral)
    row.wce_bandlimited = predict("bandlimited", curve.ctx, terms_rule(at, t)).wce
    row.weight_sum = t["weight_sum"]
    if n is None:
        why = (" (OSW: an NxN solve per N; raise --osw-nmax)"
               if row.weights == "osw" and upper < opts.nmax else "")
        row.note = f"target not reached for N <= {upper}{why}"
        row.recommendable = False
    else:
        row.n = row.cost = n
        row.wce = math.sqrt(t["e2_plain"])
        row.predicted_rmse_plain = predict("plain", curve.ctx,
                                           QuadratureRule(n=n, wce=row.wce)).rmse


def search_quadrature(pointset: str, weights: str, wf, model: MapModel, opts: AdviseOptions,
                      store: AdviseCache, bar=None) -> AdviceRow:
    """Smallest N of one rule on the map (``wf`` the lobe) by the predictor of
    :mod:`envfit.advisor._choice`; the curve's cached points hold the map-independent terms,
    predicted by :func:`envfit.predict.predict` on the map's context
    (:meth:`~envfit.advisor._model.MapModel.context`: :math:`a_l(s')\\tau_l` for (b'),
    :math:`\\hat P_l` for (c)). ``bar``: a progress bar whose postfix names
    each N whose error power is computed (seconds each on a 2048x1024 map)."""
    curve = _RuleCurve(pointset, weights, wf, model, opts, store, bar)
    upper = opts.nmax if weights == "equal" else opts.osw_upper
    row = AdviceRow(method="quadrature", pointset=pointset, weights=weights,
                    realisations=max(1, len(curve.seeds)), searched_max=upper)
    try:
        n, row.predictor, row.warning = _choose_n(curve, row.label, model, opts, upper)
        _fill_quadrature(row, curve, n, upper, model, opts)
    except (TheoryParameterError, ParameterError) as exc:
        curve.save()
        row.note = f"failed: {exc}"
        row.recommendable = False
        return row
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


class _ShCurves:
    r"""SH truncation's predictions for every L: (b') :math:`\sigma'E'(L)` (0 from L = H − 1
    on: every degree of the band-limited model is kept) and (c)
    (:func:`envfit.predict._spectral.spectral_truncation_curve`, the map's own power to
    2H − 1; ``band``: to H − 1)."""

    def __init__(self, wf, model: MapModel):
        H1, lt = model.band_lmax, model.spectral_lmax
        self.b = np.append(model.sigma * sh_truncation_curve_transfer(
            wf, model.s_rounded, H1 - 1, H1, model.tau), 0.0)               # L = 0…H − 1
        zonal = wf.sh_coefficients(lt)
        self.c = spectral_truncation_curve(model.map_power, zonal, lt - 1)  # L = 0…2H − 2
        self.c_band = spectral_truncation_curve(model.map_power[:, :H1 + 1], zonal, H1)
        self.top = {"bandlimited": H1 if H1 - 1 <= LMAX_SEARCH else LMAX_SEARCH,
                    "spectral": min(lt - 1, LMAX_SEARCH)}

    def at(self, name: str, L: int) -> float:
        """The prediction ``name`` at L."""
        curve = {"bandlimited": self.b, "spectral": self.c, "band": self.c_band}[name]
        return float(curve[min(L, curve.size - 1)])

    def first(self, name: str, target: float) -> int | None:
        """The smallest L ≤ the top of ``name`` whose prediction is at most ``target``."""
        curve = self.b if name == "bandlimited" else self.c
        ok = np.nonzero(curve[:self.top[name] + 1] <= target)[0]
        return int(ok[0]) if ok.size else None


def _sh_row(wf, model: MapModel, opts: AdviseOptions) -> AdviceRow:
    """Smallest SH degree L by the predictor of :mod:`envfit.advisor._choice`."""
    cv = _ShCurves(wf, model)
    row = AdviceRow(method="sh")
    name = first_predictor(opts.predictor, opts.scale)
    L = cv.first(name, model.target)
    at = cv.top[name] if L is None else L
    if opts.predictor == "auto" and disagree(cv.at("bandlimited", at), cv.at("spectral", at)):
        r = ratio(cv.at("bandlimited", at), cv.at("spectral", at))
        row.warning = disagreement_line(row.label, r, f"L = {at}")
        if name == "bandlimited":
            name = "spectral"
            L = cv.first(name, model.target)
    row.predictor = name
    at = cv.top[name] if L is None else L
    row.predicted_rmse, row.predicted_rmse_spectral = cv.at("bandlimited", at), \
        cv.at("spectral", at)
    row.predicted_rmse_spectral_band = cv.at("band", at)
    row.spectral_lmax, row.wce_bandlimited = model.spectral_lmax, row.predicted_rmse / model.sigma
    row.spectral_ratio = ratio(row.predicted_rmse, row.predicted_rmse_spectral)
    if L is None:
        row.searched_max, row.recommendable = at, False
        row.note = f"target not reached for L <= {at}"
    else:
        row.L, row.cost = L, (L + 1) ** 2
        row.wce = float(truncation_error_curve(wf, model.s_rounded, L, "sh")[L])
        row.predicted_rmse_plain = model.sigma * row.wce
    return row


def _hsh_row(wf, model: MapModel, opts: AdviseOptions) -> AdviceRow:
    """Smallest HSH degree L by (b') (``truncation_error_curve(..., lmax=H-1)``, no τ), unless
    (b') fails on this map (:func:`_hsh_unsupported`)."""
    s, sigma = model.s_rounded, model.sigma
    row = AdviceRow(method="hsh", note="(b') only: no (c) for HSH (its projection is not "
                                       "diagonal in l)")
    E, ok, lmax = _truncation_curve("hsh", wf, model)
    L, eb = (int(ok[0]), float(E[int(ok[0])])) if ok.size else (None, float(E[-1]))
    row.searched_max = lmax if L is None else None
    row.wce_bandlimited = eb
    row.predicted_rmse = sigma * eb
    why = _hsh_unsupported(wf, model, opts, lmax if L is None else L)
    if why:
        row.warning, row.searched_max, row.recommendable = why, lmax if L is None else L, False
        row.note += "; not sized: (b') fails on this map"
    elif L is not None:
        row.L, row.cost = L, (L + 1) ** 2
        row.wce = float(truncation_error_curve(wf, s, L, "hsh")[L])
        row.predicted_rmse_plain = sigma * row.wce
    else:
        row.note += f"; target not reached for L <= {lmax}"
        row.recommendable = False
    if opts.brdf == "diffuse":
        row.recommendable = False
        row.note += "; diffuse HSH is exact from L = 1 (the projection is the integral): " \
                    "not recommended"
    return row


def _hsh_unsupported(wf, model: MapModel, opts: AdviseOptions, L: int) -> str:
    r"""Why the HSH row, which only (b′) predicts, cannot be sized on this map ("" if it can):
    with ``predictor="auto"``, (b′) and (c) of the *SH* truncation at the same L disagree by
    more than :data:`~envfit.advisor._choice.DISAGREEMENT` — the Sobolev model does not hold
    at those degrees (a linear map with a sun: on city.exr, glossy, HSH by (b′) measured
    8–9× its target), and there is no second prediction to size the row by."""
    if opts.predictor != "auto" or opts.brdf == "diffuse":
        return ""
    cv = _ShCurves(wf, model)
    b, c = cv.at("bandlimited", L), cv.at("spectral", L)
    if not disagree(b, c):
        return ""
    return (f"rule HSH: only (b′) predicts it, and on this map (b′) and (c) of SH truncation "
            f"disagree (ratio {ratio(b, c):.3g} at L = {L}); not sized")


def search_truncation(basis: str, wf, model: MapModel, opts: AdviseOptions) -> AdviceRow:
    """Smallest L: SH by (b') (:func:`~envfit.shading._spectra.sh_truncation_curve_transfer`,
    with τ) or (c) (:func:`~envfit.predict._spectral.spectral_truncation_curve`), chosen as a
    quadrature row's predictor; HSH by (b') only (``truncation_error_curve(..., lmax=H-1)``,
    no τ; see :mod:`envfit.advisor._advise`)."""
    return _sh_row(wf, model, opts) if basis == "sh" else _hsh_row(wf, model, opts)


def search_rules(wf, model: MapModel, opts: AdviseOptions, store: AdviseCache) -> list[AdviceRow]:
    """One row per point set × weighting and per basis, sorted by cost
    (:func:`~envfit.advisor._result.sort_rows`), with a progress bar unless ``opts.quiet``."""
    jobs = [("quadrature", ps, w) for ps in opts.pointsets for w in opts.weights] + \
           [(b, None, None) for b in opts.bases]
    rows: list[AdviceRow] = []
    bar = progress_bar(len(jobs), desc="advise", quiet=opts.quiet, unit="rule")
    try:
        for method, ps, w in jobs:
            if hasattr(bar, "set_postfix_str"):
                bar.set_postfix_str(f"{ps}/{w}" if ps else method)
            if method == "quadrature":
                rows.append(search_quadrature(ps, w, wf, model, opts, store, bar))
            else:
                rows.append(search_truncation(method, wf, model, opts))
            bar.update(1)
    finally:
        bar.close()
    return sort_rows(rows)
