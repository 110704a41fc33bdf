r"""Closed-form shading integrals of spherical caps and of the glossy lobe (Eq. 17), in the
map's local frame (z up): the ground truth of :mod:`envfit.data_gen._analytic`'s maps.

* :func:`glossy_normalisation` :math:`r_s = (1 - e^{-n})/n` (Eq. 18) and
  :func:`glossy_mean_cosine` :math:`\mu(n) = \frac{1}{1-e^{-n}} - \frac1n`, the normalised
  glossy integral of a linear map's direction (hemisphere cut included);
* :func:`diffuse_cap_integral`: the closed-form irradiance of a horizon-clipped cap
  (Snyder 1996, "Area light sources for real-time graphics"; the form used in Lagarde &
  de Rousiers 2014, "Moving Frostbite to PBR", Sec. 4.7), extended to ρ > π/2 by complement;
* :func:`glossy_cap_integral`: no elementary closed form (a von Mises–Fisher cap probability
  cut by the hemisphere), reduced *exactly* to a 1-D integral over t = u·a evaluated with
  ``scipy.integrate.quad``.

Each is checked against brute-force 2-D quadrature in tests/test_data_gen_analytic.py.

Example
-------
>>> float(diffuse_cap_integral(1.0, np.pi / 2))          # the hemisphere about n: sin²(π/2)·1
1.0
"""
from __future__ import annotations

import numpy as np

from envfit.data_gen._errors import SyntheticMapError

__all__ = ["direction", "diffuse_cap_integral", "glossy_cap_integral", "glossy_mean_cosine",
           "glossy_normalisation"]


def direction(theta, phi) -> np.ndarray:
    r"""Local unit vector(s) :math:`(\sin\theta\cos\varphi, \sin\theta\sin\varphi, \cos\theta)`, shape (…, 3)."""
    theta, phi = np.broadcast_arrays(np.asarray(theta, float), np.asarray(phi, float))
    st = np.sin(theta)
    return np.stack([st * np.cos(phi), st * np.sin(phi), np.cos(theta)], axis=-1)

def _angle(x, name: str, lo: float, hi: float, *, lo_open=True, hi_open=True) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise SyntheticMapError(f"{name} must be a number (radians), got {x!r}") from None
    ok = (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
    if not ok:
        br = ("(" if lo_open else "[") + f"{lo:g}, {hi:g}" + (")" if hi_open else "]")
        raise SyntheticMapError(f"{name} must lie in {br} (radians), got {x!r}")
    return v


def _axes(axes) -> tuple[np.ndarray, bool]:
    a = np.asarray(axes, dtype=np.float64)
    single = a.ndim == 1
    a = np.atleast_2d(a)
    if a.ndim != 2 or a.shape[1] != 3:
        raise SyntheticMapError(f"axes must have shape (3,) or (N, 3), got {np.shape(axes)}")
    if not np.all(np.isfinite(a)):
        raise SyntheticMapError("axes contain non-finite values")
    norm = np.linalg.norm(a, axis=1)
    if np.any(np.abs(norm - 1.0) > 1e-6):
        raise SyntheticMapError("axes must be unit vectors in the local frame (|a| = 1 within 1e-6)")
    return a / norm[:, None], single


def _shininess(n) -> float:
    try:
        v = float(n)
    except (TypeError, ValueError):
        raise SyntheticMapError(f"shininess must be a positive number, got {n!r}") from None
    if not (np.isfinite(v) and v > 0):
        raise SyntheticMapError(f"shininess must be a positive finite number, got {n!r}")
    return v


def glossy_normalisation(shininess: float) -> float:
    r""":math:`r_s = \frac{1}{2\pi}\int_{H_a} e^{n(u\cdot a-1)} dS = (1-e^{-n})/n` (Eq. 18)."""
    n = _shininess(shininess)
    return float(-np.expm1(-n) / n)


def glossy_mean_cosine(shininess: float) -> float:
    r""":math:`\mu(n) = \frac{1}{2\pi r_s}\int_{H_a} (u\cdot a)\,e^{n(u\cdot a-1)}\,dS = \frac{1}{1-e^{-n}} - \frac1n`.

    From :math:`\int_0^1 t e^{n(t-1)} dt = 1/n - (1-e^{-n})/n^2`. μ → 1/2 as n → 0 (uniform
    hemisphere) and → 1 as n → ∞; a series is used for n < 1e-3 (cancellation).

    >>> round(glossy_mean_cosine(1e-9), 9)
    0.5
    """
    n = _shininess(shininess)
    if n < 1e-3:
        return 0.5 + n / 12.0 - n ** 3 / 720.0
    return float(-1.0 / np.expm1(-n) - 1.0 / n)


def diffuse_cap_integral(cos_gamma, radius: float) -> np.ndarray:
    r"""Normalised diffuse integral of a cap's indicator: :math:`\frac1\pi\int_{cap(c,\rho)} \max(u\cdot n,0)\,dS`.

    ``cos_gamma`` = n·c (array), ``radius`` = ρ ∈ (0, π). Closed form:

    * γ + ρ ≤ π/2 (cap above the horizon of n): :math:`\sin^2\rho\cos\gamma`;
    * γ − ρ ≥ π/2 (below): 0;
    * otherwise (Snyder 1996), with :math:`x = \cot\rho`, :math:`y = -x\cot\gamma`:
      :math:`\frac1\pi[(\cos\gamma \arccos y - x\sin\gamma\sqrt{1-y^2})\sin^2\rho
      + \arctan(\sin\gamma\sqrt{1-y^2}/x)]`;
    * ρ > π/2: :math:`1 - D(-\cos\gamma, \pi-\rho)` (the complement cap about −c).

    >>> float(diffuse_cap_integral(0.0, np.pi / 2))     # hemisphere about c ⟂ n: half of it
    0.5
    """
    rho = _angle(radius, "cap radius", 0.0, np.pi)
    cg = np.clip(np.asarray(cos_gamma, dtype=np.float64), -1.0, 1.0)
    if rho > np.pi / 2:
        return 1.0 - diffuse_cap_integral(-cg, np.pi - rho)
    g = np.arccos(cg)
    sg = np.sqrt(np.maximum(1.0 - cg * cg, 0.0))
    s2 = np.sin(rho) ** 2
    x = np.cos(rho) / np.sin(rho)
    full = g + rho <= np.pi / 2
    none = g - rho >= np.pi / 2
    part = ~(full | none)
    out = np.where(full, s2 * cg, 0.0)
    if np.any(part):
        cgp, sgp = cg[part] if cg.ndim else cg, sg[part] if sg.ndim else sg
        y = np.clip(-x * cgp / sgp, -1.0, 1.0)
        r = np.sqrt(1.0 - y * y)
        e = (cgp * np.arccos(y) - x * sgp * r) * s2 + np.arctan2(sgp * r, x)
        if out.ndim:
            out[part] = e / np.pi
        else:
            out = np.asarray(e / np.pi)
    return out


def _cap_arc(t, cos_gamma: float, sin_gamma: float, cos_rho: float):
    r""":math:`2\psi(t)`: azimuthal length of the circle {u·a = t} inside the cap {u·c ≥ cos ρ}.

    On that circle :math:`u\cdot c = t\cos\gamma + \sqrt{1-t^2}\sin\gamma\cos\psi`.
    """
    t = np.asarray(t, dtype=np.float64)
    den = np.sqrt(np.maximum(1.0 - t * t, 0.0)) * sin_gamma
    with np.errstate(divide="ignore", invalid="ignore"):
        c = (cos_rho - t * cos_gamma) / den
    arc = 2.0 * np.arccos(np.clip(np.where(den > 1e-300, c, 0.0), -1.0, 1.0))
    degenerate = 2.0 * np.pi * (t * cos_gamma >= cos_rho)
    return np.where(den > 1e-300, arc, degenerate)


def glossy_cap_integral(axes, centre, radius: float, shininess: float) -> np.ndarray:
    r"""Normalised glossy integral of a cap's indicator about each axis a (Eq. 17).

    :math:`\frac{1}{2\pi r_s}\int_{cap(c,\rho)\cap\{u\cdot a>0\}} e^{n(u\cdot a-1)}\,dS
    = \frac{1}{2\pi r_s}\int_0^1 e^{n(t-1)}\,2\psi(t)\,dt`, an exact reduction (dS = dt dψ)
    evaluated with ``scipy.integrate.quad`` (epsabs 1e-15, epsrel 1e-12; break points at the
    tangencies t = cos(γ ± ρ) and near t = 1 − 1/n). One ``quad`` per axis (~ms).
    ``axes`` (3,) or (N, 3), ``centre`` a unit vector, all in the same frame.
    """
    from scipy import integrate  # local: scipy.integrate imports scipy.optimize, ~0.1 s

    a, single = _axes(axes)
    c, _ = _axes(centre)
    c = c[0]
    rho = _angle(radius, "cap radius", 0.0, np.pi)
    n = _shininess(shininess)
    rs = glossy_normalisation(n)
    cr = np.cos(rho)
    out = np.empty(a.shape[0])
    for k, ak in enumerate(a):
        cg = float(np.clip(ak @ c, -1.0, 1.0))
        g = np.arccos(cg)
        sg = np.sin(g)
        pts = [p for p in (np.cos(g + rho), np.cos(g - rho), 1.0 - 1.0 / n, 1.0 - 10.0 / n)
               if 1e-12 < p < 1.0 - 1e-12]
        val, _err = integrate.quad(lambda t: np.exp(n * (t - 1.0)) * _cap_arc(t, cg, sg, cr),
                                   0.0, 1.0, points=sorted(set(pts)) or None,
                                   epsabs=1e-15, epsrel=1e-12, limit=400)
        out[k] = val / (2.0 * np.pi * rs)
    return out[0] if single else out
