r"""The principled BSDF (Burley's "Disney BRDF") in its dielectric-and-metal reflection form —
a diffuse lobe with retro-reflection under a GGX specular lobe whose Fresnel blends the
dielectric's and a metal's — :class:`Principled`, with the interface of
:class:`~envfit.shading.microfacet.RoughPlastic` (``eval`` = f·cos θ_o, ``pdf``, ``sample``,
``sample_square``, :meth:`~Principled.lobe_probability`).

Local frame, z = the normal, ω_i towards the viewer, both above the surface; H the
normalised half vector of (ω_i, ω_o); D and G₁ the GGX distribution of
:math:`\alpha = \max(0.001, r^2)` (r the ``roughness``) and Smith's masking with χ⁺;
:math:`w(c) = (1 - c)^5` clamped (Schlick's weight); :math:`F_d` the dielectric Fresnel of
:math:`\eta = 2/(1 - \sqrt{0.08\,s}) - 1` (s the ``specular``) at ω_i·H
(:func:`~envfit.shading.microfacet.fresnel_dielectric`); c the grey ``base_color``, m the
``metallic``, t the ``spec_tint``; :math:`S(R_0, c) = R_0 + (1 - R_0)\,w(c)`:

.. math::
   f\cos\theta_o = F\,\frac{D(H)\,G_1(\omega_i,H)\,G_1(\omega_o,H)}{4\cos\theta_i}
   + (1 - m)\,\frac{c}{\pi}\cos\theta_o\,\big[(1 - \tfrac12 F_i)(1 - \tfrac12 F_o) + R_r
   (F_o + F_i + F_oF_i(R_r - 1))\big] + k\,(1 - m)\,w(\omega_o\cdot H)\cos\theta_o,

with :math:`F = (1 - m)(1 - t)F_d + m\,S(c, \omega_i\cdot H) + (1 - m)\,t\,S(R_0(\eta),
\omega_i\cdot H)` (the specular term only where :math:`F_d > 0` and ω_i·H, ω_o·H > 0),
:math:`F_i = w(\cos\theta_i)`, :math:`F_o = w(\cos\theta_o)`, :math:`R_r = 2r(\omega_o\cdot
H)^2` (retro-reflection), :math:`R_0(\eta) = ((\eta - 1)/(\eta + 1))^2`, k the ``sheen``
(its tint is 1 for a grey base). With ``flatness`` φ > 0 the bracket is lerped towards the
Hanrahan–Krueger "fake subsurface" :math:`1.25\,(F_{ss}(1/(\cos\theta_o + \cos\theta_i) -
\tfrac12) + \tfrac12)`, :math:`F_{ss} = (1 + (R_r/2 - 1)F_o)(1 + (R_r/2 - 1)F_i)`.

Sampling: the lobe by ``sample1``: the diffuse one when it is below
:math:`p_d = (1 - m)/(2 - m)` (the specular lobe's weight 1, the diffuse's 1 − m,
normalised; the same at every view), ω_o cosine-distributed by the concentric map; else the
specular one, ω_o = reflect(ω_i, n) with n a visible normal of the GGX lobe by the
``slope_space`` warp (:func:`~envfit.shading.microfacet.sample_visible_normals`), dead where
ω_i·n ≤ 0, ω_o·n ≤ 0 or ω_o below the surface. The density is the mixture

.. math:: p(\omega_o) = (1 - p_d)\,\frac{D(H)\,G_1(\omega_i,H)}{4\cos\theta_i} + p_d\,
   \frac{\cos\theta_o}{\pi},

the weight f·cos/p over both lobes.

Clear coat, specular transmission and anisotropy (the BSDF's other lobes) are not in this
class. Which renderer has this BSDF, read from which source (each step above by file and
function), its folder says (``envfit/renderers/<name>/_bsdf.py``).

Reference: B. Burley, "Physically-Based Shading at Disney", SIGGRAPH 2012 course notes;
"Extending the Disney BRDF to a BSDF with Integrated Subsurface Scattering", SIGGRAPH 2015.
"""
from __future__ import annotations

import math

import numpy as np

from envfit.base import ParameterError
from envfit.shading.microfacet._conductor import _dirs
from envfit.shading.microfacet._distributions import MicrofacetDistribution
from envfit.shading.microfacet._plastic import (PlasticSample, _half, cosine_directions,
                                               fresnel_dielectric, lobe_from_square,
                                               mixture_sample, split_lobe_numbers)
from envfit.shading.microfacet._vndf import sample_visible_normals

__all__ = ["Principled"]


def schlick_weight(c) -> np.ndarray:
    """w(c) = (1 − c)⁵ with 1 − c clamped to [0, 1]."""
    m = np.clip(1.0 - np.asarray(c, dtype=np.float64), 0.0, 1.0)
    return m ** 5


def _unit(value, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"the principled BSDF's {name} must be a number, got "
                             f"{value!r}") from None
    if not (math.isfinite(v) and 0.0 <= v <= 1.0):
        raise ParameterError(f"the principled BSDF's {name} must be in [0, 1], got {value!r}")
    return v


class Principled:
    r"""The principled BSDF's reflection lobes (module docstring), with the interface of
    :class:`~envfit.shading.microfacet.RoughPlastic`.

    Parameters
    ----------
    roughness : r in [0, 1] (default 0.5): α = max(0.001, r²), and the retro-reflection's R_r
    base_color : the grey base colour c (default 0.5)
    metallic, specular, spec_tint, sheen, sheen_tint, flatness : in [0, 1] (defaults 0, 0.5,
        0, 0, 0, 0); ``sheen_tint`` is accepted and changes nothing (a grey base's tint is 1)

    >>> p = Principled()
    >>> p.alpha, round(p.eta, 6), p.lobe_probability(np.array([0.3, 0.9])).tolist()
    (0.25, 1.5, [0.5, 0.5])
    >>> wi = np.array([[0.6, 0.0, 0.8]])
    >>> s = p.sample(wi, np.array([[0.7, 0.3, 0.6]]))          # columns: sample1, sample2
    >>> bool(s.specular[0]), bool(np.isclose(s.weight[0], p.eval(wi, s.wo)[0] / p.pdf(wi, s.wo)[0]))
    (True, True)
    """

    def __init__(self, roughness: float = 0.5, *, base_color: float = 0.5,
                 metallic: float = 0.0, specular: float = 0.5, spec_tint: float = 0.0,
                 sheen: float = 0.0, sheen_tint: float = 0.0, flatness: float = 0.0) -> None:
        values = dict(roughness=roughness, base_color=base_color, metallic=metallic,
                      specular=specular, spec_tint=spec_tint, sheen=sheen,
                      sheen_tint=sheen_tint, flatness=flatness)
        self.params = {k: _unit(v, k) for k, v in values.items()}
        for k, v in self.params.items():
            setattr(self, k, v)
        self.distribution = MicrofacetDistribution("ggx", max(0.001, self.roughness ** 2))
        self.eta = 2.0 / (1.0 - math.sqrt(0.08 * self.specular)) - 1.0
        if self.eta == 1.0:
            raise ParameterError("the principled BSDF's specular must be > 0 (0 is eta 1: no "
                                 "specular lobe)")
        self.vndf = "slope_space"

    def __repr__(self) -> str:
        rest = ", ".join(f"{k}={v:g}" for k, v in self.params.items() if k != "roughness")
        return f"Principled({self.roughness:g}, {rest})"

    @property
    def alpha(self) -> float:
        return self.distribution.alpha

    def lobe_probability(self, cos_theta_i) -> np.ndarray:
        """p_d = (1 − m)/(2 − m): the chance that ``sample1`` picks the diffuse lobe (the
        first: sample1 < p_d), the same at every view above the surface."""
        c = np.asarray(cos_theta_i, dtype=np.float64)
        m = self.metallic
        return np.full(c.shape, (1.0 - m) / (2.0 - m))

    def _D(self, h: np.ndarray) -> np.ndarray:  # noqa: N802
        """D(h), zeroed where D cos θ_h ≤ 1e-20."""
        d = self.distribution.D(h)
        return np.where(d * h[:, 2] > 1e-20, d, 0.0)

    def _schlick(self, r0: float, c: np.ndarray) -> np.ndarray:
        """S(R₀, c) = R₀ + (1 − R₀) w(|c|) (η > 1, seen from outside)."""
        w = schlick_weight(np.abs(c))
        return w * (1.0 - r0) + r0

    def fresnel(self, cos_ih: np.ndarray) -> np.ndarray:
        """F at ω_i·H = ``cos_ih``: the dielectric's, the metal's and the tinted Schlick blend
        (module docstring)."""
        m, t = self.metallic, self.spec_tint
        fd = fresnel_dielectric(cos_ih, self.eta)[0]
        r0 = ((self.eta - 1.0) / (self.eta + 1.0)) ** 2
        return ((1.0 - m) * (1.0 - t) * fd + m * self._schlick(self.base_color, cos_ih)
                + (1.0 - m) * t * self._schlick(r0, cos_ih)), fd

    def _diffuse(self, ci, co, cd) -> np.ndarray:
        """The diffuse lobe's f·cos θ_o over its weight (1 − m): c/π cos θ_o (diffuse +
        retro, or lerped to the fake subsurface), plus the sheen."""
        fo, fi = schlick_weight(co), schlick_weight(ci)
        rr = 2.0 * self.roughness * cd * cd
        lobe = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo) + rr * (fo + fi + fo * fi * (rr - 1.0))
        if self.flatness > 0.0:
            fss = (1.0 + (0.5 * rr - 1.0) * fo) * (1.0 + (0.5 * rr - 1.0) * fi)
            with np.errstate(divide="ignore", invalid="ignore"):
                ss = 1.25 * (fss * (1.0 / (co + ci) - 0.5) + 0.5)
            lobe = lobe + self.flatness * (ss - lobe)
        out = co * self.base_color / math.pi * lobe
        if self.sheen > 0.0:
            out = out + self.sheen * schlick_weight(np.abs(cd)) * co
        return out

    def eval(self, wi, wo) -> np.ndarray:
        """f(ω_i, ω_o)·cos θ_o (K,): the specular and the diffuse lobe."""
        wi, wo = _dirs(wi, "wi"), _dirs(wo, "wo")
        ci, co = wi[:, 2], wo[:, 2]
        ok = (ci > 0) & (co > 0)
        h = _half(wi, wo)
        cih, coh = np.einsum("ij,ij->i", wi, h), np.einsum("ij,ij->i", wo, h)
        f, fd = self.fresnel(cih)
        spec_on = (cih > 0) & (coh > 0) & (fd > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            spec = f * self._D(h) * self.distribution.g_separable(wi, wo, h) / (4.0 * ci)
        spec = np.where(spec_on, np.nan_to_num(spec), 0.0)
        diff = (1.0 - self.metallic) * self._diffuse(ci, co, coh) if self.metallic < 1 else 0.0
        return np.where(ok, spec + diff, 0.0)

    def pdf(self, wi, wo) -> np.ndarray:
        """The solid-angle density (K,) of ``sample``: the two lobes' mixture."""
        wi, wo = _dirs(wi, "wi"), _dirs(wo, "wo")
        ok = (wi[:, 2] > 0) & (wo[:, 2] > 0)
        h = _half(wi, wo)
        on = (np.einsum("ij,ij->i", wi, h) > 0) & (np.einsum("ij,ij->i", wo, h) > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            spec = self._D(h) * self.distribution.g1(wi, h) / (4.0 * wi[:, 2])
        pd = self.lobe_probability(wi[:, 2])
        p = (1.0 - pd) * np.where(on, np.nan_to_num(spec), 0.0) + pd * wo[:, 2] / math.pi
        return np.where(ok, p, 0.0)

    def sample(self, wi, u, u1=None) -> PlasticSample:
        """Draw ω_o for views ``wi`` (K, 3): the lobe, then the direction in it.

        ``u`` is (K, 3) (column 0 ``sample1``: the diffuse lobe where it is below
        :meth:`lobe_probability`; columns 1–2 ``sample2``), or (K, 2) ``sample2`` with ``u1``
        (K,) ``sample1``. ``specular`` in the result flags the specular lobe's samples."""
        wi = _dirs(wi, "wi")
        s1, s2 = split_lobe_numbers(u, u1)
        if len(s2) != len(wi):
            raise ParameterError(f"wi and u must have as many rows, got {len(wi)} and {len(s2)}")
        diffuse = s1 < self.lobe_probability(wi[:, 2])
        up = wi[:, 2] > 0
        d = self.distribution
        n = np.zeros((len(wi), 3))
        wo = np.zeros((len(wi), 3))
        spec = up & ~diffuse
        if np.any(spec):
            ws = wi[spec]
            n[spec] = sample_visible_normals(self.vndf, "ggx", d.alpha, ws, s2[spec])
            wo[spec] = 2.0 * np.einsum("ij,ij->i", ws, n[spec])[:, None] * n[spec] - ws
            dead = ((np.einsum("ij,ij->i", ws, n[spec]) <= 0)
                    | (np.einsum("ij,ij->i", wo[spec], n[spec]) <= 0))
            wo[np.flatnonzero(spec)[dead]] = (0.0, 0.0, -1.0)
        if np.any(diffuse):
            wo[diffuse] = cosine_directions(s2[diffuse])
        return mixture_sample(self, wi, wo, n, spec, dead=~up)

    def sample_square(self, wi, u) -> PlasticSample:
        r""":meth:`sample` driven by two uniform numbers: the lobe by :math:`u_x < p_d`, u_x
        rescaled within its lobe (the same distribution of (lobe, ω_o); the independent
        sampler's noise model, as :meth:`RoughPlastic.sample_square`)."""
        wi = _dirs(wi, "wi")
        return self.sample(wi, *lobe_from_square(u, self.lobe_probability(wi[:, 2])))
