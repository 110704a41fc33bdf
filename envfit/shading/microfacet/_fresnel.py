r"""Unpolarised Fresnel reflectance of a conductor with complex index of refraction η + ik, in
two forms (:data:`FRESNEL_FORMS`; they agree to rounding):

* ``moeller`` — :func:`fresnel_conductor`, the real-arithmetic form (after K.D. Moeller,
  *Optics*): with :math:`t = \eta^2 - k^2 - \sin^2\theta`, :math:`a^2 + b^2 = \sqrt{t^2 +
  4\eta^2k^2}`, :math:`a = \sqrt{(a^2 + b^2 + t)/2}`,

  .. math:: R_s = \frac{a^2 + b^2 + \cos^2\theta - 2a\cos\theta}{a^2 + b^2 + \cos^2\theta +
     2a\cos\theta},\quad R_p = R_s\,\frac{(a^2 + b^2)\cos^2\theta + \sin^4\theta -
     2a\cos\theta\sin^2\theta}{(a^2 + b^2)\cos^2\theta + \sin^4\theta +
     2a\cos\theta\sin^2\theta},\quad F = \tfrac12(R_s + R_p);

* ``complex`` — :func:`fr_complex`, Snell's law in complex arithmetic with η̃ = η + ik,
  :math:`\cos\theta_t = \sqrt{1 - \sin^2\theta/\tilde\eta^2}`,
  :math:`r_\parallel = (\tilde\eta\cos\theta - \cos\theta_t)/(\tilde\eta\cos\theta +
  \cos\theta_t)`, :math:`r_\perp = (\cos\theta - \tilde\eta\cos\theta_t)/(\cos\theta +
  \tilde\eta\cos\theta_t)`, :math:`F = (|r_\parallel|^2 + |r_\perp|^2)/2`, cos θ clamped to
  [0, 1].

and the artists' **F82-tint** form (Kutz et al., "Novel aspects of the Adobe Standard
Material", 2021): Schlick's :math:`F_s = f_0 + (1 - f_0)(1 - \cos\theta)^5` less
:math:`b\cos\theta\,(1 - \cos\theta)^6`, clamped to [0, 1] (:func:`fresnel_f82`), b set so
that the value at cos θ = 1/7 is :math:`F_s` times the tint (:func:`f82_tint_b`; a tint of 1
is b = 0, Schlick's form), with its cosine-weighted hemispherical average
:math:`\bar F = f_0 + (1 - f_0)/21 - b/126` (:func:`f82_average`).

(η, k) = (0, 1) gives F ≡ 1 (a perfect mirror); envfit's conductors are white by default
(no η, k: F = 1, the map alone sets the error). Which renderer uses which form, read from
which source, its folder says (``envfit/renderers/<name>/_bsdf.py``).
"""
from __future__ import annotations

import numpy as np

__all__ = ["fr_complex", "fresnel_conductor", "FRESNEL_FORMS", "f82_average", "f82_tint_b",
           "fresnel_f82"]


def fresnel_conductor(cos_theta, eta: float, k: float) -> np.ndarray:
    """The ``moeller`` form F(cos θ, η + ik); cos θ ∈ [0, 1], any shape."""
    c = np.asarray(cos_theta, dtype=np.float64)
    c2 = c * c
    s2 = 1.0 - c2
    s4 = s2 * s2
    t1 = eta * eta - k * k - s2
    a2pb2 = np.sqrt(np.maximum(t1 * t1 + 4.0 * k * k * eta * eta, 0.0))
    a = np.sqrt(np.maximum(0.5 * (a2pb2 + t1), 0.0))
    term1 = a2pb2 + c2
    term2 = 2.0 * c * a
    rs = (term1 - term2) / (term1 + term2)
    term3 = a2pb2 * c2 + s4
    term4 = term2 * s2
    rp = rs * (term3 - term4) / (term3 + term4)
    return 0.5 * (rs + rp)


def fr_complex(cos_theta, eta: float, k: float) -> np.ndarray:
    """The ``complex`` form F(cos θ, η + ik); cos θ clamped to [0, 1], any shape."""
    c = np.clip(np.asarray(cos_theta, dtype=np.float64), 0.0, 1.0)
    e = complex(eta, k)
    sin2_t = (1.0 - c * c) / (e * e)
    cos_t = np.sqrt(1.0 - sin2_t + 0j)
    r_parl = (e * c - cos_t) / (e * c + cos_t)
    r_perp = (c - e * cos_t) / (c + e * cos_t)
    return 0.5 * (np.abs(r_parl) ** 2 + np.abs(r_perp) ** 2)


def fresnel_f82(cos_theta, f0: float, b: float) -> np.ndarray:
    """F82 at cos θ: clamp(f0 + (1 − f0)s⁵ − b cos θ s⁶, 0, 1), s = clamp(1 − cos θ, 0, 1)."""
    c = np.asarray(cos_theta, dtype=np.float64)
    s = np.clip(1.0 - c, 0.0, 1.0)
    s5 = s ** 5
    return np.clip(f0 + (1.0 - f0) * s5 - b * c * s5 * s, 0.0, 1.0)


def f82_tint_b(f0: float, tint: float) -> float:
    """b of the F82-tint form: F_s(1/7)·7/(f⁵·f)·(1 − tint), f = 6/7 (0 for a tint of 1)."""
    if tint == 1.0:
        return 0.0
    f = 6.0 / 7.0
    f5 = f ** 5
    return (f0 + (1.0 - f0) * f5) * (7.0 / (f5 * f)) * (1.0 - tint)


def f82_average(f0: float, b: float) -> float:
    """2∫F82(μ)μ dμ without the clamp: f0 + (1 − f0)/21 − b/126."""
    return f0 + (1.0 - f0) / 21.0 - b / 126.0


#: the conductor Fresnel forms by name (module docstring) → F(cos θ, η, k)
FRESNEL_FORMS = {"moeller": fresnel_conductor, "complex": fr_complex}
