r"""The error of a shifted point set from the warped integrand's power *above the box*, with
the strips along the axes of frequency space resolved.

:mod:`envfit.predict.warped._warped_spectrum` knows :math:`|\hat h(k)|^2` on the box
:math:`|k_0|, |k_1| \le B` and the total variance V, so the power above the box is
:math:`R = V - \sum_{box}|\hat h|^2`. Its contribution to a shifted estimator's error is
:math:`\sum_{k\notin box}|\hat h(k)|^2|S(k)|^2`, with :math:`|S|^2 = 1/n` on average over
high frequencies for any set. But a warped integrand is not periodic on the unit square (the
lobe's pole and horizon, the map's poles), and its jumps at the square's edges — and at the
map sampler's row boundaries, which are lines of constant :math:`u_1` — put much of R on the
strips :math:`|k_\perp| \le w` along the axes, decaying like :math:`k^{-2}`. There a QMC set's
exponential sums are far below 1/n: a lattice's or a (0, m, 2)-net's one-dimensional
projections are stratified, so :math:`S(k, 0) = 0` for :math:`0 < |k| < n`, and near the axes
:math:`|S|` stays small up to :math:`|k_\parallel| \approx n/|k_\perp|` (the hyperbolic cross).
Counting that power at 1/n over-predicts high-N QMC errors: by 25 % at N = 1024 for the
source split with a glossy lobe on a 128-row sun + GP map, where 84 % of the box's outer
octave lies on the strips.

:func:`strip_tail` therefore splits R:

* on each of the :math:`4w + 2` rays of the strips (the half plane, each ray's mirror image
  counted twice), the box's power on its outer two octaves :math:`(B/4, B/2]` and
  :math:`(B/2, B]` fixes a power law :math:`c\,k^{-\alpha}` (α solved from their ratio,
  clamped to [1.5, 8]), continued to k = K with the set's own exponential sums on the strip
  (one non-uniform FFT) and beyond K at 1/n (:math:`c\,\zeta(\alpha, K+1)/n`, Hurwitz ζ);
* the strips' continued power is capped at R, and the rest of R counts at 1/n as before.

For random points :math:`\mathbb E|S|^2 = 1/n` everywhere and nothing changes; for h a sum of
one-dimensional functions with power-law spectra (e.g. :math:`h = u_0`,
:math:`|\hat h(k,0)|^2 = 1/(4\pi^2k^2)`) it is exact up to K (``tests/test_spectral_tail.py``
checks it against the direct sum of :math:`|\hat h|^2|S|^2` to :math:`10^6`).

Example
-------
>>> import numpy as np
>>> B = 16
>>> P = np.zeros((2 * B + 1, B + 1))
>>> k = np.arange(-B, B + 1)
>>> P[:, 0] = np.where(k != 0, 1.0 / (4 * np.pi ** 2 * np.maximum(k * k, 1)), 0.0)   # h = u0
>>> u = np.c_[(np.arange(64) + 0.5) / 64, np.random.default_rng(0).random(64)]  # stratified u0
>>> t = strip_tail(P, 1.0 / 12.0, u)
>>> round(t["rest"], 12), round(t["strips"] * 12 * 64 ** 2, 2)   # exact: 1/(12 n²)
(0.0, 1.02)
>>> round((t["rest"] + t["above"] / 64) * 12 * 64 ** 2, 1)      # the power at 1/n: 2.4×
2.4
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import special

__all__ = ["strip_tail", "strip_fits", "strip_exp_sums", "StripFit", "STRIP_HALF_WIDTH",
           "STRIP_LENGTH_MAX"]

#: w: the strips are the rows |k_⊥| ≤ w beside each axis
STRIP_HALF_WIDTH = 3
#: the strips are continued to K = min(max(8B, 4n), this)
STRIP_LENGTH_MAX = 1 << 13
#: relative accuracy of the strips' non-uniform FFTs
STRIP_EPSILON = 1e-7
#: the power law's exponent is clamped to this range
ALPHA_RANGE = (1.5, 8.0)


def strip_exp_sums(u: np.ndarray, length: int, half_width: int) -> tuple[np.ndarray, np.ndarray]:
    r""":math:`S(k) = \frac1n\sum_j e^{2\pi i k\cdot u_j}` on the two strips: rows
    (2K+1, 2w+1) for :math:`k_0 \in [-K, K], k_1 \in [-w, w]` and columns (2w+1, 2K+1) for
    :math:`k_0 \in [-w, w], k_1 \in [-K, K]`: per row of a strip one one-dimensional type-1
    non-uniform FFT (ducc0) of the points' coordinate along the strip, weighted by
    :math:`e^{2\pi i k_\perp u_\perp}` (relative accuracy :data:`STRIP_EPSILON`)."""
    import ducc0

    u = np.asarray(u, dtype=np.float64)
    n = u.shape[0]
    perp = np.arange(-half_width, half_width + 1)
    out = []
    for along in (0, 1):
        coord = np.ascontiguousarray(2.0 * np.pi * u[:, along:along + 1])
        other = u[:, 1 - along]
        z = np.exp(2j * np.pi * other)
        weights = np.empty((perp.size, n), dtype=np.complex128)
        weights[half_width] = 1.0
        for j in range(1, half_width + 1):                # e^{±2πi j u} by products
            weights[half_width + j] = weights[half_width + j - 1] * z
            weights[half_width - j] = np.conj(weights[half_width + j])
        buf = np.zeros((perp.size, 2 * length + 2), dtype=np.complex128)
        ducc0.nufft.nu2u(points=weights,
                         coord=coord, forward=False, epsilon=STRIP_EPSILON, out=buf,
                         nthreads=1)                  # one transform per row, in one call
        s = buf[:, 1:] / n
        out.append(s.T if along == 0 else s)
    return out[0], out[1]


@dataclass(frozen=True)
class StripFit:
    r"""The power law :math:`c\,k^{-\alpha}` of one ray of the strips: ``kind`` "row" (along
    :math:`k_0` at :math:`k_1` = ``perp``, ``sign`` ±1 the direction) or "col" (along
    :math:`k_1 > 0` at :math:`k_0` = ``perp``), counted ``weight`` times (its mirror image)."""

    weight: float
    kind: str
    perp: int
    sign: int
    c: float
    alpha: float


def _rays(power: np.ndarray, band: int, w: int):
    """The strips' rays of the half box: (in-box profile at k = 1..B, weight, kind, k_⊥, sign)."""
    k = np.arange(1, band + 1)
    for k1 in range(0, w + 1):                       # along k0: P(±k, k1), k1 ≥ 0
        for sign in ((1,) if k1 == 0 else (1, -1)):
            yield power[band + sign * k, k1], 2.0, "row", k1, sign
    for k0 in range(-w, w + 1):                      # along k1: P(k0, k), k > 0
        yield power[band + k0, k], 2.0, "col", k0, 1


def _power_law(profile: np.ndarray, band: int):
    """(c, α) of the power law c·k^-α with the profile's sums over the octaves (B/4, B/2] and
    (B/2, B] (α solved on the discrete sums, clamped to :data:`ALPHA_RANGE`); None where
    either sum is not positive."""
    k = np.arange(1, band + 1, dtype=np.float64)
    lo, hi = (k > band / 4) & (k <= band / 2), k > band / 2
    s1, s2 = float(profile[lo].sum()), float(profile[hi].sum())
    if not (s1 > 0.0 and s2 > 0.0):
        return None

    def gap(a):                                  # increasing in a
        return np.log(np.sum(k[lo] ** -a) / np.sum(k[hi] ** -a)) - np.log(s1 / s2)

    a0, a1 = ALPHA_RANGE
    if gap(a0) >= 0 or gap(a1) <= 0:
        alpha = a0 if gap(a0) >= 0 else a1
    else:
        # bisection to 1e-9: scipy.optimize.brentq would do it, but importing scipy.optimize
        # costs 0.44 s of a cached advise call (3 s budget), for one monotone root per ray
        while a1 - a0 > 1e-9:
            mid = 0.5 * (a0 + a1)
            a0, a1 = (mid, a1) if gap(mid) < 0 else (a0, mid)
        alpha = 0.5 * (a0 + a1)
    return s2 / float(np.sum(k[hi] ** -alpha)), float(alpha)


def strip_fits(power: np.ndarray, half_width: int = STRIP_HALF_WIDTH) -> list[StripFit]:
    """The :class:`StripFit` of every ray of the strips with a power law, for a half-box
    ``power`` (2B+1, B+1); they depend on the spectrum only, so a spectrum fits them once for
    all its point sets (:attr:`envfit.predict.renderer.WarpedSpectrum.strip_fits`)."""
    power = np.asarray(power, dtype=np.float64)
    band = power.shape[1] - 1
    w = min(int(half_width), band // 2)
    out = []
    for profile, weight, kind, perp, sign in _rays(power, band, w):
        fit = _power_law(profile, band)
        if fit is not None:
            out.append(StripFit(weight, kind, perp, sign, *fit))
    return out


def strip_tail(power: np.ndarray, variance: float, u: np.ndarray, *,
               half_width: int = STRIP_HALF_WIDTH, negligible: float = 0.0,
               fits: list | None = None) -> dict:
    r"""The error above the box of the shifted points u for a part with half-box power
    ``power`` (2B+1, B+1) (row :math:`k_0 + B`, column :math:`k_1 \ge 0`) and variance V:
    ``strips`` (the continued strips with the set's sums), ``rest`` (the rest of R at 1/n),
    ``strip_power`` (the strips' continued power above the box) and ``above`` = R.

    Falls back to ``rest`` = R/n (no strips) for a box smaller than B = 4, or where R/n is at
    most ``negligible`` (the strips could lower the result by no more than R/n). ``fits``:
    :func:`strip_fits` of ``power`` with ``half_width``, if already computed."""
    power = np.asarray(power, dtype=np.float64)
    band = power.shape[1] - 1
    u = np.asarray(u, dtype=np.float64)
    n = u.shape[0]
    above = max(float(variance) - float(power[:, 0].sum() + 2.0 * power[:, 1:].sum()), 0.0)
    w = min(int(half_width), band // 2)
    if band < 4 or above == 0.0 or above / n <= negligible:
        return {"strips": 0.0, "rest": above / n, "strip_power": 0.0, "above": above}
    K = int(min(max(8 * band, 4 * n), STRIP_LENGTH_MAX))
    rows, cols = strip_exp_sums(u, K, w)
    k = np.arange(band + 1, K + 1)
    kf = k.astype(np.float64)
    terms, total = [], 0.0
    if fits is None:
        fits = strip_fits(power, half_width)
    for f in fits:
        total += f.weight * f.c * float(special.zeta(f.alpha, band + 1))
        s = rows[K + f.sign * k, w + f.perp] if f.kind == "row" else cols[w + f.perp, K + k]
        terms.append((f, float(np.sum(kf ** -f.alpha * np.abs(s) ** 2))))
    scale = min(1.0, above / total) if total > 0 else 0.0
    strips = sum(f.weight * f.c * scale * (inside + float(special.zeta(f.alpha, K + 1)) / n)
                 for f, inside in terms)
    return {"strips": float(strips), "rest": (above - scale * total) / n,
            "strip_power": float(scale * total), "above": above}
