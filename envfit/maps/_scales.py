r"""Value scales on which images are compared (the scale of an RMSE is an explicit choice).

The paper's Table 2 RMSE values (0.23 → 0.07) are on a display-referred image in [0, 1],
not on raw HDR radiance, where the sun dominates every error (see docs/ERRATA.md, "Table 2"). So an
error is always measured after a :class:`Scale`, and the scale's parameters are fitted
**once, on the reference map** (:func:`fit_scale`) and then applied unchanged to the
reference and to every reconstruction.

Scales (``v`` a linear value, :math:`\bar Y` the solid-angle weighted mean luminance of the
reference, Rec. 709 weights for RGB, channel 0 otherwise):

* ``"linear"``: :math:`v` (identity).
* ``"display"``: :math:`\mathrm{sRGB}(\mathrm{clip}(k v, 0, 1))` with exposure
  :math:`k = 0.18/\bar Y` (the mean luminance maps to middle grey 0.18) and the IEC
  61966-2-1 sRGB OETF (:func:`srgb_oetf`).
* ``"log"``: :math:`\log(1 + \max(v, 0)/\bar Y)`.

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> ref = EnvMap(np.full((4, 8, 3), 2.0))
>>> s = fit_scale("display", ref)
>>> round(s.exposure, 6), round(float(s.apply(ref.data).max()), 6)
(0.09, 0.461356)
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envfit.base import ParameterError

__all__ = ["SCALES", "MIDDLE_GREY", "Scale", "fit_scale", "srgb_oetf", "check_not_constant"]

#: the names of the available scales
SCALES = ("linear", "display", "log")

#: the display scale maps the map's mean luminance to this linear value
MIDDLE_GREY = 0.18


def srgb_oetf(x):
    r"""The sRGB opto-electronic transfer function (IEC 61966-2-1), elementwise, float64.

    .. math::  V = \begin{cases} 12.92\,x & x \le 0.0031308 \\
                                  1.055\,x^{1/2.4} - 0.055 & x > 0.0031308 \end{cases}

    Meant for ``x`` in [0, 1] (negative inputs take the linear branch).

    >>> [round(float(v), 6) for v in srgb_oetf([0.0, 0.0031308, 0.18, 1.0])]
    [0.0, 0.04045, 0.461356, 1.0]
    """
    x = np.asarray(x, dtype=np.float64)
    lin = 12.92 * x
    powr = 1.055 * np.power(np.maximum(x, 0.0031308), 1.0 / 2.4) - 0.055
    return np.where(x <= 0.0031308, lin, powr)


@dataclass(frozen=True)
class Scale:
    """A fitted value scale: ``name`` in :data:`SCALES` and its parameters.

    Attributes
    ----------
    name : "linear", "display" or "log"
    exposure : the display exposure ``k`` (1 for the other scales)
    normaliser : the log scale's divisor, the reference mean luminance (1 otherwise)
    reference_mean_luminance : the fitted reference statistic, kept for reporting

    >>> bool(Scale("log", normaliser=2.0).apply(np.array([2.0]))[0] == np.log(2.0))
    True
    """

    name: str
    exposure: float = 1.0
    normaliser: float = 1.0
    reference_mean_luminance: float = float("nan")

    def __post_init__(self) -> None:
        if self.name not in SCALES:
            raise ParameterError(f"scale must be one of {', '.join(SCALES)}; got {self.name!r}")
        for attr in ("exposure", "normaliser"):
            v = getattr(self, attr)
            if not (np.isfinite(v) and v > 0):
                raise ParameterError(f"scale {attr} must be a positive finite number, got {v!r}")

    def apply(self, values) -> np.ndarray:
        """Transform linear values (any shape; the last axis may be channels), float64.

        >>> Scale("display", exposure=0.5).apply(np.array([[0.36, 4.0]])).round(6).tolist()
        [[0.461356, 1.0]]
        """
        v = np.asarray(values, dtype=np.float64)
        if self.name == "linear":
            return v.copy()
        if self.name == "display":
            return srgb_oetf(np.clip(v * self.exposure, 0.0, 1.0))
        return np.log1p(np.maximum(v, 0.0) / self.normaliser)

    def to_linear(self, values) -> np.ndarray:
        """Back to radiance where the scale is invertible (linear, log); the display scale
        maps values in [0, 1] back through the sRGB EOTF and the exposure (clipped highlights
        stay clipped)."""
        v = np.asarray(values, dtype=np.float64)
        if self.name == "linear":
            return v
        if self.name == "log":
            return np.expm1(v) * self.normaliser
        x = np.clip(v, 0.0, 1.0)
        lin = np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)
        return lin / self.exposure

    def to_display(self, values) -> np.ndarray:
        """Display-referred [0, 1] values for a PNG preview of data on this scale."""
        if self.name == "display":
            return np.clip(np.asarray(values, dtype=np.float64), 0.0, 1.0)
        exposure = MIDDLE_GREY / self.reference_mean_luminance \
            if np.isfinite(self.reference_mean_luminance) and self.reference_mean_luminance > 0 else 1.0
        return srgb_oetf(np.clip(self.to_linear(values) * exposure, 0.0, 1.0))

    def describe(self) -> str:
        """One line for reports, e.g. ``display: exposure k=0.09 ...``."""
        if self.name == "linear":
            return "linear: raw values (no transform)"
        if self.name == "display":
            return (f"display: exposure k={self.exposure:.6g} (mean luminance "
                    f"{self.reference_mean_luminance:.6g} -> {MIDDLE_GREY}), clipped to [0, 1], "
                    f"sRGB OETF")
        return f"log: log(1 + max(v, 0) / {self.normaliser:.6g}) (reference mean luminance)"


def fit_scale(name: str, envmap) -> Scale:
    r"""Fit a scale's parameters on the reference map (an :class:`EnvMap` or H x 2H [x C] array).

    The reference statistic is the solid-angle weighted mean luminance
    :math:`\bar Y = \sum \Omega_{ij} Y_{ij} / \sum \Omega_{ij}`; ``display`` uses
    :math:`k = 0.18/\bar Y` and ``log`` divides by :math:`\bar Y`. A map with
    :math:`\bar Y \le 0` (black) raises :class:`ParameterError` for those two scales.

    >>> from envfit.maps._envmap import EnvMap
    >>> fit_scale("log", EnvMap(np.full((2, 4, 1), 4.0))).normaliser
    4.0
    """
    from envfit.maps._envmap import EnvMap
    from envfit.maps._latlong import row_solid_angles

    if name not in SCALES:
        raise ParameterError(f"scale must be one of {', '.join(SCALES)}; got {name!r}")
    m = envmap if isinstance(envmap, EnvMap) else EnvMap(np.asarray(envmap))
    y = m.luminance()
    w = row_solid_angles(m.height, m.width)
    ybar = float(w @ y.sum(axis=1) / (w.sum() * m.width))
    if name == "linear":
        return Scale("linear", reference_mean_luminance=ybar)
    if not (np.isfinite(ybar) and ybar > 0):
        label = f"map {m.name}" if m.name else "the map"
        what = ("exposure 0.18 / mean luminance" if name == "display"
                else "log(1 + v / mean luminance)")
        if not np.any(m.data):
            raise ParameterError(f"{label} is all zero: the {name} scale ({what}) needs a "
                                 "positive mean luminance, and there is nothing to fit")
        raise ParameterError(f"{label} has mean luminance {ybar:.6g}: the {name} scale ({what}) "
                             "needs a positive mean luminance; use the linear scale")
    if name == "display":
        return Scale("display", exposure=MIDDLE_GREY / ybar, reference_mean_luminance=ybar)
    return Scale("log", normaliser=ybar, reference_mean_luminance=ybar)


def check_not_constant(values, scale: str, name: str = "", *, where: str = "") -> None:
    """Refuse a map (or its samples) that is constant on its scale: there is nothing to fit
    or reconstruct (σ̂ = 0, the likelihood is infinite for every s and the fit's root search
    meets NaN). ``values``: the map's data (or samples) on ``scale``, last axis channels;
    ``where`` says which values, e.g. ``" at its 400 samples"``.

    >>> check_not_constant(np.zeros((2, 4, 3)), "linear", "forest.exr")
    Traceback (most recent call last):
    ...
    envfit.base._errors.ParameterError: map forest.exr is all zero on the linear scale: there is nothing to fit
    >>> check_not_constant(np.arange(8.0).reshape(2, 4, 1), "linear")
    """
    v = np.asarray(values, dtype=np.float64)
    v = v.reshape(-1, v.shape[-1]) if v.ndim > 1 else v.reshape(-1, 1)
    if v.size == 0:
        return
    lo, hi = v.min(axis=0), v.max(axis=0)
    if np.any(hi > lo) or not np.all(np.isfinite(lo)):
        return
    label = f"map {name}" if name else "the map"
    if not np.any(hi):
        raise ParameterError(f"{label} is all zero on the {scale} scale{where}: there is "
                             "nothing to fit")
    if np.all(lo == lo[0]):
        vals = f"value {lo[0]:.6g}"
    else:
        vals = "values " + ", ".join(f"{x:.6g}" for x in lo[:4]) + " per channel"
    raise ParameterError(f"{label} is constant on the {scale} scale{where} ({vals}): there is "
                         "nothing to fit")
