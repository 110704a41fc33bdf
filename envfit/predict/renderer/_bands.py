r"""The view-angle bands of a microfacet prediction: each band's RMSE, its share of the
sphere's weight, and a bootstrap interval over the frames behind it (issue 38).

A band's MSE is the weighted mean of its frames' MSE, :math:`\hat M_b = \sum_{i\in b} w_i
m_i / \sum_{i\in b} w_i`; the whole sphere's is :math:`\sum_b W_b \hat M_b` with :math:`W_b =
\sum_{i\in b} w_i` (the weights summing to 1): the frame-weighted combination of the strata
:data:`STRATA` (the reported :data:`BANDS` and 80–90°). The frames are a sample (drawn from a
pool, :meth:`MicrofacetModel._select`), so each value carries a sampling error; its interval
is a percentile bootstrap over the frames — each stratum's frames resampled with replacement,
:data:`~envfit.defaults.BAND_BOOTSTRAP_RESAMPLES` times from a seeded
:class:`numpy.random.Generator` — with the *expanded* tail probability of Hesterberg
("What teachers should know about the bootstrap", Am. Stat. 69(4), 2015, Sec. 4.2):
:math:`\alpha'/2 = \Phi(-\sqrt{K/(K-1)}\;t_{K-1,\,1-\alpha/2})`, which corrects the plain
percentile interval's narrowness at small K (K the fewest frames in a resampled stratum).
Below :data:`~envfit.defaults.BAND_MIN_FRAMES` frames there is no interval (None): a band
then has too few frames to say how far off it may be, and the whole sphere's interval needs
every stratum to have that many. Heavy-tailed frames (a sun caught by a sharp lobe in a few
frames) still cover less than the nominal 95 %.

>>> import numpy as np
>>> theta = np.array([10.0, 20.0, 40.0, 70.0])
>>> s = band_spread(theta, np.full(4, 0.25), np.array([[1.0], [3.0], [2.0], [2.0]]))
>>> round(s["all"]["rmse"] ** 2, 12), round(s["0-30"]["rmse"] ** 2, 12), s["0-30"]["weight"]
(2.0, 2.0, 0.5)
>>> s["0-30"]["frames"], s["0-30"]["interval"]
(2, None)
"""
from __future__ import annotations

import numpy as np

from envfit.defaults import BAND_BOOTSTRAP_RESAMPLES, BAND_BOOTSTRAP_SEED, BAND_MIN_FRAMES

__all__ = ["BANDS", "STRATA", "band_key", "in_stratum", "band_spread", "bootstrap_interval",
           "expanded_tail"]

#: the view-angle bands θ_o (degrees) reported beside the whole-sphere value (issue 25)
BANDS = ((0.0, 30.0), (30.0, 60.0), (60.0, 80.0))
#: the strata of the frames: the bands and the rest to the horizon (the whole sphere is their
#: weighted combination)
STRATA = BANDS + ((80.0, 90.0),)


def band_key(lo: float, hi: float) -> str:
    """A band's name, ``"0-30"``."""
    return f"{lo:g}-{hi:g}"


def in_stratum(theta: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """The frames of the stratum [lo, hi) (the last stratum takes every θ_o ≥ its lo)."""
    theta = np.asarray(theta, dtype=np.float64)
    top = np.inf if (lo, hi) == STRATA[-1] else hi
    return (theta >= lo) & (theta < top)


def expanded_tail(k: int, level: float = 0.95) -> float:
    """The expanded percentile bootstrap's lower tail probability for K frames (module
    docstring): below (1 − level)/2, the more so the fewer frames.

    >>> round(expanded_tail(8), 4), round(expanded_tail(10 ** 6), 4)
    (0.0057, 0.025)
    """
    from scipy import stats  # local: scipy.stats costs ~0.4 s to import, a cached answer ~0.3 s

    a = (1.0 - level) / 2.0
    return float(stats.norm.cdf(-np.sqrt(k / (k - 1.0)) * stats.t.ppf(1.0 - a, k - 1)))


def bootstrap_interval(strata, *, level: float = 0.95,
                       resamples: int = BAND_BOOTSTRAP_RESAMPLES,
                       seed: int = BAND_BOOTSTRAP_SEED, min_frames: int = BAND_MIN_FRAMES):
    r"""The bootstrap interval of :math:`\sqrt{\sum_s W_s \hat M_s / \sum_s W_s}` over
    ``strata``, a list of (weights, values) — each stratum's frames resampled on their own,
    its weight :math:`W_s` fixed: ``(low, high, relative standard deviation)``, or None when a
    stratum has fewer than ``min_frames`` frames of positive weight (module docstring).

    >>> rng = np.random.default_rng(1)
    >>> lo, hi, sd = bootstrap_interval([(np.ones(40), rng.gamma(2.0, 0.5, 40))])
    >>> bool(lo < 1.0 < hi), bootstrap_interval([(np.ones(2), np.ones(2))])
    (True, None)
    """
    parts = []
    for w, m in strata:
        w, m = np.asarray(w, np.float64), np.asarray(m, np.float64)
        keep = w > 0
        parts.append((w[keep], m[keep]))
    if not parts or min(len(w) for w, _ in parts) < max(2, min_frames):
        return None
    rng = np.random.default_rng(seed)
    total = sum(float(w.sum()) for w, _ in parts)
    point, boot = 0.0, np.zeros(resamples)
    for w, m in parts:
        idx = rng.integers(0, len(w), size=(resamples, len(w)))
        boot += w.sum() * (w[idx] * m[idx]).sum(axis=1) / w[idx].sum(axis=1)
        point += float(w @ m)
    rmse = np.sqrt(np.clip(boot / total, 0.0, None))
    tail = expanded_tail(min(len(w) for w, _ in parts), level)
    lo, hi = np.quantile(rmse, [tail, 1.0 - tail])
    centre = np.sqrt(max(point / total, 0.0))
    return float(lo), float(hi), float(rmse.std() / centre) if centre > 0 else 0.0


def band_spread(theta, weights, mse_k) -> dict:
    """Per stratum of :data:`STRATA` (``"0-30"``, …, ``"80-90"``) and ``"all"``: ``frames``
    (in it), ``weight`` (its share of the frames' weight), ``rmse`` (the weighted mean of its
    frames' MSE (K, C), clipped at 0 per channel, averaged over the channels, square root),
    ``interval`` ([low, high], the 95 % bootstrap interval of that RMSE; None below
    :data:`~envfit.defaults.BAND_MIN_FRAMES` frames) and ``rel_se`` (the bootstrap's relative
    standard deviation; None likewise). A stratum without frames is absent."""
    w = np.asarray(weights, np.float64)
    w = w / w.sum()
    mse_k = np.asarray(mse_k, np.float64).reshape(len(w), -1)
    m = mse_k.mean(axis=1)
    out, strata = {}, []
    for lo, hi in STRATA:
        inside = in_stratum(theta, lo, hi)
        if not np.any(inside & (w > 0)):
            continue
        strata.append((w[inside], m[inside]))
        out[band_key(lo, hi)] = _entry(w[inside], mse_k[inside], [strata[-1]])
    out["all"] = _entry(w, mse_k, strata)
    return out


def _entry(w, mse_k, strata) -> dict:
    mean = np.clip(w @ mse_k / w.sum(), 0.0, None)
    iv = bootstrap_interval(strata)
    return {"frames": int(len(w)), "weight": float(w.sum()),
            "rmse": float(np.sqrt(np.mean(mean))),
            "interval": None if iv is None else [iv[0], iv[1]],
            "rel_se": None if iv is None else iv[2]}
