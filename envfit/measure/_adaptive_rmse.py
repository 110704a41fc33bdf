r"""Measuring an estimator's RMSE over random axes with a confidence interval that survives
heavy tails, an adaptive number of axes, and the comparison of a prediction with it.

The RMSE over M axes of :func:`envfit.shading._estimators.rmse_over_axes` is the square root
of a mean of per-axis squared errors,

.. math:: \widehat{\mathrm{RMSE}} = \Big(\frac1M\sum_{m=1}^M d_m\Big)^{1/2}, \qquad
          d_m = \frac1C\sum_{c=1}^C(\tilde I_{mc} - I_{mc})^2 ,

an estimate of :math:`\mathrm{RMSE} = (\mathbb E_a\,d)^{1/2}` over uniform random axes a.
On linear HDR maps with a sun the :math:`d_m` are heavy-tailed (a kurtosis of ≈ 320 has been
seen: the few axes whose lobe catches the sun dominate the mean), so the normal-theory
interval, which treats the errors as Gaussian with one variance
(:math:`M C\,\widehat{\mathrm{RMSE}}^2/\mathrm{RMSE}^2 \sim \chi^2_{MC}`), is far too narrow,
and even the spread of the :math:`d_m` is estimated poorly. The bootstrap resamples the
*axes* — the unit is the per-axis channel mean :math:`d_m`, channels of one axis are not
independent — and reads the interval off the distribution of the resampled statistic
(Efron & Tibshirani 1993):

* **percentile** (ch. 13): :math:`[\hat\theta^*_{(\alpha/2)}, \hat\theta^*_{(1-\alpha/2)}]`,
  the quantiles of B bootstrap replicates :math:`\hat\theta^*_b`;
* **BCa** (bias-corrected and accelerated, ch. 14, §14.3): the quantiles at
  :math:`\alpha_{1,2} = \Phi\big(\hat z_0 + \frac{\hat z_0 + z_{\alpha/2,\,1-\alpha/2}}
  {1 - \hat a(\hat z_0 + z_{\alpha/2,\,1-\alpha/2})}\big)`, with the bias correction
  :math:`\hat z_0 = \Phi^{-1}(\#\{\hat\theta^*_b < \hat\theta\}/B)` and the acceleration
  :math:`\hat a = \sum_i U_i^3 / \big(6(\sum_i U_i^2)^{3/2}\big)` from the jackknife
  influence values :math:`U_i = (M-1)(\bar\theta_{(\cdot)} - \hat\theta_{(i)})`. Second-order
  accurate, and it corrects for the skew that a heavy tail gives the distribution of
  :math:`\widehat{\mathrm{RMSE}}`.

Both are :func:`scipy.stats.bootstrap` (``vectorized=True``, the statistic
:math:`\sqrt{\mathrm{mean}}` over the last axis, an explicit ``numpy.random.Generator``); this
module only chooses the unit, the batches and the degenerate cases. Cost: B·M for the
resamples, plus M·(M − 1) for BCa's jackknife — measured ≈ 0.03 s at M = 500, 0.2 s at 4000,
1 s at 16 000 and ≈ 15 s at 64 000 (B = 2000); use ``method="percentile"`` (0.8 s at 64 000)
for very many axes. Memory is bounded by batches of about :data:`BATCH_ELEMENTS` values.

*Adaptive axes* (:func:`adaptive_rmse`). Each axis is measured exactly once, so measure
sees :math:`M_\mathrm{final}` axes in :math:`1 + \lceil\log_2(M_\mathrm{final}/M_0)\rceil`
calls; since the half-width falls like :math:`M^{-1/2}`,
:math:`M_\mathrm{final} \lesssim 2M_0(h_0/t)^2` for an initial relative half-width
:math:`h_0` and target t (at most twice the axes the target needs). The bootstrap of the
rounds costs about twice the last one (BCa is O(M²), above; ``method="percentile"`` for
huge M). Stopping when the interval is narrow is an optional-stopping rule: the final
interval's coverage can be a little below nominal, most so at the first round; a larger
``axes_start`` reduces that.

* :func:`rmse_interval` — the interval, as :class:`RMSEInterval`.
* :func:`adaptive_rmse` — doubles the axes until the interval is within ±target of the RMSE.
* :func:`agreement_with_interval` — a predicted RMSE against a measured interval.

No bootstrap interval is exact for a finite M: when the tail is so heavy that the sample
rarely contains the axes that dominate the mean (e.g. 1 % of axes with 100× the error and
M = 200: no such axis with probability 13 %), every interval computed from the sample
misses; the bootstrap still covers far more often than the normal-theory interval
(``tests/test_measurement.py`` measures both).

References
----------
B. Efron, R. J. Tibshirani, *An Introduction to the Bootstrap*, Chapman & Hall, 1993
(ch. 12–14; BCa §14.3). SciPy, ``scipy.stats.bootstrap``
(https://docs.scipy.org/doc/scipy/reference/generated/scipy.stats.bootstrap.html).

Example
-------
>>> import numpy as np
>>> rng = np.random.default_rng(1)
>>> truth = np.zeros((400, 3))
>>> est = rng.normal(0.0, 0.5, (400, 3))                       # RMSE 0.5
>>> r = rmse_interval(est, truth, resamples=500)
>>> bool(r.low < 0.5 < r.high), r.axes, r.method
(True, 400, 'bca')
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Callable

import numpy as np

from envfit.base import check_int
from envfit.base import ParameterError
from envfit.shading import rmse_over_axes

__all__ = ["RMSEInterval", "AdaptiveRMSE", "Agreement", "rmse_interval", "adaptive_rmse",
           "agreement_with_interval", "squared_errors_per_axis", "BATCH_ELEMENTS", "METHODS"]

#: bootstrap / jackknife values held at once (batches of about this many float64)
BATCH_ELEMENTS = 1 << 21

#: the interval methods: envfit name → ``scipy.stats.bootstrap`` name
METHODS = {"bca": "BCa", "percentile": "percentile"}


@dataclass(frozen=True)
class RMSEInterval:
    """A bootstrap confidence interval of the RMSE over axes.

    ``rmse`` the point estimate (:func:`envfit.shading._estimators.rmse_over_axes` ``.total``),
    ``[low, high]`` the interval, ``relative_half_width`` = (high − low) / (2·rmse),
    ``axes`` the number M of axes, ``method`` "bca" or "percentile" (the one used: a
    degenerate BCa falls back to the percentile interval of the same replicates),
    ``confidence`` the level.
    """

    rmse: float
    low: float
    high: float
    relative_half_width: float
    axes: int
    method: str
    confidence: float = 0.95

    def contains(self, value: float) -> bool:
        """Whether ``low <= value <= high``."""
        return bool(self.low <= value <= self.high)


@dataclass(frozen=True)
class AdaptiveRMSE:
    """The result of :func:`adaptive_rmse`: the final ``interval``, the ``axes`` measured
    (each once), whether the ``target_met``, the number of ``rounds`` (calls of measure) and
    the axes' ``sampling``: "uniform" or "importance" (drawn from a proposal and weighted)."""

    interval: RMSEInterval
    axes: int
    target_met: bool
    rounds: int
    sampling: str = "uniform"


@dataclass(frozen=True)
class Agreement:
    """A predicted RMSE against a measured interval (:func:`agreement_with_interval`).

    ``ratio`` = predicted / measured RMSE; ``inside`` — the prediction lies in the interval;
    ``within_band`` — \\|ratio − 1\\| ≤ band; ``both`` / ``either`` of the two.
    """

    predicted: float
    measured: float
    ratio: float
    inside: bool
    within_band: bool
    band: float

    @property
    def both(self) -> bool:
        return self.inside and self.within_band

    @property
    def either(self) -> bool:
        return self.inside or self.within_band


def _sqrt_mean(d, axis=-1):
    """The statistic: √(mean of the per-axis squared errors) over ``axis`` (vectorised)."""
    return np.sqrt(np.mean(d, axis=axis))


def squared_errors_per_axis(estimates, truth) -> np.ndarray:
    r"""The bootstrap unit: :math:`d_m = \frac1C\sum_c(\tilde I_{mc} - I_{mc})^2`, (M,).

    Same shapes as :func:`envfit.shading._estimators.rmse_over_axes` without leading axes:
    estimates and truth (M, C), or (M,) for one channel.

    >>> squared_errors_per_axis([[1.0, 3.0], [0.0, 0.0]], [[0.0, 0.0], [0.0, 2.0]]).tolist()
    [5.0, 2.0]
    """
    e = np.asarray(estimates, dtype=np.float64)
    t = np.asarray(truth, dtype=np.float64)
    if e.ndim == 1 and t.ndim == 1:
        e, t = e[:, None], t[:, None]
    rmse_over_axes(e, t)                                # the shape checks, one place
    if e.ndim != 2:
        raise ParameterError(f"estimates must be (M, C) like truth, got {e.shape}")
    d = ((e - t) ** 2).mean(axis=1)
    if not np.all(np.isfinite(d)):
        raise ParameterError("estimates and truth must be finite")
    return d


def _interval_of(d: np.ndarray, confidence: float, resamples: int, seed, method: str) -> RMSEInterval:
    m = d.shape[0]
    rmse = float(_sqrt_mean(d))
    if m < 2:
        raise ParameterError(f"a bootstrap interval needs at least 2 axes, got {m}")
    if np.all(d == d[0]):                               # no spread: every resample is the same
        return RMSEInterval(rmse, rmse, rmse, 0.0, m, method, confidence)
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    batch = max(1, BATCH_ELEMENTS // m)
    kw = dict(statistic=_sqrt_mean, vectorized=True, n_resamples=resamples, batch=batch,
              confidence_level=confidence)
    used = method
    from scipy import stats          # here: scipy.stats costs ~0.8 s to import (advise's cache)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", stats.DegenerateDataWarning)
        res = stats.bootstrap((d,), method=METHODS[method], rng=rng, **kw)
        lo, hi = float(res.confidence_interval.low), float(res.confidence_interval.high)
        if not (np.isfinite(lo) and np.isfinite(hi)):   # BCa undefined (e.g. all θ* on one side)
            used = "percentile"
            res = stats.bootstrap((d,), method="percentile", bootstrap_result=res,
                                  rng=rng, **{**kw, "n_resamples": 0})
            lo, hi = float(res.confidence_interval.low), float(res.confidence_interval.high)
    half = 0.5 * (hi - lo)
    rel = half / rmse if rmse > 0 else (0.0 if half == 0 else float("inf"))
    return RMSEInterval(rmse, lo, hi, float(rel), m, used, confidence)


def _check_options(confidence, resamples, method):
    try:
        conf = float(confidence)
    except (TypeError, ValueError):
        conf = float("nan")
    if not 0.0 < conf < 1.0:
        raise ParameterError(f"confidence must be in (0, 1), got {confidence!r}")
    if method not in METHODS:
        raise ParameterError(f"method must be one of {sorted(METHODS)}, got {method!r}")
    return conf, check_int(resamples, "resamples", 10)


def rmse_interval(estimates, truth, *, confidence: float = 0.95, resamples: int = 2000,
                  seed=0, method: str = "bca") -> RMSEInterval:
    r"""Bootstrap confidence interval of the RMSE over axes, resampling the axes.

    .. math:: \widehat{\mathrm{RMSE}} = \Big(\frac1M\sum_m d_m\Big)^{1/2},\qquad
              d_m = \frac1C\sum_c(\tilde I_{mc}-I_{mc})^2,

    and :math:`[\mathrm{low}, \mathrm{high}]` from B = ``resamples`` replicates
    :math:`\hat\theta^*_b = (\frac1M\sum_m d^*_{m})^{1/2}` of M axes drawn with replacement:
    ``method="bca"`` the BCa interval, ``"percentile"`` the percentile interval
    (Efron & Tibshirani 1993, ch. 13–14; the module docstring), both by
    :func:`scipy.stats.bootstrap` with ``vectorized=True``.

    Parameters
    ----------
    estimates, truth : (M, C) (or (M,)) as :func:`envfit.shading._estimators.rmse_over_axes`;
        M ≥ 2 axes, each an independent draw (the interval assumes i.i.d. axes).
    confidence : the level, in (0, 1).
    resamples : B ≥ 10 (2000 is Efron & Tibshirani's advice for BCa).
    seed : an int / None for ``numpy.random.default_rng(seed)``, or a ``numpy.random.Generator``.
    method : "bca" (default) or "percentile" (:data:`METHODS`).

    Returns an :class:`RMSEInterval`. If every :math:`d_m` is equal (e.g. an exact
    estimator) the interval is the point; if BCa is undefined (a degenerate replicate
    distribution) the percentile interval of the same replicates is returned, with
    ``method="percentile"``.

    Work: B·M, plus M² for BCa (the jackknife), in batches of :data:`BATCH_ELEMENTS`.

    >>> d = np.random.default_rng(0).normal(size=(300, 1))
    >>> r = rmse_interval(d, np.zeros((300, 1)), method="percentile", resamples=400)
    >>> round(r.rmse, 3), bool(r.low < 1.0 < r.high), bool(0.05 < r.relative_half_width < 0.15)
    (1.018, True, True)
    """
    conf, b = _check_options(confidence, resamples, method)
    return _interval_of(squared_errors_per_axis(estimates, truth), conf, b, seed, method)


def _uniform_axes(rng: np.random.Generator, count: int) -> np.ndarray:
    """``count`` i.i.d. uniform unit vectors (normalised Gaussians; a zero draw is redrawn)."""
    v = rng.normal(size=(count, 3))
    n = np.linalg.norm(v, axis=1)
    while np.any(n == 0.0):                             # pragma: no cover - probability 0
        bad = n == 0.0
        v[bad] = rng.normal(size=(int(bad.sum()), 3))
        n = np.linalg.norm(v, axis=1)
    return v / n[:, None]


def adaptive_rmse(measure: Callable, *, axes_start: int = 500, max_axes: int = 64000,
                  target_relative: float = 0.10, confidence: float = 0.95, seed=0,
                  resamples: int = 2000, method: str = "bca", proposal=None) -> AdaptiveRMSE:
    r"""Measure the RMSE over uniform random axes with as many axes as its interval needs.

    ``measure(axes)`` — supplied by the caller — gets an (K, 3) array of unit axes and
    returns ``(estimates, truth)``, each (K, C) (or (K,)), for those axes only — or a (K,)
    array of each axis's squared error (mean over channels; e.g. the mean over several
    randomised estimates of the same axis, the bootstrap then resampling axes).

    Stopping rule: measure :math:`M_0` = ``axes_start`` axes; after each round compute the
    interval (:func:`rmse_interval` on *all* axes measured so far) and stop when
    :math:`(\mathrm{high}-\mathrm{low})/2 \le` ``target_relative`` · RMSE (target met) or
    when M has reached ``max_axes``; otherwise draw :math:`M` *new* axes (doubling M,
    capped at ``max_axes``) and measure only them. The axes are one stream of
    ``numpy.random.default_rng(seed)``, so the first M axes of a run do not depend on when
    it stopped.

    Its cost and the coverage of its final interval: the module docstring, *Adaptive axes*.

    Parameters
    ----------
    measure : callable (K, 3) → (estimates, truth).
    axes_start, max_axes : 2 ≤ axes_start ≤ max_axes.
    target_relative : the relative half-width to reach, > 0.
    confidence, seed, resamples, method : as :func:`rmse_interval` (``seed`` also draws the
        axes; the bootstrap of every round uses a generator from the same seed).
    proposal : None (uniform axes) or an importance density over axes with
        ``draw(rng, K) -> (axes (K, 3), weights (K,))``, the weights :math:`u/q` of the
        uniform density over it (:class:`envfit.measure._axis_proposal.AxisProposal`); the
        bootstrap unit is then :math:`w_m d_m`, whose mean is unbiased for the uniform mean
        (importance sampling), and far less skewed when q follows d.

    Returns an :class:`AdaptiveRMSE` (interval, axes, target_met, rounds).

    >>> def measure(axes):                               # errors with RMS 0.1 per channel
    ...     rng = np.random.default_rng(len(axes))
    ...     return rng.normal(0, 0.1, (len(axes), 3)), np.zeros((len(axes), 3))
    >>> out = adaptive_rmse(measure, axes_start=50, target_relative=0.05, resamples=500)
    >>> out.target_met, out.axes, out.rounds, bool(out.interval.low < 0.1 < out.interval.high)
    (True, 400, 4, True)
    """
    m0, m_max, target, conf, b = _check_adaptive(measure, axes_start, max_axes,
                                                 target_relative, confidence, resamples, method)
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    boot_seed = rng.integers(0, 2 ** 63)                # one bootstrap seed for all rounds
    parts: list[np.ndarray] = []
    have, want, rounds = 0, m0, 0
    while True:
        new, wts = _draw_axes(rng, want - have, proposal)
        d = _measured_errors(measure, new)
        parts.append(d if wts is None else d * wts)
        have, rounds = want, rounds + 1
        interval = _interval_of(np.concatenate(parts), conf, b, int(boot_seed), method)
        met = interval.relative_half_width <= target
        if met or have >= m_max:
            return AdaptiveRMSE(interval, have, bool(met), rounds,
                                "uniform" if proposal is None else "importance")
        want = min(2 * have, m_max)


def _check_adaptive(measure, axes_start, max_axes, target_relative, confidence, resamples,
                    method) -> tuple[int, int, float, float, int]:
    """``(M_0, M_max, target, confidence, B)`` of :func:`adaptive_rmse`, checked
    (ParameterError)."""
    m0 = check_int(axes_start, "axes_start", 2)
    m_max = check_int(max_axes, "max_axes", m0)
    try:
        target = float(target_relative)
    except (TypeError, ValueError):
        target = float("nan")
    if not target > 0.0:
        raise ParameterError(f"target_relative must be > 0, got {target_relative!r}")
    conf, b = _check_options(confidence, resamples, method)
    if not callable(measure):
        raise ParameterError("measure must be a callable axes -> (estimates, truth)")
    return m0, m_max, target, conf, b


def _draw_axes(rng: np.random.Generator, count: int, proposal):
    """``(axes (count, 3), weights (count,) or None)``: uniform axes, or ``proposal``'s."""
    if proposal is None:
        return _uniform_axes(rng, count), None
    return proposal.draw(rng, count)


def _measured_errors(measure: Callable, axes: np.ndarray) -> np.ndarray:
    """:math:`d_m` of the new ``axes``: ``measure(axes)`` as given squared errors per axis
    (a 1-D array) or ``(estimates, truth)`` (:func:`squared_errors_per_axis`)."""
    result = measure(axes)
    if isinstance(result, np.ndarray) and result.ndim == 1:
        d = result                                        # squared errors per axis, given
    else:
        try:
            est, tru = result
        except (TypeError, ValueError):
            raise ParameterError("measure must return (estimates, truth)") from None
        d = squared_errors_per_axis(est, tru)
    if d.shape[0] != axes.shape[0]:
        raise ParameterError(f"measure returned {d.shape[0]} axes for {axes.shape[0]}")
    return d


def agreement_with_interval(predicted: float, interval: RMSEInterval, band: float = 0.2) -> Agreement:
    r"""Does a predicted RMSE agree with a measured one? Two criteria, reported separately.

    ``inside``: :math:`\mathrm{low} \le \hat r \le \mathrm{high}` — the prediction is
    consistent with the measurement's sampling error; ``within_band``:
    :math:`|\hat r/\widehat{\mathrm{RMSE}} - 1| \le` ``band`` — close enough for the
    purpose, whatever the measurement's precision. A wide interval (few axes, heavy tail)
    can make ``inside`` true for a poor prediction, a narrow one make it false for a good
    one; ``both`` / ``either`` combine them.

    >>> iv = RMSEInterval(rmse=1.0, low=0.9, high=1.2, relative_half_width=0.15, axes=500, method="bca")
    >>> a = agreement_with_interval(1.15, iv)
    >>> a.inside, a.within_band, a.both, round(a.ratio, 2)
    (True, True, True, 1.15)
    >>> agreement_with_interval(0.7, iv).either
    False
    """
    if not isinstance(interval, RMSEInterval):
        raise ParameterError(f"interval must be an RMSEInterval, got {type(interval).__name__}")
    try:
        p, bd = float(predicted), float(band)
    except (TypeError, ValueError):
        raise ParameterError("predicted and band must be numbers") from None
    if not (np.isfinite(p) and p >= 0):
        raise ParameterError(f"predicted must be a finite RMSE >= 0, got {predicted!r}")
    if not (np.isfinite(bd) and bd >= 0):
        raise ParameterError(f"band must be finite and >= 0, got {band!r}")
    r = interval.rmse
    ratio = p / r if r > 0 else (1.0 if p == 0 else float("inf"))
    return Agreement(predicted=p, measured=r, ratio=float(ratio), inside=interval.contains(p),
                     within_band=bool(abs(ratio - 1.0) <= bd), band=bd)
