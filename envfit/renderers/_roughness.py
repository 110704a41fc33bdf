"""A renderer's roughness convention: the user-facing roughness R of its microfacet BSDFs and
the microfacet α it means (:class:`RoughnessConvention`, a renderer record's
:attr:`~envfit.renderers.Renderer.roughness`); the range of R the advice takes and its words.

Each renderer's convention, with the source it is read from, is in its folder
(``envfit/renderers/<name>/_bsdf.py``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from envfit.base import ParameterError
from envfit.defaults import ADVISE_ALPHA

__all__ = ["RoughnessConvention", "ROUGHNESS_RTOL"]

#: the relative tolerance of a roughness at the end of its range (a bound typed rounded,
#: e.g. sqrt(0.05) = 0.2236068 where alpha = R^2, or 0.0025 where alpha = sqrt(R), whose
#: alpha = sqrt(0.0025) is a hair from 0.05 in floating point): within it the value is taken
#: as the bound
ROUGHNESS_RTOL = 1e-6


@dataclass(frozen=True)
class RoughnessConvention:
    """A renderer's roughness R ↔ microfacet α.

    Attributes
    ----------
    rule : R → α in words (``"alpha = sqrt(R)"``)
    units : the renderer's R in words (``"pbrt-v4's roughness R, alpha = sqrt(R)"``)
    alpha_of : R → α (R already checked to be in [0, 1])
    roughness_of : α → R (the inverse)

    >>> c = RoughnessConvention("alpha = R^2", "a roughness R, alpha = R^2",
    ...                         lambda r: r * r, math.sqrt)
    >>> c.to_alpha(0.5), c.range(), c.words()
    (0.25, (0.223607, 1.0), 'a roughness R, alpha = R^2: 0.223607 to 1 (alpha 0.05 to 1)')
    """

    rule: str
    units: str
    alpha_of: Callable[[float], float]
    roughness_of: Callable[[float], float]

    def to_alpha(self, roughness) -> float:
        """The microfacet α of a user-facing ``roughness`` in [0, 1]; ParameterError else."""
        try:
            r = float(roughness)
        except (TypeError, ValueError):
            raise ParameterError(f"roughness must be a number, got {roughness!r}") from None
        if not (math.isfinite(r) and 0.0 <= r <= 1.0):
            raise ParameterError(f"roughness must be in [0, 1], got {roughness!r}")
        return self.alpha_of(r)

    def from_alpha(self, alpha) -> float:
        """The roughness of the microfacet α (:meth:`to_alpha` inverted)."""
        return self.roughness_of(float(alpha))

    def range(self, alpha_range=ADVISE_ALPHA) -> tuple[float, float]:
        """The roughness range for ``alpha_range`` (default: the advice's,
        :data:`envfit.defaults.ADVISE_ALPHA`), the lower bound rounded up and the upper down to
        6 significant digits (typed as printed, it is inside)."""
        lo, hi = (self.from_alpha(a) for a in alpha_range)
        return _round6(lo, math.ceil), _round6(hi, math.floor)

    def words(self) -> str:
        """The roughness and its range (:meth:`range`), as ``envfit advise --help`` and its
        error say it."""
        lo, hi = self.range()
        return (f"{self.units}: {lo:g} to {hi:g} (alpha {ADVISE_ALPHA[0]:g} to "
                f"{ADVISE_ALPHA[1]:g})")


def _round6(x: float, how) -> float:
    """``x`` to 6 significant digits, rounded by ``how`` (math.ceil or math.floor) unless it
    is within :data:`ROUGHNESS_RTOL` of the nearest 6-digit value."""
    if x <= 0:
        return x
    scale = 10.0 ** (5 - math.floor(math.log10(x)))
    near = round(x * scale) / scale
    return near if abs(near - x) <= ROUGHNESS_RTOL * x else how(x * scale) / scale
