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

(η, k) = (0, 1) gives F ≡ 1 (a perfect mirror); envfit's conductors are white by default
(no η, k: F = 1, the map alone sets the error). Which renderer uses which form, read from
which source, its folder says (``envfit/renderers/<name>/_bsdf.py``).
"""
from __future__ import annotations

import numpy as np

__all__ = ["fr_complex", "fresnel_conductor", "FRESNEL_FORMS"]


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


#: the conductor Fresnel forms by name (module docstring) → F(cos θ, η, k)
FRESNEL_FORMS = {"moeller": fresnel_conductor, "complex": fr_complex}
