r"""The advisor: how many samples, or which SH/HSH degree, for this map, this BRDF and a target error?

Marques, Bouville, Bouatouch, "Spectral Analysis of Quadrature Rules and Fourier
Truncation-based Methods Applied to Shading Integrals": the worst-case error of a quadrature
rule (Eq. 41) and of an SH/HSH truncation (Eqs. 51–52), turned into an *absolute* predicted
RMS error with the map's fitted smoothness s' and scale σ' (``envfit fit --kernel
bandlimited``), then inverted: the smallest N (or L) whose predicted error is at most the
target.

Prediction (the refined absolute prediction (b') of :mod:`envfit.validate.pipeline`)
-------------------------------------------------------------------------
Under the Gaussian-process reading of the Sobolev model, f − m̄ ~ GP(0, σ² K_gd^(s)) (Eq. 14),
the error of a linear rule at a random axis has mean square :math:`\sigma^2\sum_l a_l e_l`
(:math:`a_l^{(s)}` the kernel's Legendre coefficients, Eqs. 15–16; :math:`e_l` the rule's
squared error on the degree-l harmonics, the bracket of Eq. 42,
:func:`envfit.shading.spectra.rule_error_power`). A lat-long map is not that field, and (b') models
what it is (points (i)–(iv) of the validation's (b')):

* it holds no degree above its Nyquist degree H − 1 (H rows): the sum stops at l = H − 1;
* s' and σ' are fitted under that model — the likelihood of the kernel band-limited at
  H − 1 with the samples at pixel centres (:func:`envfit.fit.smoothness.fit_smoothness` with
  ``kernel="bandlimited"``; for a given s, σ' by
  :func:`envfit.validate.pipeline.bandlimited_profiled_sigma`). The full kernel and bilinear lookups
  read a finite-resolution map as smoother than it is (ŝ ≈ 0.04 high on 256-row GP maps);
* the estimators integrate the map's *bilinear interpolant*, whose power at degree l is the
  pixel field's times :math:`\tau_l` (:func:`envfit.shading.spectra.lookup_transfer` of the map's
  :func:`~envfit.shading.spectra.map_degree_power` over its
  :func:`~envfit.shading.spectra.pixel_degree_power`; 1 at low degrees, ≈ 0.25 at H − 1), so degree
  l is weighted by :math:`\tau_l`. Without it (b') was up to 35 % high for spherical
  Fibonacci at large N, whose error lives near the band limit;

and a rule whose weights do not sum to 1 (OSW) also errs by :math:`\bar m(\sum_j w_j - 1)`
on the map's mean, for every axis:

.. math:: \hat R(N) = \Big(\sigma'^2 E'(N)^2 + (\textstyle\sum_j w_j - 1)^2\,\overline{m^2}\Big)^{1/2},
          \qquad E'^2 = \sum_{l=0}^{H-1} a_l(s')\,\tau_l\,e_l

(:math:`\sigma' = (\frac1C\sum_c\sigma'^2_c)^{1/2}`, :func:`envfit.validate.pipeline.combine_sigma`;
:math:`\overline{m^2}` the mean over channels of the squared solid-angle mean;
``wce_bandlimited`` = E'). On ensembles of GP maps this agrees with the measured RMSE to
≈ 5 %. For the stochastic point sets (random, jitter, bnot) :math:`e_l` and
:math:`(\sum w - 1)^2` are averaged over ``seeds`` realisations per N (the expected error
of the sampler, not of one draw; E'² is linear in :math:`e_l`, so averaging the power is
averaging E'²). OSW weights are those of the kernel at s'. The unrestricted
:math:`\sigma'\,\mathrm{wce}(N)` (Eq. 41 at s', prediction (b) of the validation with the
band-limited fit; it over-predicts by up to 2× for spherical Fibonacci at large N on a map)
is reported beside it at the chosen N but not used for the choice.

Truncation (Eqs. 51–52): :math:`\hat R(L) = \sigma' E'(L)`, the truncation error with the
l-sum stopped at the map's band limit, at s'. SH truncation keeps degrees ≤ L exactly, so
its error is degree l > L of the interpolant, in expectation
:math:`E'^2(L) = \sum_{l=L+1}^{H-1} a_l\,\tau_l\,b_l^2` (Eq. 52 with :math:`e_l = b_l^2`
for l > L, weighted by τ exactly as a rule's). HSH truncation is not diagonal in l
(:math:`b_l - b'_l` non-zero at every l, and the hemispherical projection is not of the
interpolant's SH power), so it keeps ``truncation_error_curve(..., lmax=H-1)`` without τ;
its error lives at low degrees (τ₂₀ ≈ 0.99 on 256-row maps, 0.97 on 128-row ones):
weighting its Eq. 51 terms by τ would lower E by under 1 % for L ≤ 16 on 256-row maps,
3 % on 128-row ones (glossy n = 30, s = 1.2 and 1.5). SH and HSH truncation keep
:math:`b_0` exactly, so there is no mean term. SH truncation at L = H − 1 keeps every degree the map holds: error 0.

Search
------
N: doubling from ``nmin`` until :math:`\hat R(N) \le` target, then bisection between the
last failing and the first passing N (:func:`smallest_n`): at most ~2 log₂(N) evaluations.
:math:`\hat R` is monotone in N for the averaged random sets only in expectation and for
spherical Fibonacci only nearly, so the answer is a *crossing*,
:math:`\hat R(N) \le \text{target} < \hat R(N-1)` (the smallest such N when :math:`\hat R` is
monotone; the tests compare it with a brute-force scan). OSW needs an N×N Cholesky solve per
N and is searched up to ``osw_nmax`` (default 4096); beyond ``nmax`` (or ``osw_nmax``) a row
says that the target is not reached instead of failing. L: the first L of the band-limited
curve at or below the target.

Cost column: N (samples per shading point) for quadrature, (L+1)² coefficients for SH/HSH;
the rows are sorted by it. For the diffuse lobe, HSH truncation is exact from L = 1
(:math:`\tilde b_l = 0` for l ≥ 2, errata): the hemispherical projection *is* the shading
integral, so that row is listed but never recommended.

Cache (:mod:`envfit.advisor.cache`)
----------------------------------
JSON files, so that another target (or another run) on the same map recomputes nothing:

* the fit (keyed by the map's fingerprint, ``up``, scale, s/``fit_n``/seed and
  ``"kernel": "bandlimited"``, so fits of the full kernel are never reused);
* τ (keyed by the map's fingerprint, ``up`` and scale);
* every evaluated point of every curve, keyed by s rounded to 1e-6 (the OSW weights' s),
  BRDF, shininess, point set, weighting, the realisation seeds and the band limit H − 1,
  holds *map-independent* terms: the error power :math:`e_l` (l = 0…H − 1, averaged over the
  realisations), :math:`(\sum w-1)^2`, :math:`\sum w` and, at the chosen N, the plain
  wce². The map's numbers — :math:`a_l(s')\tau_l`, σ', :math:`\overline{m^2}` and the
  target — are applied afresh (:func:`degree_weights`, :func:`band_e2`), so one curve
  serves every map of that size fitted to the same s'. JSON round-trips floats exactly and
  E'² is the same correctly rounded sum (``math.fsum``) of the same products, so a cached
  answer is identical to a fresh one.

``check=True`` measures the RMSE over ``axes`` random axes (:func:`envfit.validate.pipeline.random_axes`,
seeded) at the chosen N/L on the map — the ground truth :func:`envfit.shading.ground_truth.shading_integral`,
the rotated and twisted rule :func:`envfit.validate.pipeline.quadrature_estimates_multi` (averaged in
the mean-square sense over the same realisations as the prediction), SH truncation
:func:`envfit.shading.estimators.sh_truncation_curve` on the full map, and HSH truncation
:func:`envfit.shading.estimators.hsh_truncation_curve` on the map downscaled to
``check_hsh_height`` rows with ``check_hsh_axes`` axes (the HSH projection is a per-axis
quadrature over the hemisphere, ~1000× dearer than an SH one).

Example
-------
>>> import tempfile
>>> from envfit.maps.envmap import EnvMap
>>> from envfit.data_gen.gp import gaussian_process_map
>>> env = EnvMap(gaussian_process_map(1.5, 16, seed=0), name="gp")
>>> adv = advise(env, "diffuse", 0.05, scale="linear", s=1.5, fit_n=200, pointsets=("sf",),
...              weights=("equal",), bases=("sh",), cache_dir=tempfile.mkdtemp())
>>> [(r.method, r.n is not None or r.L is not None) for r in adv.rows]
[('sh', True), ('quadrature', True)]
>>> r = next(r for r in adv.rows if r.method == "quadrature")
>>> bool(r.predicted_rmse <= 0.05), r.n == smallest_n(lambda n: _q_predict(adv, r, n), 0.05, 4, 65536)[0]
(True, True)
"""
from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field
from typing import Callable, Sequence

import numpy as np

from envfit.theory.errors import TheoryParameterError
from envfit.theory.pointsets import DETERMINISTIC_POINTSETS, generate
from envfit.theory.truncation import truncation_error_curve
from envfit.theory.weights import equal_weights, optimal_weights

from envfit.advisor.cache import AdviseCache
from envfit.kernels.bandlimited import max_samples
from envfit.base.checks import check_int, check_names, check_positive
from envfit.maps.envmap import EnvMap
from envfit.base.errors import ParameterError
from envfit.shading.estimators import hsh_truncation_curve, rmse_over_axes, sh_truncation_curve
from envfit.base.progress import progress_bar
from envfit.base.resources import plan_memory
from envfit.maps.scales import SCALES, check_not_constant, fit_scale
from envfit.shading.ground_truth import bilinear_sh_coefficients, shading_integral, weight_function
from envfit.shading.spectra import (band_e2, degree_weights, map_transfer, rule_error_power,  # noqa: F401
                      sh_truncation_curve_transfer)
from envfit.base.store import array_fingerprint
from envfit.fit.sigma import bandlimited_profiled_sigma, combine_sigma, parse_s
from envfit.shading.quadrature import quadrature_estimates_multi, random_axes
from envfit.theory.quadrature import worst_case_error



def fit_smoothness(*args, **kwargs):
    """:func:`envfit.fit.smoothness.fit_smoothness`, imported on first use: numba and the interpolator
    load only when a fit is not cached (a cached ``envfit advise`` stays under 2 s)."""
    from envfit.fit.smoothness import fit_smoothness as _fit_smoothness
    return _fit_smoothness(*args, **kwargs)


__all__ = ["Advice", "AdviceRow", "advise", "smallest_n", "predicted_rmse", "mean_shading_value",
           "map_transfer", "degree_weights", "band_e2", "sh_truncation_curve_transfer",
           "DEFAULT_POINTSETS", "ALL_POINTSETS", "WEIGHTINGS", "BASES", "BRDFS",
           "DEFAULT_FIT_N", "DEFAULT_NMIN", "DEFAULT_NMAX", "DEFAULT_OSW_NMAX", "DEFAULT_SEEDS",
           "plan_advise_memory"]

#: every point set (envfit.theory.pointsets); BNOT costs ≈15 s per realisation at N = 4096
ALL_POINTSETS = ("sf", "sobol", "lp", "bnot", "random", "jitter")
#: the default point sets (BNOT only when asked for)
DEFAULT_POINTSETS = ("sf", "sobol", "lp", "random", "jitter")
WEIGHTINGS = ("equal", "osw")
BASES = ("sh", "hsh")
BRDFS = ("diffuse", "glossy")
DEFAULT_FIT_N = 3000
DEFAULT_NMIN = 4
DEFAULT_NMAX = 65536
#: OSW needs an N×N float64 Cholesky per evaluated N (134 MB, ≈1–3 s at 4096)
DEFAULT_OSW_NMAX = 4096
#: realisations averaged per N for the stochastic point sets
DEFAULT_SEEDS = 4
#: largest L searched for a truncation (also bounded by the band limit H − 1)
LMAX_SEARCH = 512


# ----------------------------------------------------------------------------- results

@dataclass
class AdviceRow:
    """One rule of the table.

    ``method`` is "quadrature" (``pointset``/``weights``, ``n`` samples) or "sh"/"hsh" (degree
    ``L``). ``cost`` = N or (L+1)²; None when the target is not reached (then ``n``/``L`` are
    None and ``predicted_rmse`` is the prediction at the largest N/L searched, ``searched_max``).
    ``predicted_rmse`` is the refined prediction (b') used for the choice (``wce_bandlimited``
    = E', with τ for quadrature and SH), ``predicted_rmse_plain`` σ'·wce (Eq. 41) or σ'·E(L)
    (Eqs. 51–52) without the band limit and τ, at the band-limited fit's s' and σ'.
    ``measured_rmse`` and ``measured_over_predicted`` are filled by ``check=True``.
    """

    method: str
    pointset: str | None = None
    weights: str | None = None
    n: int | None = None
    L: int | None = None
    cost: int | None = None
    predicted_rmse: float | None = None
    predicted_rmse_plain: float | None = None
    wce_bandlimited: float | None = None
    wce: float | None = None
    weight_sum: float | None = None
    realisations: int = 1
    searched_max: int | None = None
    evaluations: int = 0
    recommendable: bool = True
    note: str = ""
    measured_rmse: float | None = None
    measured_over_predicted: float | None = None
    measured_over_target: float | None = None
    check_note: str = ""

    @property
    def reached(self) -> bool:
        return self.cost is not None

    @property
    def label(self) -> str:
        if self.method == "quadrature":
            return f"{self.pointset}/{self.weights}"
        return self.method.upper()

    @property
    def setting(self) -> str:
        if self.method == "quadrature":
            return f"N = {self.n}" if self.n is not None else f"N > {self.searched_max}"
        return f"L = {self.L}" if self.L is not None else f"L > {self.searched_max}"


@dataclass
class Advice:
    """What :func:`advise` found: the map's fit, the target, and the rows sorted by cost.

    ``s``, ``sigma`` are the band-limited fit's s' and σ' (``fit_kernel`` "bandlimited",
    kernel truncated at degree ``fit_band_lmax`` = H − 1, ``fit_samples`` distinct pixel
    centres); ``lookup_transfer`` is τ_l, l = 0…H − 1.
    """

    map: str
    map_size: list[int]
    channels: int
    brdf: str
    shininess: float | None
    scale: str
    scale_description: str
    target_rmse: float
    target_relative: float | None
    mean_shading: float
    s: float
    s_interval: list[float] | None
    sigma: float
    sigma_channels: list[float]
    fit_source: str
    fit_cached: bool
    fit_kernel: str
    fit_band_lmax: int | None
    fit_samples: int | None
    band_lmax: int
    mean_rms: float
    rows: list[AdviceRow]
    recommendation: str
    settings: dict = field(default_factory=dict)
    cache: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    check: dict | None = None
    lookup_transfer: list[float] = field(default_factory=list)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["rows"] = [{**asdict(r), "reached": r.reached, "label": r.label} for r in self.rows]
        return d

    def best(self) -> AdviceRow | None:
        """The recommended row (cheapest reached, recommendable), or None."""
        ok = [r for r in self.rows if r.reached and r.recommendable]
        return ok[0] if ok else None

    def table_lines(self) -> list[str]:
        """The table as text lines (what the CLI prints)."""
        chk = self.check is not None
        head = (f"  {'rule':<14s} {'N / L':>10s} {'cost':>7s} {'predicted':>10s} "
                f"{'sigma*wce':>10s}")
        if chk:
            head += f" {'measured':>10s} {'meas/pred':>9s} {'meas/target':>11s}"
        lines = [head + "  note"]

        def f(v, w=10):
            return f"{'–':>{w}s}" if v is None else f"{v:>{w}.3e}"

        def g(v, w):
            return f"{'–':>{w}s}" if v is None else f"{v:>{w}.2f}"

        for r in self.rows:
            line = (f"  {r.label:<14s} {r.setting:>10s} "
                    f"{('–' if r.cost is None else str(r.cost)):>7s} {f(r.predicted_rmse)} "
                    f"{f(r.predicted_rmse_plain)}")
            if chk:
                line += (f" {f(r.measured_rmse)} {g(r.measured_over_predicted, 9)} "
                         f"{g(r.measured_over_target, 11)}")
            notes = "; ".join(x for x in (r.note, r.check_note) if x)
            lines.append(line + (f"  {notes}" if notes else ""))
        return lines


# ----------------------------------------------------------------------------- pure math

def predicted_rmse(sigma: float, e2_band: float, dev2: float = 0.0, mean_sq: float = 0.0) -> float:
    r"""The refined prediction (b'): :math:`(\sigma'^2 E'^2 + (\sum w-1)^2\overline{m^2})^{1/2}`.

    ``e2_band`` is :math:`E'^2 = \sum_{l\le H-1} a_l\tau_l e_l` (:func:`band_e2`; averaged
    over realisations for stochastic sets), ``dev2`` :math:`(\sum_j w_j - 1)^2` (likewise),
    ``mean_sq`` :math:`\overline{m^2}`.

    >>> round(predicted_rmse(2.0, 0.25, 0.01, 9.0), 12) == round(math.sqrt(4 * 0.25 + 0.01 * 9), 12)
    True
    """
    return math.sqrt(max(sigma * sigma * e2_band + dev2 * mean_sq, 0.0))


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


def mean_shading_value(scaled: EnvMap) -> float:
    r"""Mean over all axes of the normalised shading integral (Eq. 17), averaged over channels.

    By Funk–Hecke, :math:`I(a) = \sum_l \lambda_l\sum_m f_{lm}Y_{lm}(a)`, and only l = 0
    survives the mean over the sphere of axes: :math:`\bar I = \lambda_0 f_{00}Y_{00} =
    f_{00}/\sqrt{4\pi}` (:math:`\lambda_0 = 1` since I ≡ 1 for f ≡ 1) — the solid-angle mean of
    the map's bilinear interpolant, the same for every normalised lobe. From the exact
    :math:`f_{00}` of :func:`envfit.shading.ground_truth.bilinear_sh_coefficients`.

    >>> round(mean_shading_value(EnvMap(np.full((4, 8, 2), 3.0))), 9)
    3.0
    """
    alm = bilinear_sh_coefficients(scaled, 0)
    return float(np.mean(alm[:, 0].real) / math.sqrt(4.0 * math.pi))


def _s_key(s: float) -> float:
    return round(float(s), 6)


def _seed_list(pointset: str, seed: int, k: int) -> list[int]:
    """Realisation seeds of a stochastic point set ([] for a deterministic one)."""
    if pointset in DETERMINISTIC_POINTSETS:
        return []
    return [int(np.random.SeedSequence([int(seed), 41, j]).generate_state(1)[0]) for j in range(k)]


def _rule(pointset: str, n: int, wf, s: float, weights: str, seed) -> tuple[np.ndarray, np.ndarray]:
    pts = generate(pointset, n, seed=0 if seed is None else seed, morph=wf.morph)
    w = equal_weights(n) if weights == "equal" else optimal_weights(pts, wf, s)
    return pts, w


def rule_terms(pointset: str, n: int, wf, s: float, weights: str, seeds: Sequence[int],
               band_lmax: int) -> dict:
    r"""The map-independent terms of a rule, averaged over the realisations ``seeds``
    ([] = the deterministic set once): ``power`` the error power :math:`e_l`, l = 0…band_lmax
    (:func:`envfit.shading.spectra.rule_error_power`, a list), ``dev2`` :math:`(\sum w-1)^2` and
    ``weight_sum``. ``s`` only sets the OSW weights. :math:`E'^2` is
    ``band_e2(power, degree_weights(s', band_lmax, tau))``."""
    pw, dev2, ws = [], [], []
    for sd in (seeds or [None]):
        pts, w = _rule(pointset, n, wf, s, weights, sd)
        pw.append(rule_error_power(pts, w, wf, band_lmax))
        wsum = math.fsum(w)
        dev2.append((wsum - 1.0) ** 2)
        ws.append(wsum)
    power = pw[0] if len(pw) == 1 else np.mean(np.stack(pw), axis=0)
    return {"power": [float(x) for x in power], "dev2": float(np.mean(dev2)),
            "weight_sum": float(np.mean(ws))}


def rule_plain_wce2(pointset: str, n: int, wf, s: float, weights: str, seeds: Sequence[int],
                    workers: int = 2) -> float:
    """Unrestricted squared worst-case error (Eq. 41), averaged over the realisations."""
    out = []
    for sd in (seeds or [None]):
        pts, w = _rule(pointset, n, wf, s, weights, sd)
        out.append(worst_case_error(pts, w, wf, s, workers=workers) ** 2)
    return float(np.mean(out))


def _q_predict(adv: Advice, row: AdviceRow, n: int) -> float:
    """The prediction of ``row``'s rule at N, recomputed (no cache; for tests and examples)."""
    wf = weight_function(adv.brdf, adv.shininess or 30.0)
    seeds = _seed_list(row.pointset, adv.settings["seed"], adv.settings["seeds"])
    s = _s_key(adv.s)
    t = rule_terms(row.pointset, n, wf, s, row.weights, seeds, adv.band_lmax)
    e2 = band_e2(t["power"], degree_weights(s, adv.band_lmax, adv.lookup_transfer))
    return predicted_rmse(adv.sigma, e2, t["dev2"], adv.mean_rms ** 2)


# ----------------------------------------------------------------------------- the advisor

#: bytes per point of a quadrature rule while its error power is computed (points, square
#: points, weights, the SH synthesis' angles and temporaries)
_RULE_BYTES_PER_POINT = 8 * 24


def plan_advise_memory(envmap: EnvMap, *, pointsets: Sequence[str], weights: Sequence[str],
                       nmin: int, nmax: int, osw_nmax: int, fit_n: int, check: bool = False,
                       workers: int = 2) -> None:
    """The advisor's memory guard (:func:`envfit.base.resources.plan_memory`), before any point
    is made: the equal-weight search up to ``nmax`` (O(N): points, weights, error-power
    temporaries, and with ``check`` the lookup blocks), the OSW search up to
    ``min(nmax, osw_nmax)`` (an N x N solve per N) and the band-limited fit (``fit_n``
    capped at half the map's H² degrees of freedom)."""
    c = envmap.channels
    fixed = 8 * envmap.width * envmap.height * (c + 4)
    per_point = _RULE_BYTES_PER_POINT + (8 * (8 + 2 * c) * max(1, int(workers)) if check else 0)
    if pointsets and "equal" in weights:
        plan_memory(nmax, "advise's quadrature search (equal weights)", channels=c,
                    kernel=False, per_n_bytes=per_point, fixed_bytes=fixed, n_name="nmax",
                    smallest=nmin)
    if pointsets and "osw" in weights:
        plan_memory(max(nmin, min(nmax, osw_nmax)), "advise's OSW search (an NxN solve per N)",
                    channels=c, per_n_bytes=per_point, fixed_bytes=fixed, n_name="osw_nmax",
                    smallest=nmin)
    n_fit = min(int(fit_n), max(10, max_samples(envmap.height - 1)))
    plan_memory(n_fit, "advise's band-limited fit", channels=c, fixed_bytes=fixed,
                n_name="fit_n", smallest=10)


def advise(envmap: EnvMap, brdf: str = "diffuse", target_rmse: float | None = None, *,
           target_relative: float | None = None, shininess: float = 30.0,
           scale: str = "display", pointsets: Sequence[str] = DEFAULT_POINTSETS,
           weights: Sequence[str] = WEIGHTINGS, bases: Sequence[str] = BASES,
           s: float | str = "auto", fit_n: int = DEFAULT_FIT_N, seed: int = 0,
           nmin: int = DEFAULT_NMIN, nmax: int = DEFAULT_NMAX, osw_nmax: int = DEFAULT_OSW_NMAX,
           seeds: int = DEFAULT_SEEDS, check: bool = False, axes: int = 1000,
           check_hsh_height: int = 128, check_hsh_axes: int = 200, cache: bool = True,
           cache_dir=None, workers: int = 2, quiet: bool = True) -> Advice:
    """Smallest N per point set and weighting, and smallest SH/HSH degree L, whose predicted
    RMS shading error on ``envmap`` is at most the target (see the module docstring).

    Parameters
    ----------
    envmap : the map on its raw (linear) values; ``scale`` is applied here.
    brdf, shininess : "diffuse" or "glossy" (lobe exponent n = ``shininess``).
    target_rmse : the target RMS error, on the ``scale`` values; or ``target_relative``: the
        target as a fraction (0 < t < 1) of the map's mean shading value
        (:func:`mean_shading_value`). Exactly one of the two.
    scale : "display" (default, as the rest of the CLI), "linear" or "log".
    pointsets, weights : the quadrature rules (``ALL_POINTSETS``; "equal", "osw").
    bases : truncations, "sh" and/or "hsh" (empty: none).
    s : "auto" (fit s' and σ' by the likelihood of the kernel band-limited at H − 1 from
        ``fit_n`` samples moved to pixel centres) or a value in (1, 2) (σ' by the band-limited
        profiled likelihood at that s).
    seed : seed of the fit, of the realisations of stochastic point sets (``seeds`` of them
        averaged per N) and of the check's axes.
    nmin, nmax, osw_nmax : the N range searched (OSW up to ``min(nmax, osw_nmax)``).
    check : measure the RMSE at the chosen N/L over ``axes`` random axes (HSH: on
        ``check_hsh_height`` rows with ``check_hsh_axes`` axes).
    cache, cache_dir : the on-disk cache (:mod:`envfit.advisor.cache`; default folder
        ``$ENVFIT_CACHE_DIR`` or ``~/.cache/envfit``).

    Returns an :class:`Advice`. Bad input raises :class:`envfit.base.errors.ParameterError` (a map
    constant on ``scale`` too: there is nothing to fit); a search or fit that cannot fit in
    memory raises :class:`envfit.base.errors.MemoryBudgetError` before any point is made
    (:func:`plan_advise_memory`, naming the largest ``nmax``/``osw_nmax`` that fits).
    """
    t_start = time.perf_counter()
    # ---- input
    if not isinstance(envmap, EnvMap):
        raise ParameterError(f"envmap must be an EnvMap, got {type(envmap).__name__}")
    brdf_name = check_names([brdf], BRDFS, "BRDF")[0]
    shin = check_positive(shininess, "shininess") if brdf_name == "glossy" else None
    wf = weight_function(brdf_name, shin if shin is not None else 30.0)
    if (target_rmse is None) == (target_relative is None):
        raise ParameterError("give exactly one of target_rmse (--target-rmse) and "
                             "target_relative (--target-relative)")
    if target_relative is not None:
        rel = check_positive(target_relative, "the relative target (--target-relative)")
        if rel >= 1.0:
            raise ParameterError(f"the relative target (--target-relative) is a fraction of the "
                                 f"mean shading value and must be < 1, got {target_relative!r}")
    else:
        rel = None
        target_rmse = check_positive(target_rmse, "the target RMSE (--target-rmse)")
    if scale not in SCALES:
        raise ParameterError(f"scale must be one of {', '.join(SCALES)}, got {scale!r}")
    pointsets = check_names(pointsets, ALL_POINTSETS, "point set")
    weights = check_names(weights, WEIGHTINGS, "weighting")
    bases = check_names(bases, BASES, "basis")
    if not pointsets and not bases:
        raise ParameterError("nothing to advise on: no point set and no SH/HSH basis")
    if pointsets and not weights:
        raise ParameterError("give at least one weighting (equal, osw)")
    s_in = parse_s(s)
    fit_n = check_int(fit_n, "fit_n", 10)
    seed = check_int(seed, "seed", 0)
    nmin = check_int(nmin, "nmin", 1)
    nmax = check_int(nmax, "nmax", nmin)
    osw_nmax = check_int(osw_nmax, "osw_nmax", 1)
    seeds = check_int(seeds, "seeds", 1)
    axes = check_int(axes, "axes", 2)
    check_hsh_height = check_int(check_hsh_height, "check_hsh_height", 4)
    check_hsh_axes = check_int(check_hsh_axes, "check_hsh_axes", 2)
    if envmap.height < 4:
        raise ParameterError(f"the map needs at least 4 rows, got {envmap.height}")
    # the memory guard, before any point set or sample is made
    plan_advise_memory(envmap, pointsets=pointsets, weights=weights, nmin=nmin, nmax=nmax,
                       osw_nmax=osw_nmax, fit_n=fit_n, check=check, workers=workers)
    store = AdviseCache(cache_dir, enabled=cache)

    # ---- the map on its scale
    sc = fit_scale(scale, envmap)
    scaled = envmap.with_data(np.asarray(sc.apply(envmap.data), dtype=np.float64))
    check_not_constant(scaled.data, scale, envmap.name)
    band_lmax = scaled.height - 1
    mean_rms = float(np.sqrt(np.mean(scaled.mean() ** 2)))
    mean_shading = mean_shading_value(scaled)
    notes = list(envmap.notes)
    if rel is not None:
        if not mean_shading > 0:
            raise ParameterError(f"the map's mean shading value on the {scale} scale is "
                                 f"{mean_shading:.3g}, not positive: give --target-rmse instead")
        target = rel * mean_shading
    else:
        target = float(target_rmse)

    # ---- s' and sigma' of the band-limited model (cached)
    t0 = time.perf_counter()
    map_key = {"fingerprint": array_fingerprint(envmap.data), "shape": list(envmap.data.shape),
               "up": envmap.up, "scale": scale}
    fit_key = {**map_key, "s": s_in, "method": "likelihood", "kernel": "bandlimited",
               "n": fit_n, "seed": seed}
    fit = store.load("fit", fit_key)
    fit_cached = fit is not None
    if fit is None:
        if s_in == "auto":
            res = fit_smoothness(envmap, method="likelihood", n=fit_n, scale=scale, seed=seed,
                                 kernel="bandlimited", quiet=quiet)
            fit = {"s": float(res.s), "s_interval": [float(x) for x in res.s_interval],
                   "sigma_channels": [float(x) for x in res.sigma], "source": "fit",
                   "kernel": "bandlimited", "band_lmax": int(res.band_lmax),
                   "samples": int(res.n), "notes": list(res.notes)}
        else:
            sig, used = bandlimited_profiled_sigma(scaled, float(s_in), n=fit_n, seed=seed)
            fit = {"s": float(s_in), "s_interval": None, "sigma_channels": sig.tolist(),
                   "source": "given", "kernel": "bandlimited", "band_lmax": band_lmax,
                   "samples": int(used), "notes": []}
        fit["seconds"] = time.perf_counter() - t0
        store.save("fit", fit_key, fit)
    t_fit = time.perf_counter() - t0
    notes.extend(fit.get("notes", []))
    s_fit = float(fit["s"])
    s_use = _s_key(s_fit)
    sigma_ch = [float(x) for x in fit["sigma_channels"]]
    sigma = combine_sigma(sigma_ch)
    if not sigma > 0:
        raise ParameterError("the map is constant on this scale (sigma = 0): every rule is exact")

    # ---- tau_l of the bilinear lookup (cached per map and scale)
    t0 = time.perf_counter()
    tr = store.load("transfer", {**map_key, "band_lmax": band_lmax})
    if tr is None or len(tr.get("tau", [])) != band_lmax + 1:
        tr = {"tau": [float(x) for x in map_transfer(scaled)]}
        store.save("transfer", {**map_key, "band_lmax": band_lmax}, tr)
    tau = np.asarray(tr["tau"], dtype=np.float64)
    dw = degree_weights(s_use, band_lmax, tau)          # a_l(s') tau_l, l = 0..H-1
    t_transfer = time.perf_counter() - t0

    # ---- search
    t1 = time.perf_counter()
    rows: list[AdviceRow] = []
    jobs = [("quadrature", ps, w) for ps in pointsets for w in weights] + \
           [(b, None, None) for b in bases]
    bar = progress_bar(len(jobs), desc="advise", quiet=quiet, unit="rule")
    try:
        for method, ps, w in jobs:
            if hasattr(bar, "set_postfix_str"):
                bar.set_postfix_str(f"{ps}/{w}" if ps else method)
            if method == "quadrature":
                rows.append(_search_quadrature(ps, w, wf, brdf_name, shin, s_use, sigma,
                                               mean_rms, target, band_lmax, dw, seed, seeds,
                                               nmin, nmax, osw_nmax, store, workers))
            else:
                rows.append(_search_truncation(method, wf, brdf_name, s_use, sigma, target,
                                               band_lmax, tau))
            bar.update(1)
    finally:
        bar.close()
    t_search = time.perf_counter() - t1
    rows.sort(key=lambda r: (r.cost is None, r.cost if r.cost is not None else 0,
                             r.predicted_rmse if r.predicted_rmse is not None else math.inf,
                             r.label))

    adv = Advice(
        map=envmap.name, map_size=[envmap.width, envmap.height], channels=envmap.channels,
        brdf=brdf_name, shininess=shin, scale=scale, scale_description=sc.describe(),
        target_rmse=target, target_relative=rel, mean_shading=mean_shading, s=s_fit,
        s_interval=fit.get("s_interval"), sigma=sigma, sigma_channels=sigma_ch,
        fit_source=fit["source"], fit_cached=fit_cached,
        fit_kernel=fit.get("kernel", "bandlimited"), fit_band_lmax=fit.get("band_lmax"),
        fit_samples=fit.get("samples"),
        band_lmax=band_lmax, mean_rms=mean_rms, rows=rows, recommendation="",
        settings={"pointsets": pointsets, "weights": weights, "bases": bases, "s": s_in,
                  "fit_n": fit_n, "seed": seed, "nmin": nmin, "nmax": nmax,
                  "osw_nmax": osw_nmax, "seeds": seeds, "s_rounded": s_use},
        notes=notes, lookup_transfer=[float(x) for x in tau])
    adv.recommendation = _recommendation(adv)

    t_check = 0.0
    if check:
        t2 = time.perf_counter()
        adv.check = _check(adv, scaled, wf, brdf_name, shin, axes, check_hsh_height,
                           check_hsh_axes, workers, quiet)
        t_check = time.perf_counter() - t2
    adv.notes.extend(store.notes)
    adv.cache = {"enabled": store.enabled, "folder": str(store.folder), "hits": store.hits,
                 "misses": store.misses, "writes": store.writes}
    adv.timings = {"fit": t_fit, "transfer": t_transfer, "search": t_search, "check": t_check,
                   "total": time.perf_counter() - t_start}
    return adv


def _search_quadrature(ps, w, wf, brdf, shin, s, sigma, mean_rms, target, band_lmax, dw, seed,
                       k_seeds, nmin, nmax, osw_nmax, store: AdviseCache, workers) -> AdviceRow:
    """Smallest N of one rule; ``dw`` = a_l(s') tau_l (:func:`degree_weights`). The curve's
    cached points hold the map-independent :func:`rule_terms` (and ``e2_plain``)."""
    sds = _seed_list(ps, seed, k_seeds)
    key = {"s": s, "brdf": brdf, "shininess": shin, "pointset": ps, "weights": w,
           "seeds": sds, "band_lmax": band_lmax}
    curve = store.load_curve(key)
    new: dict[int, dict] = {}
    upper = nmax if w == "equal" else max(nmin, min(nmax, osw_nmax))
    mean_sq = mean_rms * mean_rms
    evaluations = 0

    def terms(n: int) -> dict:
        nonlocal evaluations
        t = curve.get(n)
        if t is None or len(t.get("power", ())) != band_lmax + 1:
            t = {**(t or {}), **rule_terms(ps, n, wf, s, w, sds, band_lmax)}
            curve[n] = new[n] = t
            evaluations += 1
        return t

    def predict(n: int) -> float:
        t = terms(n)
        return predicted_rmse(sigma, band_e2(t["power"], dw), t["dev2"], mean_sq)

    row = AdviceRow(method="quadrature", pointset=ps, weights=w, realisations=max(1, len(sds)),
                    searched_max=upper)
    try:
        n, seen = smallest_n(predict, target, nmin, upper)
    except (TheoryParameterError, ParameterError) as exc:
        store.merge_curve(key, new)
        row.note = f"failed: {exc}"
        row.recommendable = False
        return row
    if n is None:
        t = curve[upper]
        row.predicted_rmse = seen[upper]
        row.wce_bandlimited = math.sqrt(band_e2(t["power"], dw))
        row.weight_sum = t["weight_sum"]
        why = " (OSW: an NxN solve per N; raise --osw-nmax)" if w == "osw" and upper < nmax else ""
        row.note = f"target not reached for N <= {upper}{why}"
        row.recommendable = False
    else:
        t = curve[n]
        if "e2_plain" not in t:
            t = {**t, "e2_plain": rule_plain_wce2(ps, n, wf, s, w, sds, workers)}
            curve[n] = new[n] = t
        row.n = row.cost = n
        row.predicted_rmse = seen[n]
        row.wce_bandlimited = math.sqrt(band_e2(t["power"], dw))
        row.wce = math.sqrt(t["e2_plain"])
        row.predicted_rmse_plain = sigma * row.wce
        row.weight_sum = t["weight_sum"]
    row.evaluations = evaluations
    if len(sds) > 1:
        row.note = (row.note + "; " if row.note else "") + f"mean over {len(sds)} realisations"
    store.merge_curve(key, new)
    return row


def _search_truncation(basis, wf, brdf, s, sigma, target, band_lmax, tau) -> AdviceRow:
    """Smallest L: SH by :func:`sh_truncation_curve_transfer` (with τ), HSH by
    ``truncation_error_curve(..., lmax=H-1)`` (no τ; see the module docstring)."""
    row = AdviceRow(method=basis)
    top = min(band_lmax - 1, LMAX_SEARCH)
    Lmax = min(32, top)
    while True:
        if basis == "sh":
            E = sh_truncation_curve_transfer(wf, s, Lmax, band_lmax, tau)
        else:
            E = truncation_error_curve(wf, s, Lmax, basis, lmax=band_lmax)
        ok = np.nonzero(sigma * E <= target)[0]
        if ok.size or Lmax >= top:
            break
        Lmax = min(2 * Lmax, top)
    if ok.size:
        L = int(ok[0])
        eb = float(E[L])
    elif basis == "sh" and band_lmax - 1 <= LMAX_SEARCH:
        L, eb = band_lmax, 0.0                # every degree the map holds is kept: exact
    else:
        L = None
        eb = float(E[-1])
    row.searched_max = Lmax if L is None else None
    row.wce_bandlimited = eb
    row.predicted_rmse = sigma * eb
    if L is not None:
        row.L = L
        row.cost = (L + 1) ** 2
        plain = float(truncation_error_curve(wf, s, L, basis)[L])
        row.wce = plain
        row.predicted_rmse_plain = sigma * plain
    else:
        row.note = f"target not reached for L <= {Lmax}"
        row.recommendable = False
    if basis == "hsh" and brdf == "diffuse":
        row.recommendable = False
        row.note = (row.note + "; " if row.note else "") + \
            "diffuse HSH is exact from L = 1 (the projection is the integral): not recommended"
    return row


def _recommendation(adv: Advice) -> str:
    best = adv.best()
    if best is None:
        return (f"no rule reaches the target RMSE {adv.target_rmse:.3g} in the searched range: "
                f"raise --nmax / --osw-nmax or relax the target")
    what = {"quadrature": f"{best.label} (point set / weights) with N = {best.n} samples per "
                          f"shading point",
            "sh": f"SH truncation at L = {best.L} ({best.cost} coefficients)",
            "hsh": f"HSH truncation at L = {best.L} ({best.cost} coefficients)"}[best.method]
    text = (f"recommendation: {what} (predicted RMSE {best.predicted_rmse:.3g} <= target "
            f"{adv.target_rmse:.3g})")
    if best.method != "quadrature":
        q = next((r for r in adv.rows if r.method == "quadrature" and r.reached
                  and r.recommendable), None)
        if q is not None:
            text += f"; by sampling: {q.pointset}/{q.weights} N = {q.n}"
    return text


# ----------------------------------------------------------------------------- --check

def _check(adv: Advice, scaled: EnvMap, wf, brdf, shin, n_axes, hsh_height, hsh_axes,
           workers, quiet) -> dict:
    """Measured RMSE at each row's chosen N/L (see the module docstring)."""
    seed = adv.settings["seed"]
    s = adv.settings["s_rounded"]
    sh_ = shin if shin is not None else 30.0
    A = random_axes(n_axes, [seed, 31])
    truth = shading_integral(scaled, A, brdf, sh_)
    hsh_env = hsh_A = hsh_truth = None
    todo = [r for r in adv.rows if r.reached]
    bar = progress_bar(len(todo), desc="advise: check", quiet=quiet, unit="rule")
    try:
        for r in todo:
            if r.method == "quadrature":
                sds = _seed_list(r.pointset, seed, adv.settings["seeds"]) or [None]
                ms = []
                for k, sd in enumerate(sds):
                    pts, w = _rule(r.pointset, r.n, wf, s, r.weights, sd)
                    est = quadrature_estimates_multi(scaled, A, pts, [w], seed=[seed, 32, k],
                                                     workers=workers)[0]
                    ms.append(float(rmse_over_axes(est, truth).total) ** 2)
                r.measured_rmse = math.sqrt(float(np.mean(ms)))
                if len(sds) > 1:
                    r.check_note = f"RMS over the {len(sds)} realisations"
            elif r.method == "sh":
                est = sh_truncation_curve(scaled, A, brdf, [r.L], shininess=sh_)[0]
                r.measured_rmse = float(rmse_over_axes(est, truth).total)
            else:
                if hsh_env is None:
                    hsh_env = scaled.resized(min(hsh_height, scaled.height))
                    hsh_A = A[:min(hsh_axes, A.shape[0])]
                    hsh_truth = shading_integral(hsh_env, hsh_A, brdf, sh_)
                est = hsh_truncation_curve(hsh_env, hsh_A, brdf, [r.L], shininess=sh_)[0]
                r.measured_rmse = float(rmse_over_axes(est, hsh_truth).total)
                if hsh_env.height < scaled.height or hsh_A.shape[0] < A.shape[0]:
                    r.check_note = (f"measured on {hsh_env.height} rows, {hsh_A.shape[0]} axes")
            if r.predicted_rmse:
                r.measured_over_predicted = r.measured_rmse / r.predicted_rmse
            r.measured_over_target = r.measured_rmse / adv.target_rmse
            bar.update(1)
    finally:
        bar.close()
    ratios = [r.measured_over_predicted for r in todo if r.measured_over_predicted is not None
              and r.recommendable]
    summary = {"axes": int(n_axes), "hsh_height": None if hsh_env is None else hsh_env.height,
               "hsh_axes": None if hsh_A is None else int(hsh_A.shape[0])}
    if ratios:
        summary.update({"median_measured_over_predicted": float(np.median(ratios)),
                        "min_measured_over_predicted": float(np.min(ratios)),
                        "max_measured_over_predicted": float(np.max(ratios))})
    best = adv.best()
    if best is not None and best.measured_rmse is not None:
        summary["recommended_measured_rmse"] = best.measured_rmse
        summary["recommended_measured_over_target"] = best.measured_over_target
    return summary
