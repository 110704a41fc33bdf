r"""Isotropic microfacet normal distributions (GGX / Trowbridge–Reitz and Beckmann) and Smith's
shadowing-masking in its two forms, separable and height-correlated.

All directions are in the local shading frame (z = the normal), as (K, 3) float64 arrays.

* :math:`D_{GGX}(m) = \dfrac{1}{\pi\alpha^2\,\cos^4\theta_m\,(1 + \tan^2\theta_m/\alpha^2)^2}`;
* :math:`D_{B}(m) = \dfrac{\exp(-\tan^2\theta_m/\alpha^2)}{\pi\alpha^2\cos^4\theta_m}`;
* Smith :math:`\Lambda`: GGX :math:`\tfrac12(\sqrt{1 + \alpha^2\tan^2\theta} - 1)` (Heitz 2014,
  Eq. 72); Beckmann by the rational approximation of Walter et al. 2007 in the variable
  :math:`a = 1/(\alpha\tan\theta)`: :math:`\Lambda \approx (1 - 1.259a + 0.396a^2)/(3.535a +
  2.181a^2)` for :math:`a < 1.6`, 0 beyond, whose :math:`1/(1+\Lambda)` is the rational
  :math:`G_1 = (3.535a + 2.181a^2)/(1 + 2.276a + 2.577a^2)` (algebraically equal: either is
  what a renderer evaluates); the exact Beckmann
  :math:`\Lambda = \tfrac12(\operatorname{erf}(a) - 1 +
  e^{-a^2}/(a\sqrt\pi))` is :meth:`MicrofacetDistribution.lambda_exact`;
* :math:`G_1(v, m) = \chi^+(v\cdot m / v_z)/(1 + \Lambda(v))`;
  separable :math:`G = G_1(\omega_i)G_1(\omega_o)`;
  height-correlated :math:`G = 1/(1 + \Lambda(\omega_i) + \Lambda(\omega_o))`;
* the distribution of visible normals :math:`D_{\omega_i}(m) = G_1(\omega_i, m)\,
  \max(0, \omega_i\cdot m)\,D(m)/\cos\theta_i` (Heitz 2014, Eq. 16).

Accepted roughness: :math:`\alpha \in [10^{-4}, 1]` (the renderers' own floor on α, each
cited in its folder, ``envfit/renderers/<name>/_bsdf.py``; issue 25 uses 0.05–1).

Which renderer evaluates which form, read from which source, its folder says.

References: Walter, Marschner, Li, Torrance, "Microfacet Models for Refraction through Rough
Surfaces", EGSR 2007; Heitz, "Understanding the Masking-Shadowing Function in
Microfacet-Based BRDFs", JCGT 3(2), 2014.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import erf

from envfit.base import ParameterError

__all__ = ["ALPHA_RANGE", "DISTRIBUTIONS", "MicrofacetDistribution"]

DISTRIBUTIONS = ("ggx", "beckmann")
ALPHA_RANGE = (1e-4, 1.0)


def _tan2(v: np.ndarray) -> np.ndarray:
    """tan²θ of directions (K, 3); +inf at the horizon (z = 0)."""
    xy2 = v[:, 0] ** 2 + v[:, 1] ** 2
    z2 = v[:, 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(xy2 == 0.0, 0.0, xy2 / z2)


@dataclass(frozen=True)
class MicrofacetDistribution:
    """An isotropic microfacet distribution: ``kind`` "ggx" or "beckmann", roughness ``alpha``.

    >>> d = MicrofacetDistribution("ggx", 0.5)
    >>> float(d.D(np.array([[0.0, 0.0, 1.0]]))[0] * math.pi * 0.25)
    1.0
    """

    kind: str
    alpha: float

    def __post_init__(self) -> None:
        if self.kind not in DISTRIBUTIONS:
            raise ParameterError(f"microfacet distribution must be one of {DISTRIBUTIONS}, "
                                 f"got {self.kind!r}")
        try:
            a = float(self.alpha)
        except (TypeError, ValueError):
            raise ParameterError(f"alpha must be a number, got {self.alpha!r}") from None
        lo, hi = ALPHA_RANGE
        if not (math.isfinite(a) and lo <= a <= hi):
            raise ParameterError(f"alpha must be in [{lo:g}, {hi:g}], got {self.alpha!r}")
        object.__setattr__(self, "alpha", a)

    def D(self, m: np.ndarray) -> np.ndarray:  # noqa: N802 (the literature's name)
        """The normal distribution D(m), zero for m below the surface (m_z ≤ 0)."""
        a2 = self.alpha ** 2
        z2 = m[:, 2] ** 2
        up = m[:, 2] > 0
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if self.kind == "ggx":
                d = 1.0 / (math.pi * a2 * ((m[:, 0] ** 2 + m[:, 1] ** 2) / a2 + z2) ** 2)
            else:
                d = np.exp(-(m[:, 0] ** 2 + m[:, 1] ** 2) / (a2 * z2)) / (math.pi * a2 * z2 * z2)
        return np.where(up, np.nan_to_num(d, nan=0.0, posinf=0.0), 0.0)

    def lambda_(self, v: np.ndarray) -> np.ndarray:
        r"""Smith's Λ(v) as renderers compute it (GGX exact, Beckmann rational)."""
        t2 = self.alpha ** 2 * _tan2(v)
        if self.kind == "ggx":
            return 0.5 * (np.sqrt(1.0 + t2) - 1.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            a = 1.0 / np.sqrt(t2)
            lam = (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a)
        return np.where(a >= 1.6, 0.0, np.nan_to_num(lam, nan=0.0, posinf=np.inf))

    def lambda_exact(self, v: np.ndarray) -> np.ndarray:
        r"""Smith's Λ(v) in closed form (Beckmann: with erf, not the rational fit)."""
        if self.kind == "ggx":
            return self.lambda_(v)
        t2 = self.alpha ** 2 * _tan2(v)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            a = 1.0 / np.sqrt(t2)
            lam = 0.5 * (erf(a) - 1.0 + np.exp(-a * a) / (a * math.sqrt(math.pi)))
        return np.where(t2 == 0.0, 0.0, np.where(np.isinf(t2), np.inf, lam))

    def g1(self, v: np.ndarray, m: np.ndarray) -> np.ndarray:
        r"""Smith's masking :math:`G_1(v, m) = \chi^+(v\cdot m / v_z)/(1+\Lambda(v))`
        (zero where v sees the back of the microfacet)."""
        g = 1.0 / (1.0 + self.lambda_(v))
        back = np.einsum("ij,ij->i", v, m) * v[:, 2] <= 0.0
        return np.where(back, 0.0, g)

    def g_separable(self, wi: np.ndarray, wo: np.ndarray, m: np.ndarray) -> np.ndarray:
        """Separable shadowing-masking G1(wi, m)·G1(wo, m)."""
        return self.g1(wi, m) * self.g1(wo, m)

    def g_correlated(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Height-correlated shadowing-masking 1/(1 + Λ(wi) + Λ(wo))."""
        return 1.0 / (1.0 + self.lambda_(wi) + self.lambda_(wo))

    def visible_pdf(self, wi: np.ndarray, m: np.ndarray) -> np.ndarray:
        r"""Density of visible normals :math:`D_{\omega_i}(m)` (solid angle of m)."""
        cos_i = wi[:, 2]
        dot = np.einsum("ij,ij->i", wi, m)
        with np.errstate(divide="ignore", invalid="ignore"):
            p = self.g1(wi, m) * np.maximum(dot, 0.0) * self.D(m) / cos_i
        return np.where(cos_i > 0, p, 0.0)
