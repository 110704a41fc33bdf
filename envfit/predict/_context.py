r"""What a prediction is made from: a map (:class:`PredictionContext`), a quadrature rule
(:class:`Rule`), and what it says (:class:`Prediction`).

Every predictor of :mod:`envfit.predict` is a function ``f(ctx, rule) -> Prediction``: the
context holds what the map gives (the fitted :math:`\hat s, \hat\sigma`, the band-limited
fit :math:`\hat s', \hat\sigma'`, the band limit H − 1, the bilinear lookup's transfer
:math:`\tau_l`, the map's realised power per degree :math:`\hat P_{l,c}` and the RMS of
its mean), the rule what a point set with weights gives (N, its worst-case error E(ŝ), its
error power per degree :math:`e_l`, :math:`\sum_j w_j`). Both are plain frozen
dataclasses: a predictor reads them and computes nothing about the map or the points.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from envfit.base._errors import ParameterError
from envfit.fit._sigma import combine_sigma
from envfit.maps._envmap import EnvMap
from envfit.theory._quadrature import worst_case_error
from envfit.shading._spectra import (lookup_transfer, map_degree_power, pixel_degree_power,
                                     rule_error_power)

__all__ = ["PredictionContext", "Rule", "Prediction"]


@dataclass(frozen=True)
class PredictionContext:
    r"""What a map gives to the predictors.

    Attributes
    ----------
    s, sigma : the paper's fitted smoothness :math:`\hat s` and :math:`\hat\sigma` (RMS over
        channels, :func:`envfit.fit._sigma.combine_sigma`) — prediction (b).
    s_bandlimited, sigma_bandlimited : :math:`\hat s'`, :math:`\hat\sigma'` of the
        band-limited model (kernel truncated at H − 1, samples at pixel centres) — (b′).
    sigma_bandlimited_channels : :math:`\hat\sigma'_c` per channel (the one-map scatter).
    band_lmax : the highest degree the map holds, H − 1 for an H-row lat-long map.
    transfer : :math:`\tau_l`, l = 0…H − 1, of the bilinear lookup
        (:func:`envfit.shading._spectra.lookup_transfer`); None = 1.
    map_power : (C, H) realised power per degree :math:`\hat P_{l,c}` of the map's bilinear
        interpolant (:func:`envfit.shading._spectra.map_degree_power`) — prediction (c).
    mean_rms : :math:`(\overline{m^2})^{1/2}`, the RMS over channels of the map's
        solid-angle mean: a rule with :math:`\sum_j w_j \ne 1` errs by
        :math:`\bar m(\sum_j w_j - 1)` on every axis.
    """

    s: float
    sigma: float
    s_bandlimited: float | None = None
    sigma_bandlimited: float | None = None
    sigma_bandlimited_channels: Sequence[float] = ()
    band_lmax: int | None = None
    transfer: np.ndarray | None = None
    map_power: np.ndarray | None = None
    mean_rms: float = 0.0

    @classmethod
    def from_map(cls, scaled: EnvMap, s: float, sigma_channels, s_bandlimited: float,
                 sigma_bandlimited_channels) -> "PredictionContext":
        r"""The context of a (scaled) map and its two fits: band limit H − 1, the realised
        power :math:`\hat P` to H − 1, :math:`\tau_l = \sum_c\hat P^{bil}_{l,c}/\sum_c\hat
        P^{pix}_{l,c}` and the RMS over channels of the mean (≈ 0.7 s on a 1024×512 map).

        >>> ctx = PredictionContext.from_map(EnvMap(np.full((8, 16, 2), 3.0)), 1.5, [1.0, 1.0],
        ...                                  1.4, [2.0, 2.0])
        >>> ctx.band_lmax, ctx.map_power.shape, round(ctx.mean_rms, 12), ctx.sigma_bandlimited
        (7, (2, 8), 3.0, 2.0)
        """
        band_lmax = scaled.height - 1          # the highest degree an H-row lat-long map holds
        map_power = map_degree_power(scaled, band_lmax)
        transfer = lookup_transfer(map_power, pixel_degree_power(scaled, band_lmax))
        ch = [float(x) for x in sigma_bandlimited_channels]
        return cls(s=float(s), sigma=combine_sigma(sigma_channels),
                   s_bandlimited=float(s_bandlimited), sigma_bandlimited=combine_sigma(ch),
                   sigma_bandlimited_channels=tuple(ch), band_lmax=band_lmax,
                   transfer=transfer, map_power=map_power,
                   mean_rms=float(np.sqrt(np.mean(scaled.mean() ** 2))))

    def need(self, *names: str, who: str) -> None:
        """Raise :class:`envfit.base._errors.ParameterError` naming the fields of ``names``
        that are unset (None) but needed by the predictor ``who``."""
        missing = [n for n in names if getattr(self, n) is None]
        if missing:
            raise ParameterError(f"predictor {who!r} needs {', '.join(missing)} in its "
                                 "PredictionContext (see PredictionContext.from_map)")


@dataclass(frozen=True)
class Rule:
    r"""What a quadrature rule (or a truncation) gives to the predictors.

    Attributes
    ----------
    n : the number of points N (for a truncation: the cut-off degree L).
    wce : its worst-case error :math:`E(\hat s)` (Eq. 41) at the context's s; None: unknown.
    error_power : :math:`e_l`, l = 0…H − 1, the squared error of the rule on the degree-l
        harmonics (:func:`envfit.shading._spectra.rule_error_power`); None: unknown.
    weight_sum : :math:`\sum_j w_j`; None for a rule without weights (a truncation keeps
        :math:`b_0` exactly: no error from the map's mean).
    wce_bandlimited : :math:`E'(\hat s')` given directly, used by (b′) when there is no
        ``error_power`` (a truncation's closed form,
        :func:`envfit.shading._spectra.sh_truncation_curve_transfer`).
    points, weights, brdf : the rule itself, when at hand (informative only).
    """

    n: int
    wce: float | None = None
    error_power: Sequence[float] | np.ndarray | None = None
    weight_sum: float | None = None
    wce_bandlimited: float | None = None
    points: np.ndarray | None = None
    weights: np.ndarray | None = None
    brdf: object | None = None

    @classmethod
    def from_points(cls, points, weights, brdf, s: float, band_lmax: int, *,
                    workers: int = 1) -> "Rule":
        r"""The rule of ``points`` and ``weights`` for ``brdf``: E(s)
        (:func:`envfit.theory._quadrature.worst_case_error`), :math:`e_l` to
        ``band_lmax`` (:func:`envfit.shading._spectra.rule_error_power`), :math:`\sum_j w_j`.

        >>> from envfit.theory._brdf import Diffuse
        >>> r = Rule.from_points(np.array([[0.0, 0.0, 1.0]]), [1.0], Diffuse(), 1.5, 4)
        >>> r.n, r.weight_sum, r.error_power.shape
        (1, 1.0, (5,))
        """
        pts = np.asarray(points, dtype=np.float64)
        w = np.asarray(weights, dtype=np.float64)
        return cls(n=int(pts.shape[0]),
                   wce=worst_case_error(pts, w, brdf, s, workers=workers),
                   error_power=rule_error_power(pts, w, brdf, band_lmax),
                   weight_sum=float(np.sum(w)), points=pts, weights=w, brdf=brdf)


@dataclass(frozen=True)
class Prediction:
    r"""What a predictor says about one rule on one map.

    Attributes
    ----------
    name : the predictor's name in :data:`envfit.predict.PREDICTORS`.
    rmse : the predicted RMSE over random axes and channels; None when the rule lacks what
        the predictor needs (a rule whose weights could not be computed).
    wce : the model's worst-case error behind it (E for (b), E′ for (b′); None for (c)).
    mean_error : the error from the map's mean, :math:`|\sum_j w_j - 1|\,(\overline{m^2})^{1/2}`
        ((b′) only).
    relative_sd : the relative standard deviation expected between one map's RMSE and
        ``rmse`` under the model (:func:`envfit.shading._spectra.model_scatter`; (b′) only).
    """

    name: str
    rmse: float | None
    wce: float | None = None
    mean_error: float | None = None
    relative_sd: float | None = None
