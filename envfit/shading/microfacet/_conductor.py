r"""A rough conductor BSDF: one class, :class:`Conductor`, whose ``eval``, ``pdf`` and ``sample``
share one visible-normal warp, parameterised by its techniques — the shadowing-masking form,
the visible-normal warp, the Fresnel form and the multiple-scattering energy compensation.

Conventions: local frame, z = the normal; ``wi`` is the direction towards the viewer, ``wo``
the direction towards the light; ``eval`` returns f·cos θ_o. With m the half vector, F the
Fresnel factor at cos = ω_i·m, by the shadowing-masking form (:data:`SHADOWINGS`):

==================  =====================================  ===================================
``shadowing``       eval = f·cos θ_o                        pdf (visible normals)
==================  =====================================  ===================================
separable           F D G1(ω_i)G1(ω_o)/(4 cos θ_i)          D G1(ω_i)/(4 cos θ_i)
height_correlated   F D /(4 cos θ_i (1 + Λ_i + Λ_o))         D/(4 cos θ_i (1 + Λ_i))
==================  =====================================  ===================================

(the separable form's G1 with χ⁺, the pdf's view masking included), so the sample weight
f·cos/pdf is F·G1(ω_o, m) (separable) or F (1 + Λ_i)/(1 + Λ_i + Λ_o) (height-correlated).
The warp is one of :data:`~envfit.shading.microfacet.VNDF_WARPS`
(:func:`~envfit.shading.microfacet.sample_visible_normals`); the Fresnel form one of
:data:`~envfit.shading.microfacet.FRESNEL_FORMS` (used only with η + ik; without, F = 1);
``multiscatter`` scales eval and sample weight of a white GGX lobe by the inverse of its own
single-scatter albedo (:mod:`~envfit.shading.microfacet._multiscatter`).

Which renderer shades its conductor by which techniques, read from which source, its folder
says (``envfit/renderers/<name>/_bsdf.py``; the renderer object's
:meth:`~envfit.renderers.Renderer.bsdf` builds it).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envfit.base import ParameterError
from envfit.shading.microfacet._distributions import MicrofacetDistribution
from envfit.shading.microfacet._fresnel import (FRESNEL_FORMS, f82_average, f82_tint_b,
                                                fresnel_f82)
from envfit.shading.microfacet._vndf import VNDF_WARPS, sample_visible_normals

__all__ = ["BSDFSample", "Conductor", "SHADOWINGS"]

#: the shadowing-masking forms (module docstring): G2, the pdf's view masking and the weight
SHADOWINGS = ("separable", "height_correlated")


@dataclass(frozen=True)
class BSDFSample:
    """A batch of BSDF samples: directions ``wo`` (K, 3), their solid-angle ``pdf`` (K,),
    ``weight`` = f·cos/pdf (K,) (0 where the sample is invalid: below the surface), and the
    microfacet normals ``m`` (K, 3)."""

    wo: np.ndarray
    pdf: np.ndarray
    weight: np.ndarray
    m: np.ndarray


def _dirs(v, name: str) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64)
    if a.ndim < 1 or a.shape[-1] != 3:
        raise ParameterError(f"{name} must have shape (..., 3), got {a.shape}")
    return a.reshape(-1, 3)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


class Conductor:
    """A rough conductor (GGX or Beckmann) shaded by the techniques named.

    Parameters
    ----------
    distribution : "ggx" or "beckmann"
    alpha : the roughness α in [1e-4, 1]
    shadowing : a form of :data:`SHADOWINGS`: "separable" or "height_correlated"
    vndf : a visible-normal warp of :data:`~envfit.shading.microfacet.VNDF_WARPS`
        ("hemisphere_polar": GGX only)
    fresnel : a form of :data:`~envfit.shading.microfacet.FRESNEL_FORMS`, needed with
        ``eta`` and ``k``
    eta, k : the complex index of refraction η + ik; both None (default): F = 1 (white)
    f0, f82_tint : instead of η + ik, the artists' F82-tint Fresnel of reflectance f0 at
        normal incidence and tint (:func:`~envfit.shading.microfacet._fresnel.fresnel_f82`)
    multiscatter : eval and sample weight times :meth:`energy_scale` of the view, the inverse
        of the lobe's own single-scatter albedo (a GGX lobe, white or F82: then the energy
        its bounces' Fresnel keeps)

    >>> c = Conductor("ggx", 0.3, shadowing="separable", vndf="slope_space")
    >>> wi = np.array([[0.0, 0.0, 1.0]])
    >>> bool(np.isclose(c.eval(wi, wi)[0], c.pdf(wi, wi)[0] * 1.0))  # G1(normal) = 1
    True
    """

    def __init__(self, distribution: str, alpha: float, *, shadowing: str, vndf: str,
                 fresnel: str | None = None, eta: float | None = None, k: float | None = None,
                 f0: float | None = None, f82_tint: float = 1.0,
                 multiscatter: bool = False) -> None:
        _check_technique(distribution, shadowing, vndf)
        if (eta is None) != (k is None):
            raise ParameterError("give both eta and k (complex IOR) or neither (F = 1)")
        if eta is not None and fresnel not in FRESNEL_FORMS:
            raise ParameterError(f"a coloured conductor (eta, k) needs fresnel, one of "
                                 f"{tuple(FRESNEL_FORMS)}, got {fresnel!r}")
        if f0 is not None and (eta is not None or not (0.0 <= f0 <= 1.0 and 0.0 <= f82_tint)):
            raise ParameterError(f"the F82-tint Fresnel takes f0 in [0, 1] and a tint >= 0, "
                                 f"without eta and k; got f0 {f0!r}, tint {f82_tint!r}")
        if multiscatter and (distribution != "ggx" or eta is not None):
            raise ParameterError("multiscatter (energy compensation by the lobe's own albedo) "
                                 "is for a GGX conductor, white or F82 (no eta, k)")
        self.f0 = None if f0 is None else float(f0)
        self.f82_tint = float(f82_tint)
        self.f82_b = 0.0 if f0 is None else f82_tint_b(self.f0, self.f82_tint)
        self.multiscatter = bool(multiscatter)
        self.distribution = MicrofacetDistribution(distribution, alpha)
        self.shadowing, self.vndf, self.fresnel_form = shadowing, vndf, fresnel
        self.eta = None if eta is None else float(eta)
        self.k = None if k is None else float(k)

    def __repr__(self) -> str:
        d = self.distribution
        f82 = "" if self.f0 is None else f", f0={self.f0:g}, f82_tint={self.f82_tint:g}"
        return (f"Conductor({d.kind!r}, {d.alpha:g}, shadowing={self.shadowing!r}, "
                f"vndf={self.vndf!r}, fresnel={self.fresnel_form!r}, eta={self.eta}, "
                f"k={self.k}{f82}" + (", multiscatter=True)" if self.multiscatter else ")"))

    @property
    def white(self) -> bool:
        """Whether F ≡ 1 (no η + ik, no F82)."""
        return self.eta is None and self.f0 is None

    def energy_scale(self, cos_i) -> np.ndarray:
        """The multiple-scattering factor of eval and weight at view cosines ``cos_i``: 1/E of
        the lobe's single-scatter albedo E (:func:`~envfit.shading.microfacet.energy_scale`);
        1 without ``multiscatter``."""
        if not self.multiscatter:
            return np.ones(np.shape(cos_i))
        from envfit.shading.microfacet._multiscatter import energy_scale
        fss = 1.0 if self.f0 is None else f82_average(self.f0, self.f82_b)
        return energy_scale(self.alpha, cos_i, shadowing=self.shadowing, vndf=self.vndf,
                            fss=fss)

    @property
    def alpha(self) -> float:
        return self.distribution.alpha

    @property
    def separable_g(self) -> bool:
        """Whether G2 is separable and the pdf's view masking G1 with χ⁺, not height-correlated
        with 1/(1 + Λ_i)."""
        return self.shadowing == "separable"

    @property
    def vndf_variant(self) -> int:
        """The visible-normal warp's index in
        :data:`~envfit.shading.microfacet.VNDF_WARPS` (the compiled kernels' code)."""
        return VNDF_WARPS.index(self.vndf)

    def fresnel(self, cos_theta) -> np.ndarray:
        """F at cos θ = ω_i·m: 1, or the conductor Fresnel of :attr:`fresnel_form`."""
        c = np.asarray(cos_theta, dtype=np.float64)
        if self.f0 is not None:
            return fresnel_f82(c, self.f0, self.f82_b)
        if self.eta is None:
            return np.ones_like(c)
        return FRESNEL_FORMS[self.fresnel_form](c, self.eta, self.k)

    def shadowing_masking(self, wi, wo, m) -> np.ndarray:
        """G2: separable or height-correlated (:attr:`shadowing`)."""
        if self.separable_g:
            return self.distribution.g_separable(wi, wo, m)
        return self.distribution.g_correlated(wi, wo)

    def _g1_view(self, wi, m) -> np.ndarray:
        """The view's masking in the pdf: G1 (with χ⁺) where separable, else 1/(1 + Λ_i)."""
        if self.separable_g:
            return self.distribution.g1(wi, m)
        return 1.0 / (1.0 + self.distribution.lambda_(wi))

    def eval(self, wi, wo) -> np.ndarray:
        """f(ω_i, ω_o)·cos θ_o (K,) for view directions ``wi`` and light directions ``wo``."""
        wi, wo = _dirs(wi, "wi"), _dirs(wo, "wo")
        ci, co = wi[:, 2], wo[:, 2]
        ok = (ci > 0) & (co > 0)
        h = wi + wo
        n = np.linalg.norm(h, axis=1, keepdims=True)
        m = np.divide(h, n, out=np.zeros_like(h), where=n > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            v = (self.fresnel(_dot(wi, m)) * self.distribution.D(m)
                 * self.shadowing_masking(wi, wo, m) / (4.0 * ci))
        v = np.where(ok & (n[:, 0] > 0), np.nan_to_num(v), 0.0)
        return v * self.energy_scale(np.clip(ci, 0.0, 1.0)) if self.multiscatter else v

    def pdf(self, wi, wo) -> np.ndarray:
        """The solid-angle density (K,) of ``sample`` drawing ``wo`` for the view ``wi``."""
        wi, wo = _dirs(wi, "wi"), _dirs(wo, "wo")
        ci = wi[:, 2]
        h = wi + wo
        n = np.linalg.norm(h, axis=1, keepdims=True)
        m = np.divide(h, n, out=np.zeros_like(h), where=n > 0)
        ok = (ci > 0) & (wo[:, 2] > 0) & (_dot(wi, m) > 0) & (_dot(wo, m) > 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            p = self.distribution.D(m) * self._g1_view(wi, m) / (4.0 * ci)
        return np.where(ok, np.nan_to_num(p), 0.0)

    def weight_of_normal(self, wi: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For sampled normals m: the reflected ``wo`` and f·cos/pdf, in closed form (separable:
        F·G1(ω_o, m); height-correlated: F (1 + Λ_i)/(1 + Λ_i + Λ_o)); 0 below the surface."""
        dot = _dot(wi, m)
        wo = 2.0 * dot[:, None] * m - wi
        d = self.distribution
        if self.separable_g:
            w = d.g1(wo, m)
        else:
            li = d.lambda_(wi)
            w = (1.0 + li) / (1.0 + li + d.lambda_(wo))
        valid = (wo[:, 2] > 0) & (wi[:, 2] > 0) & (d.D(m) > 0)
        w = np.where(valid, self.fresnel(dot) * w, 0.0)
        return wo, (w * self.energy_scale(np.clip(wi[:, 2], 0.0, 1.0)) if self.multiscatter
                    else w)

    def sample(self, wi, u) -> BSDFSample:
        """Draw ``wo`` for views ``wi`` (K, 3) from points ``u`` (K, 2) of the unit square, by
        the conductor's visible-normal warp; pdf = D_{ω_i}(m)/(4 ω_o·m)."""
        wi = _dirs(wi, "wi")
        u = np.asarray(u, dtype=np.float64).reshape(-1, 2)
        if u.shape[0] != wi.shape[0]:
            raise ParameterError(f"wi and u must have as many rows, got {wi.shape[0]} and "
                                 f"{u.shape[0]}")
        d = self.distribution
        m = sample_visible_normals(self.vndf, d.kind, d.alpha, wi, u)
        wo, weight = self.weight_of_normal(wi, m)
        with np.errstate(divide="ignore", invalid="ignore"):
            pdf = d.D(m) * self._g1_view(wi, m) / (4.0 * wi[:, 2])
        pdf = np.where(weight > 0, np.nan_to_num(pdf), 0.0)
        return BSDFSample(wo=wo, pdf=pdf, weight=weight, m=m)


def _check_technique(distribution: str, shadowing: str, vndf: str) -> None:
    """One line where the shadowing form or the warp is unknown, or the warp has no form for
    the distribution (``hemisphere_polar``: GGX only)."""
    if shadowing not in SHADOWINGS:
        raise ParameterError(f"shadowing must be one of {SHADOWINGS}, got {shadowing!r}")
    if vndf not in VNDF_WARPS:
        raise ParameterError(f"visible-normal warp must be one of {VNDF_WARPS}, got {vndf!r}")
    if vndf == "hemisphere_polar" and distribution != "ggx":
        raise ParameterError("the hemisphere_polar visible-normal warp is GGX's only (Heitz "
                             f"2018), got {distribution!r}")
