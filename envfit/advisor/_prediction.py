r"""The advisor's prediction of one rule's RMS shading error on a map, from map-independent terms.

A rule (point set, weighting, N, realisation seeds) contributes its error power per degree
:math:`e_l`, l = 0…H − 1 (:func:`envfit.shading._spectra.rule_error_power`, averaged over the
realisations of a stochastic set) and the squared deviation :math:`(\sum_j w_j - 1)^2` of its
weights' sum (:func:`rule_terms`), as a :class:`envfit.predict.QuadratureRule`
(:func:`terms_rule`); the map contributes σ', :math:`a_l(s')\tau_l`
(:func:`envfit.shading._spectra.degree_weights`) and :math:`\overline{m^2}`
(:meth:`envfit.advisor._model.MapModel.context`). The predictions are the registry's
(:func:`envfit.predict.predict`): (b') ``"bandlimited"``,
:math:`(\sigma'^2 E'^2 + (\sum w-1)^2\overline{m^2})^{1/2}` with
:math:`E'^2 = \sum_{l\le H-1} a_l\tau_l e_l` (:func:`envfit.predict.predict_bandlimited`);
see :mod:`envfit.advisor._advise` for the model.

Prediction (c) (``"spectral"``, :func:`envfit.predict.predict_spectral`) weights the same :math:`e_l` by the map's own
realised power per degree :math:`\hat P_{l,c}` (of its bilinear interpolant), to
:math:`L_\mathrm{tail} = 2H - 1` (:func:`envfit.advisor._model.spectral_lmax`):

.. math:: \hat R_c^2 = \frac1C\sum_c\sum_{l=0}^{L_\mathrm{tail}} \hat P_{l,c}\,e_l
          = \underbrace{\frac1C\sum_c\sum_{l\le H-1}\hat P_{l,c}e_l}_{\text{validate's (c)}}
          + \underbrace{\frac1C\sum_c\sum_{l=H}^{L_\mathrm{tail}}\hat P_{l,c}e_l}_{\text{tail}},

exact in expectation over Haar-random rotations for the interpolant's content up to
:math:`L_\mathrm{tail}` (:func:`envfit.shading._spectra.spectral_rmse`; the mean term is its
l = 0 part, :math:`\hat P_0 = 4\pi\bar m^2`). So the rule's power is computed to
:math:`L_\mathrm{tail}` and (b′) uses its first H degrees.

Example
-------
>>> from envfit.shading._ground_truth import weight_function
>>> t = rule_terms("sf", 64, weight_function("diffuse", 30.0), 1.5, "equal", [], 15)
>>> len(t["power"]), t["dev2"] < 1e-24, round(t["weight_sum"], 12)
(16, True, 1.0)
>>> seed_list("sf", 0, 4), len(seed_list("random", 0, 4))
([], 4)
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from envfit.base import ParameterError
from envfit.base import s_value
from envfit.defaults import DEFAULT_SHININESS
from envfit.maps import EnvMap
from envfit.predict import PredictionContext, QuadratureRule, predict
from envfit.shading import bilinear_sh_coefficients
from envfit.shading import weight_function
from envfit.shading import rule_error_power
from envfit.theory import DETERMINISTIC_POINTSETS, generate
from envfit.theory import worst_case_error
from envfit.theory import GLOSSY_MAX_SHININESS, Glossy
from envfit.theory import equal_weights, optimal_weights

__all__ = ["LOBE_TAIL_TRANSFER", "lobe_tail_transfer", "glossy_transfer",
           "max_resolved_shininess", "rows_resolving", "check_lobe_resolved",
           "mean_shading_value", "seed_list", "make_rule",
           "rule_terms", "rule_plain_wce2", "terms_rule", "advice_context", "row_prediction",
           "row_prediction_spectral"]


#: the most of the map's content just above the predictions' top degree 2H − 1 that the lobe
#: may pass (its Funk–Hecke factor |λ_l| there; ≤ 1 % of the power). The same 0.1 as
#: envfit.advisor._budget.lobe_rows (the rows a downsampled map keeps). Loose on sun maps: on a
#: 128-row one glossy n = 1e4 (λ = 0.037 at l = 256) measured 1.33× its (c), against
#: 1.07–1.10 at n = 30 and 1000; 0.01 would refuse it (change both together)
LOBE_TAIL_TRANSFER = 0.1


def lobe_tail_transfer(wf, top: int) -> float:
    r"""The lobe's largest :math:`|\lambda_l| = \sqrt{4\pi/(2l+1)}\,|b_l|` at l = top + 1,
    top + 2 (two, so that the diffuse lobe's zero odd degrees do not hide it): how much of
    the map's content just above degree ``top`` the shading integral passes.

    >>> round(lobe_tail_transfer(Glossy(30.0), 63), 12) <= 1e-12
    True
    """
    l = np.arange(top + 1, top + 3)
    b = np.asarray(wf.sh_coefficients(top + 2), dtype=np.float64)[l]
    return float(np.max(np.sqrt(4.0 * np.pi / (2 * l + 1)) * np.abs(b)))


def glossy_transfer(n: float, l: int) -> float:
    r""":math:`\lambda_l` of the glossy lobe :math:`e^{n(z-1)}` by the full-sphere Bessel form
    (Eq. 27), :math:`\sqrt{2\pi n/(2l+1)}\,\sqrt{2\nu}\,e^{-n}I_\nu(n)/(1-e^{-n})`, ν = l + ½,
    exponentially scaled (no overflow or underflow for any n); ≈ :math:`e^{-l(l+1)/2n}` for
    large n; exact to :math:`e^{-n}` (the lower hemisphere).

    >>> abs(glossy_transfer(1e4, 100) - math.exp(-100 * 101 / 2e4)) < 1e-3
    True
    """
    from scipy import special
    nu = l + 0.5
    with np.errstate(under="ignore"):
        iv = float(special.ive(nu, n))
    return math.sqrt(4.0 * math.pi / (2 * l + 1)) * math.sqrt(n * nu) * iv / (-math.expm1(-n))


def max_resolved_shininess(top: int, tol: float = LOBE_TAIL_TRANSFER) -> float:
    """The largest glossy exponent n whose lobe passes at most ``tol`` of degree ``top`` + 1
    (:func:`glossy_transfer`, increasing in n), by bisection on log n to 0.1 %, at most
    :data:`envfit.theory._brdf.GLOSSY_MAX_SHININESS`.

    >>> n = max_resolved_shininess(63); round(glossy_transfer(n, 64), 2)
    0.1
    """
    lo, hi = 1e-3, GLOSSY_MAX_SHININESS
    if glossy_transfer(hi, top + 1) <= tol:
        return hi
    while hi / lo > 1.001:
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if glossy_transfer(mid, top + 1) <= tol else (lo, mid)
    return lo


def rows_resolving(n: float, tol: float = LOBE_TAIL_TRANSFER) -> int:
    """The fewest rows H whose predictions (to degree 2H − 1) resolve the glossy lobe of
    exponent n: :func:`glossy_transfer` (n, 2H) ≤ ``tol``.

    >>> h = rows_resolving(1e5); glossy_transfer(1e5, 2 * h) <= 0.1 < glossy_transfer(1e5, 2 * h - 2)
    True
    """
    lo, hi = 1, 2
    while glossy_transfer(n, 2 * hi) > tol:
        lo, hi = hi, 2 * hi
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if glossy_transfer(n, 2 * mid) <= tol else (mid, hi)
    return hi


def check_lobe_resolved(wf, height: int, tol: float = LOBE_TAIL_TRANSFER) -> None:
    r"""Refuse a lobe too sharp for the predictions on an H-row map, before any work.

    Both predictions see the map to degree :math:`2H - 1` at most (:math:`\hat P_l` of (c),
    :func:`envfit.advisor._model.spectral_lmax`; (b′) to H − 1). A glossy lobe passes degree l
    of the map by :math:`\lambda_l \approx e^{-l(l+1)/2n}`, so a lobe sharper than that box
    (bandwidth ≈ √n above 2H − 1) shades with content no prediction holds, and they come
    out low: on a 32-row sun map, random/equal measured 1.18× its (c) at n = 500
    (λ = 0.016 at l = 64), 1.36× at n = 1500 (λ = 0.25), SH at L = 60 2.5× at n = 3000;
    on a 128-row one sf/osw 1.33× at n = 1e4 (λ = 0.037 at l = 256, 1.07–1.10 at n ≤ 1000);
    the issue's 1e5 on a 128-row map (λ = 0.72 at l = 256) 5×, and at n = 1e6 every
    coefficient of the old quadrature underflowed (predicted 0). Allowed: |λ| ≤ ``tol``
    (:data:`LOBE_TAIL_TRANSFER`) at 2H, 2H + 1 (:func:`lobe_tail_transfer`).

    Raises
    ------
    envfit.base._errors.ParameterError
        One line: the transfer, the largest shininess for this map and the rows a sharper
        lobe needs.

    >>> check_lobe_resolved(Glossy(30.0), 16)
    >>> check_lobe_resolved(Glossy(1e5), 128)
    Traceback (most recent call last):
    ...
    envfit.base._errors.ParameterError: shininess 100000: the lobe passes 72 % of the map's content at degree 256, above the 255 (2H - 1) that the predictions hold on this 128-row map; they need it below 10 %: shininess <= 1.43e+04 for this map (a sharper lobe needs a map of >= 340 rows)
    """
    top = 2 * int(height) - 1
    lam = lobe_tail_transfer(wf, top)
    if lam <= tol:
        return
    what = (f"shininess {wf.shininess:g}" if isinstance(wf, Glossy) else f"the lobe {wf!r}")
    msg = (f"{what}: the lobe passes {100 * lam:.0f} % of the map's content at degree "
           f"{top + 1}, above the {top} (2H - 1) that the predictions hold on this "
           f"{int(height)}-row map; they need it below {100 * tol:.0f} %")
    if isinstance(wf, Glossy):
        msg += (f": shininess <= {max_resolved_shininess(top, tol):.3g} for this map (a "
                f"sharper lobe needs a map of >= {rows_resolving(wf.shininess, tol)} rows)")
    raise ParameterError(msg)


def mean_shading_value(scaled: EnvMap) -> float:
    r"""Mean over all axes of the normalised shading integral (Eq. 17), averaged over channels.

    By Funk–Hecke, :math:`I(a) = \sum_l \lambda_l\sum_m f_{lm}Y_{lm}(a)`, and only l = 0
    survives the mean over the sphere of axes: :math:`\bar I = \lambda_0 f_{00}Y_{00} =
    f_{00}/\sqrt{4\pi}` (:math:`\lambda_0 = 1` since I ≡ 1 for f ≡ 1) — the solid-angle mean of
    the map's bilinear interpolant, the same for every normalised lobe. From the exact
    :math:`f_{00}` of :func:`envfit.shading._ground_truth.bilinear_sh_coefficients`.

    >>> round(mean_shading_value(EnvMap(np.full((4, 8, 2), 3.0))), 9)
    3.0
    """
    alm = bilinear_sh_coefficients(scaled, 0)
    return float(np.mean(alm[:, 0].real) / math.sqrt(4.0 * math.pi))


def seed_list(pointset: str, seed: int, k: int) -> list[int]:
    """Realisation seeds of a stochastic point set ([] for a deterministic one)."""
    if pointset in DETERMINISTIC_POINTSETS:
        return []
    return [int(np.random.SeedSequence([int(seed), 41, j]).generate_state(1)[0]) for j in range(k)]


#: OSW rules kept by :func:`make_rule` (an N×N kernel matrix and Cholesky each: ≈ 3 s at
#: N = 4096 on 2 cores), so that the error power, the plain wce² and the check of one rule
#: in one run share one solve
_OSW_MEMO: dict = {}
_OSW_MEMO_POINTS = 1 << 17


def make_rule(pointset: str, n: int, wf, s: float, weights: str,
              seed) -> tuple[np.ndarray, np.ndarray]:
    """Points (morphed by the lobe ``wf``) and weights ("equal", or "osw" at ``s``) of a rule;
    ``seed`` None for a deterministic set. OSW rules are kept in memory (the last ones, up to
    2^17 points in all; keyed by point set, N, the lobe, s and seed) and returned as
    read-only arrays: the same numbers as a fresh solve."""
    if weights != "equal":
        key = (pointset, int(n), type(wf).__name__, getattr(wf, "shininess", None), float(s),
               None if seed is None else int(seed))
        hit = _OSW_MEMO.get(key)
        if hit is not None:
            return hit
    pts = generate(pointset, n, seed=0 if seed is None else seed, morph=wf.morph)
    if weights == "equal":
        return pts, equal_weights(n)
    w = optimal_weights(pts, wf, s)
    pts.setflags(write=False)
    w.setflags(write=False)
    while _OSW_MEMO and sum(p.shape[0] for p, _ in _OSW_MEMO.values()) + n > _OSW_MEMO_POINTS:
        _OSW_MEMO.pop(next(iter(_OSW_MEMO)))
    _OSW_MEMO[key] = (pts, w)
    return pts, w


def rule_terms(pointset: str, n: int, wf, s: float, weights: str, seeds: Sequence[int],
               band_lmax: int) -> dict:
    r"""The map-independent terms of a rule, averaged over the realisations ``seeds``
    ([] = the deterministic set once): ``power`` the error power :math:`e_l`, l = 0…band_lmax
    (:func:`envfit.shading._spectra.rule_error_power`, a list; the advisor passes
    :math:`L_\mathrm{tail} = 2H - 1` for prediction (c)), ``dev2`` :math:`(\sum w-1)^2` and
    ``weight_sum``. ``s`` only sets the OSW weights. :math:`E'^2` is
    ``band_e2(power[:H], degree_weights(s', H - 1, tau))``."""
    pw, dev2, ws = [], [], []
    for sd in (seeds or [None]):
        pts, w = make_rule(pointset, n, wf, s, weights, sd)
        pw.append(rule_error_power(pts, w, wf, band_lmax))
        wsum = math.fsum(w)
        dev2.append((wsum - 1.0) ** 2)
        ws.append(wsum)
    power = pw[0] if len(pw) == 1 else np.mean(np.stack(pw), axis=0)
    return {"power": [float(x) for x in power], "dev2": float(np.mean(dev2)),
            "weight_sum": float(np.mean(ws))}


def rule_plain_wce2(pointset: str, n: int, wf, s: float, weights: str, seeds: Sequence[int],
                    workers: int = 2) -> float:
    r"""Unrestricted squared worst-case error (Eq. 41), averaged over the realisations.

    A lobe with a jump at the horizon (glossy, small n: :math:`b_l \sim e^{-n}n\,l^{-3/2}`)
    leaves the kernel mean embedding's series a tail above its 1e-15 goal at its cap
    (:func:`envfit.theory._quadrature.embedding_coefficients`; ≈ 4e-12 at n = 1, s = 1.5):
    that RuntimeWarning is not the user's to see — the column prints 4 digits of
    σ′·wce, and the tail moves E² by under 1e-4 of it at N = 65536 — so it is silenced here.
    """
    import warnings
    out = []
    for sd in (seeds or [None]):
        pts, w = make_rule(pointset, n, wf, s, weights, sd)
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message="kernel mean embedding",
                                    category=RuntimeWarning)
            out.append(worst_case_error(pts, w, wf, s, workers=workers) ** 2)
    return float(np.mean(out))


def terms_rule(n: int, terms: dict) -> QuadratureRule:
    r"""The :class:`envfit.predict.QuadratureRule` of a curve's terms at N
    (:func:`rule_terms`: the error power, :math:`\sum_j w_j` and :math:`(\sum_j w_j - 1)^2`,
    each averaged over the realisations), for :func:`envfit.predict.predict`.

    >>> r = terms_rule(8, {"power": [0.0, 2.0], "dev2": 0.25, "weight_sum": 1.5})
    >>> r.n, r.weight_dev2, r.weight_sum
    (8, 0.25, 1.5)
    """
    return QuadratureRule(n=int(n), error_power=terms["power"], weight_sum=terms["weight_sum"],
                          weight_dev2=terms["dev2"])


def advice_context(adv, *, band: bool = False) -> PredictionContext:
    r"""The :class:`envfit.predict.PredictionContext` of an
    :class:`~envfit.advisor._result.Advice` (its fit rounded as the search used it, τ,
    :math:`\hat P` averaged over channels; ``band``: to H − 1)."""
    P = np.atleast_2d(np.asarray(adv.map_power, dtype=np.float64))
    s = s_value(adv.s)
    return PredictionContext(s=s, sigma=adv.sigma, s_bandlimited=s, sigma_bandlimited=adv.sigma,
                             band_lmax=adv.band_lmax, transfer=adv.lookup_transfer,
                             map_power=P[:, :adv.band_lmax + 1] if band else P,
                             mean_rms=adv.mean_rms)


def _terms_of_row(adv, row, n: int) -> tuple[dict, float]:
    """A quadrature row's terms at N to ``adv.spectral_lmax``, recomputed (no cache), and s'."""
    wf = weight_function(adv.brdf, adv.shininess or DEFAULT_SHININESS)
    seeds = seed_list(row.pointset, adv.settings["seed"], adv.settings["seeds"])
    s = s_value(adv.s)
    lmax = max(adv.band_lmax, int(getattr(adv, "spectral_lmax", 0) or 0))
    return rule_terms(row.pointset, n, wf, s, row.weights, seeds, lmax), s


def row_prediction(adv, row, n: int) -> float:
    """The prediction (b′) of quadrature row ``row`` of :class:`~envfit.advisor._result.Advice`
    ``adv`` at N, recomputed from ``adv``'s fit (no cache; for tests and examples)."""
    t, _ = _terms_of_row(adv, row, n)
    return predict("bandlimited", advice_context(adv), terms_rule(n, t)).rmse


def row_prediction_spectral(adv, row, n: int) -> float:
    r"""The prediction (c) with its tail of quadrature row ``row`` at N, recomputed (no cache)
    from ``adv.map_power`` (:math:`\frac1C\sum_c\hat P_{l,c}`, l = 0…L_tail)."""
    t, _ = _terms_of_row(adv, row, n)
    return predict("spectral", advice_context(adv), terms_rule(n, t)).rmse
