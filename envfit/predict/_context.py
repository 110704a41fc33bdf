r"""What a prediction is made from: a map (:class:`PredictionContext`), a rule
(:class:`envfit.sampling.Rule`: a :class:`~envfit.sampling.QuadratureRule` or a
:class:`~envfit.sampling.RendererRule`), and what it says (:class:`Prediction`).

Every predictor of :mod:`envfit.predict` is a function ``f(ctx, rule) -> Prediction``: the
context holds what the map gives (the fitted :math:`\hat s, \hat\sigma`, the band-limited
fit :math:`\hat s', \hat\sigma'`, the band limit H − 1, the bilinear lookup's transfer
:math:`\tau_l`, the map's realised power per degree :math:`\hat P_{l,c}` and the RMS of
its mean; for the renderer rules the warped integrand's spectra,
:class:`envfit.predict.renderer.RendererModel`), the rule what a point set gives (for a
quadrature rule N, its worst-case error E(ŝ), its error power per degree :math:`e_l`,
:math:`\sum_j w_j`; for a renderer rule its strategy, point set and N). Both are plain frozen
dataclasses. :func:`reads` marks the kind of rule a predictor reads, which
:func:`envfit.predict.predict` checks.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from envfit.base import ParameterError
from envfit.fit import combine_sigma
from envfit.maps import EnvMap
from envfit.sampling import QuadratureRule, RendererRule, Rule
from envfit.shading import degree_weights, lookup_transfer, map_degree_power, pixel_degree_power

__all__ = ["PredictionContext", "Prediction", "reads", "Rule", "QuadratureRule",
           "RendererRule"]


def reads(rule_type: type) -> Callable:
    """Decorator of a predictor: the kind of :class:`envfit.sampling.Rule` it reads, stored as
    its ``rule_type`` (:func:`envfit.predict.predict` refuses another kind; a predictor
    without it reads any rule).

    >>> @reads(QuadratureRule)
    ... def f(ctx, rule): ...
    >>> f.rule_type.__name__
    'QuadratureRule'
    """
    def mark(f: Callable) -> Callable:
        f.rule_type = rule_type
        return f
    return mark


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
    renderer : the warped integrand's spectra of the map and lobe
        (:class:`envfit.predict.renderer.RendererModel`) — the renderer rules' predictors.
    point_seed : the seed of a stochastic renderer point set
        (:func:`envfit.sampling.rule_points`; 0: the sets the measurement uses).
    """

    s: float | None = None
    sigma: float | None = None
    s_bandlimited: float | None = None
    sigma_bandlimited: float | None = None
    sigma_bandlimited_channels: Sequence[float] = ()
    band_lmax: int | None = None
    transfer: np.ndarray | None = None
    map_power: np.ndarray | None = None
    mean_rms: float = 0.0
    renderer: object | None = None
    point_seed: int = 0

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

    def degree_weights(self) -> np.ndarray:
        r""":math:`a_l(\hat s')\tau_l`, l = 0…H − 1, of (b′)
        (:func:`envfit.shading._spectra.degree_weights`), computed once per context."""
        dw = self.__dict__.get("_degree_weights")
        if dw is None:
            dw = degree_weights(self.s_bandlimited, self.band_lmax, self.transfer)
            object.__setattr__(self, "_degree_weights", dw)
        return dw

    def need(self, *names: str, who: str) -> None:
        """Raise :class:`envfit.base._errors.ParameterError` naming the fields of ``names``
        that are unset (None) but needed by the predictor ``who``."""
        missing = [n for n in names if getattr(self, n) is None]
        if missing:
            raise ParameterError(f"predictor {who!r} needs {', '.join(missing)} in its "
                                 "PredictionContext (see PredictionContext.from_map)")


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
