r"""A rough conductor BSDF as Mitsuba 3 ``roughconductor``, pbrt-v4 ``conductor`` and Cycles'
microfacet reflection closure (the Principled BSDF's metallic lobe) shade it: one class,
:class:`Conductor`, whose ``eval``, ``pdf`` and ``sample`` share one visible-normal warp.

Conventions (Mitsuba's): local frame, z = the normal; ``wi`` is the direction towards the
viewer (Mitsuba's and Cycles' ``wi``, pbrt's ``wo``), ``wo`` the direction towards the light;
``eval`` returns f·cos θ_o (as Mitsuba's ``eval``; pbrt's ``f`` times ``AbsDot(wi, n)``).
With m the half vector, F the Fresnel factor at cos = ω_i·m:

=========  =====================================  ===================================
renderer   eval = f·cos θ_o                        pdf (visible normals)
=========  =====================================  ===================================
mitsuba3   F D G1(ω_i)G1(ω_o)/(4 cos θ_i)          D G1(ω_i)/(4 cos θ_i)
pbrt4      F D /(4 cos θ_i (1 + Λ_i + Λ_o))         D/(4 cos θ_i (1 + Λ_i))
cycles     F D /(4 cos θ_i (1 + Λ_i + Λ_o))         D/(4 cos θ_i (1 + Λ_i))
=========  =====================================  ===================================

so the sample weight f·cos/pdf is F·G1(ω_o, m) in Mitsuba (``RoughConductor::sample``:
``weight = distr.smith_g1(bs.wo, m)`` times F) and F (1 + Λ_i)/(1 + Λ_i + Λ_o) in pbrt-v4 and
Cycles. Sources: Mitsuba ``src/bsdfs/roughconductor.cpp`` (``sample``, ``eval``, ``pdf``);
pbrt-v4 ``src/pbrt/bxdfs.h`` (``ConductorBxDF::Sample_f``, ``f``, ``PDF``); Cycles
``src/kernel/closure/bsdf_microfacet.h`` (``bsdf_microfacet_eval``, ``bsdf_microfacet_sample``).

Roughness conventions (:func:`roughness_to_alpha`): Mitsuba takes α itself; pbrt-v4 maps
``roughness`` to α = √roughness when ``remaproughness`` (the default;
``TrowbridgeReitzDistribution::RoughnessToAlpha``); Cycles' Principled BSDF sets
α = roughness² (``src/kernel/svm/closure.h``, ``alpha_x = sqr(roughness)``).

**Cycles' Multiscatter GGX** (:func:`energy_scale`, :func:`albedo_table`,
:func:`multiscatter_or_conductor`) — Cycles' *Multiscatter GGX* — the default distribution of
Blender's Principled BSDF and
Glossy BSDF nodes — as an energy scale on its single-scatter GGX.

Cycles 5.0 (``src/kernel/closure/bsdf_microfacet.h``: ``microfacet_ggx_preserve_energy``;
``src/kernel/svm/closure.h``: the Principled BSDF's metallic component and the Glossy BSDF
with ``CLOSURE_BSDF_MICROFACET_MULTI_GGX_ID``) sets up the single-scatter GGX closure and
multiplies both its ``eval`` and its sample weight by

.. math::  s(\mu_i) = 1 + \frac{1 - E}{E} = \frac1{E},\qquad
           E = \mathrm{lerp}_{2D}\big(\texttt{table\_ggx\_E};\ \sqrt\alpha,\ \mu_i\big),

:math:`\mu_i` = cos of the view angle, the table the single-scatter GGX albedo
:math:`E(r, \mu) = \int f\cos\theta_o\,d\omega_o` (F = 1) on the 32 × 32 nodes
:math:`r = \mathrm{clamp}(x/31, 10^{-4}, 1)`, :math:`\mu = \mathrm{clamp}(y/31, 10^{-4}, 1)`
(``src/app/cycles_precompute.cpp``: ``precompute_ggx_E``, the mean of the sample weight over
2²³ Sobol' points, clamped to [0, 1]), read by ``lookup_table_read_2D`` (``src/kernel/util/
lookup_table.h``: linear in μ between rows, linear in r within a row, indices truncated). For a
white metal (base colour and specular tint 1: F82-tint Fresnel ≡ 1, so Cycles' multi-bounce
Fresnel term is 1) this is the whole change; the pdf is the single-scatter one.

envfit computes the table itself (:func:`albedo_table`: the sample weight of
:class:`~envfit.shading.microfacet.Conductor` ``("ggx", r², "cycles")`` integrated over the
unit square by a 48 × 48 Gauss–Legendre rule on each of 4 × 4 panels; rules of 24–96 nodes
on 4–16 panels agree to 5 × 10⁻⁴, and so do its values and Cycles' own at the nodes read)
instead of copying Cycles' numbers; ``tests/test_multiscatter.py`` checks it against a
direction-space quadrature, and ``tests/test_render_cycles.py`` checks the result by
rendering: a white
Multiscatter GGX sphere under a constant map renders 1 at every view.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from envfit.base import ParameterError
from envfit.defaults import ADVISE_ALPHA
from envfit.shading.microfacet._distributions import MicrofacetDistribution
from envfit.shading.microfacet._fresnel import fr_complex, fresnel_conductor
from envfit.shading.microfacet._vndf import VNDF_RENDERERS, sample_visible_normals

__all__ = ["BSDFSample", "Conductor", "MICROFACET_RENDERERS", "roughness_to_alpha",
           "alpha_to_roughness", "roughness_range", "roughness_words", "ROUGHNESS_UNITS",
           "ROUGHNESS_RULES", "ROUGHNESS_RTOL", "TABLE_SIZE", "albedo_table", "energy_scale",
           "multiscatter_or_conductor"]

MICROFACET_RENDERERS = VNDF_RENDERERS


def roughness_to_alpha(roughness: float, renderer: str) -> float:
    """The microfacet α a renderer uses for a user-facing ``roughness``.

    mitsuba3: α = roughness (``alpha`` is given directly); pbrt4: α = √roughness (pbrt-v4's
    ``remaproughness`` default); cycles: α = roughness² (Principled BSDF).

    >>> roughness_to_alpha(0.25, "pbrt4"), roughness_to_alpha(0.5, "cycles")
    (0.5, 0.25)
    """
    try:
        r = float(roughness)
    except (TypeError, ValueError):
        raise ParameterError(f"roughness must be a number, got {roughness!r}") from None
    if not (math.isfinite(r) and 0.0 <= r <= 1.0):
        raise ParameterError(f"roughness must be in [0, 1], got {roughness!r}")
    if renderer == "mitsuba3":
        return r
    if renderer == "pbrt4":
        return math.sqrt(r)
    if renderer == "cycles":
        return r * r
    raise ParameterError(f"renderer must be one of {MICROFACET_RENDERERS}, got {renderer!r}")


#: each renderer's roughness R in words (:func:`roughness_to_alpha`)
ROUGHNESS_UNITS = {"mitsuba3": "Mitsuba 3's alpha",
                   "pbrt4": "pbrt-v4's roughness R, alpha = sqrt(R)",
                   "cycles": "Cycles' roughness R, alpha = R^2"}
#: each renderer's roughness R → alpha, as a rule in words
ROUGHNESS_RULES = {"mitsuba3": "alpha = R", "pbrt4": "alpha = sqrt(R)", "cycles": "alpha = R^2"}
#: the relative tolerance of a roughness at the end of its range (a bound typed rounded,
#: e.g. Cycles' sqrt(0.05) = 0.2236068, or pbrt-v4's 0.0025, whose alpha = sqrt(0.0025) is a
#: hair from 0.05 in floating point): within it the value is taken as the bound
ROUGHNESS_RTOL = 1e-6


def alpha_to_roughness(alpha: float, renderer: str) -> float:
    """The renderer's roughness for the microfacet α (:func:`roughness_to_alpha` inverted).

    >>> alpha_to_roughness(0.05, "pbrt4"), round(alpha_to_roughness(0.25, "cycles"), 12)
    (0.0025000000000000005, 0.5)
    """
    a = float(alpha)
    if renderer == "mitsuba3":
        return a
    if renderer == "pbrt4":
        return a * a
    if renderer == "cycles":
        return math.sqrt(a)
    raise ParameterError(f"renderer must be one of {MICROFACET_RENDERERS}, got {renderer!r}")


def roughness_range(renderer: str, alpha_range=ADVISE_ALPHA) -> tuple[float, float]:
    """The renderer's roughness range for ``alpha_range`` (default: the advice's,
    :data:`envfit.defaults.ADVISE_ALPHA`), the lower bound rounded up and the
    upper down to 6 significant digits (typed as printed, it is inside).

    >>> roughness_range("mitsuba3"), roughness_range("pbrt4"), roughness_range("cycles")
    ((0.05, 1.0), (0.0025, 1.0), (0.223607, 1.0))
    """
    lo, hi = (alpha_to_roughness(a, renderer) for a in alpha_range)
    return _round6(lo, math.ceil), _round6(hi, math.floor)


def roughness_words(renderer: str) -> str:
    """The renderer's roughness and its range (:func:`roughness_range`), as ``envfit advise
    --help`` and its error say it.

    >>> print(roughness_words("cycles"))
    Cycles' roughness R, alpha = R^2: 0.223607 to 1 (alpha 0.05 to 1)
    """
    lo, hi = roughness_range(renderer)
    return (f"{ROUGHNESS_UNITS[renderer]}: {lo:g} to {hi:g} (alpha {ADVISE_ALPHA[0]:g} to "
            f"{ADVISE_ALPHA[1]:g})")


def _round6(x: float, how) -> float:
    """``x`` to 6 significant digits, rounded by ``how`` (math.ceil or math.floor) unless it
    is within :data:`ROUGHNESS_RTOL` of the nearest 6-digit value."""
    if x <= 0:
        return x
    scale = 10.0 ** (5 - math.floor(math.log10(x)))
    near = round(x * scale) / scale
    return near if abs(near - x) <= ROUGHNESS_RTOL * x else how(x * scale) / scale


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
    """A rough conductor (GGX or Beckmann) shaded as ``renderer`` shades it.

    Parameters
    ----------
    distribution : "ggx" or "beckmann" (pbrt-v4: "ggx" only)
    alpha : the roughness α in [1e-4, 1] (see :func:`roughness_to_alpha`)
    renderer : "mitsuba3" (separable G), "pbrt4" or "cycles" (height-correlated G)
    eta, k : the complex index of refraction η + ik; both None (default): F = 1 (white)
    multiscatter : Cycles' Multiscatter GGX (the Principled and Glossy BSDF nodes' default):
        eval and sample weight times :func:`energy_scale` of the view (white
        GGX in Cycles only)

    >>> c = Conductor("ggx", 0.3)
    >>> wi = np.array([[0.0, 0.0, 1.0]])
    >>> bool(np.isclose(c.eval(wi, wi)[0], c.pdf(wi, wi)[0] * 1.0))  # G1(normal) = 1
    True
    """

    def __init__(self, distribution: str = "ggx", alpha: float = 0.1, renderer: str = "mitsuba3",
                 eta: float | None = None, k: float | None = None,
                 multiscatter: bool = False) -> None:
        if renderer not in MICROFACET_RENDERERS:
            raise ParameterError(f"renderer must be one of {MICROFACET_RENDERERS}, "
                                 f"got {renderer!r}")
        if renderer == "pbrt4" and distribution != "ggx":
            raise ParameterError("pbrt-v4's conductor has only the GGX (Trowbridge-Reitz) "
                                 f"distribution, got {distribution!r}")
        if (eta is None) != (k is None):
            raise ParameterError("give both eta and k (complex IOR) or neither (F = 1)")
        if multiscatter and (renderer != "cycles" or distribution != "ggx"
                             or eta is not None):
            raise ParameterError("multiscatter is Cycles' Multiscatter GGX: renderer cycles, "
                                 "distribution ggx, white (no eta, k)")
        self.multiscatter = bool(multiscatter)
        self.distribution = MicrofacetDistribution(distribution, alpha)
        self.renderer = renderer
        self.eta = None if eta is None else float(eta)
        self.k = None if k is None else float(k)

    def __repr__(self) -> str:
        d = self.distribution
        return (f"Conductor({d.kind!r}, {d.alpha:g}, renderer={self.renderer!r}, "
                f"eta={self.eta}, k={self.k}"
                + (", multiscatter=True)" if self.multiscatter else ")"))

    def energy_scale(self, cos_i) -> np.ndarray:
        """Cycles' Multiscatter GGX factor of eval and weight at view cosines ``cos_i``
        (1 for every other conductor)."""
        if not self.multiscatter:
            return np.ones(np.shape(cos_i))
        return energy_scale(self.alpha, cos_i)

    @property
    def alpha(self) -> float:
        return self.distribution.alpha

    @property
    def separable_g(self) -> bool:
        """Whether G2 is separable and the pdf's view masking Mitsuba's ``smith_g1`` (Mitsuba
        3), not height-correlated with 1/(1 + Λ_i) (pbrt-v4, Cycles)."""
        return self.renderer == "mitsuba3"

    @property
    def vndf_variant(self) -> int:
        """The renderer's visible-normal sampling routine: its index in
        :data:`~envfit.shading.microfacet._vndf.VNDF_RENDERERS` (that of
        :func:`~envfit.shading.microfacet._vndf.sample_visible_normals`)."""
        return VNDF_RENDERERS.index(self.renderer)

    def fresnel(self, cos_theta) -> np.ndarray:
        """F at cos θ = ω_i·m: 1, or the renderer's conductor Fresnel (pbrt: ``FrComplex``)."""
        c = np.asarray(cos_theta, dtype=np.float64)
        if self.eta is None:
            return np.ones_like(c)
        if self.renderer == "pbrt4":
            return fr_complex(c, self.eta, self.k)
        return fresnel_conductor(c, self.eta, self.k)

    def shadowing(self, wi, wo, m) -> np.ndarray:
        """G2: separable (Mitsuba) or height-correlated (pbrt-v4, Cycles)."""
        if self.separable_g:
            return self.distribution.g_separable(wi, wo, m)
        return self.distribution.g_correlated(wi, wo)

    def _g1_view(self, wi, m) -> np.ndarray:
        """The view's masking in the pdf: Mitsuba's ``smith_g1`` (with χ⁺), else 1/(1 + Λ_i)."""
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
                 * self.shadowing(wi, wo, m) / (4.0 * ci))
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
        """For sampled normals m: the reflected ``wo`` and f·cos/pdf, in closed form (Mitsuba:
        F·G1(ω_o, m); pbrt-v4, Cycles: F (1 + Λ_i)/(1 + Λ_i + Λ_o)); 0 below the surface."""
        dot = _dot(wi, m)
        wo = 2.0 * dot[:, None] * m - wi
        d = self.distribution
        if self.renderer == "mitsuba3":
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
        the renderer's visible-normal warp; pdf = D_{ω_i}(m)/(4 ω_o·m)."""
        wi = _dirs(wi, "wi")
        u = np.asarray(u, dtype=np.float64).reshape(-1, 2)
        if u.shape[0] != wi.shape[0]:
            raise ParameterError(f"wi and u must have as many rows, got {wi.shape[0]} and "
                                 f"{u.shape[0]}")
        d = self.distribution
        m = sample_visible_normals(self.renderer, d.kind, d.alpha, wi, u)
        wo, weight = self.weight_of_normal(wi, m)
        with np.errstate(divide="ignore", invalid="ignore"):
            pdf = d.D(m) * self._g1_view(wi, m) / (4.0 * wi[:, 2])
        pdf = np.where(weight > 0, np.nan_to_num(pdf), 0.0)
        return BSDFSample(wo=wo, pdf=pdf, weight=weight, m=m)


# ---- Cycles' Multiscatter GGX: the energy scale on its single-scatter GGX ----
#: nodes per axis of Cycles' ``table_ggx_E`` (roughness r = √α, then μ)
TABLE_SIZE = 32
_NODES, _PANELS = 48, 4


def _square_rule() -> tuple[np.ndarray, np.ndarray]:
    """Points (Q, 2) and weights (Q,) of a product Gauss–Legendre rule on the unit square,
    _PANELS × _PANELS panels of _NODES × _NODES nodes."""
    x, w = np.polynomial.legendre.leggauss(_NODES)
    x = ((x + 1.0) / 2.0 + np.arange(_PANELS)[:, None]).ravel() / _PANELS
    w = np.tile(w / (2.0 * _PANELS), _PANELS)
    u1, u2 = np.meshgrid(x, x, indexing="ij")
    return np.stack([u1.ravel(), u2.ravel()], axis=1), np.outer(w, w).ravel()


@lru_cache(maxsize=TABLE_SIZE)
def _column(x: int) -> np.ndarray:
    """E at the 32 μ nodes of roughness node x (one column of :func:`albedo_table`)."""
    pts, wts = _square_rule()
    grid = np.clip(np.arange(TABLE_SIZE) / (TABLE_SIZE - 1.0), 1e-4, 1.0)
    c = Conductor("ggx", max(float(grid[x]) ** 2, 1e-4), "cycles")
    out = np.empty(TABLE_SIZE)
    for y, mu in enumerate(grid):
        wi = np.broadcast_to([np.sqrt(1.0 - mu * mu), 0.0, mu], (len(pts), 3))
        out[y] = wts @ c.sample(wi, pts).weight
    out = np.clip(out, 0.0, 1.0)
    out.flags.writeable = False
    return out


def albedo_table() -> np.ndarray:
    r"""E[y, x]: the single-scatter GGX albedo of Cycles at :math:`\mu = \mathrm{clamp}(y/31,
    10^{-4}, 1)`, :math:`r = \sqrt\alpha = \mathrm{clamp}(x/31, 10^{-4}, 1)` (Cycles' layout:
    one row per μ), clamped to [0, 1] as Cycles' precompute does (α below 10⁻⁴, the first
    column only, is taken at 10⁻⁴, :class:`~envfit.shading.microfacet.Conductor`'s floor)."""
    return np.stack([_column(x) for x in range(TABLE_SIZE)], axis=1)


def _lerp_index(v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``lookup_table_read``'s (index, next index, t) for values ``v`` in [0, 1]."""
    x = np.clip(v, 0.0, 1.0) * (TABLE_SIZE - 1)
    i = np.minimum(x.astype(np.int64), TABLE_SIZE - 1)
    return i, np.minimum(i + 1, TABLE_SIZE - 1), x - i


def energy_scale(alpha: float, cos_i) -> np.ndarray:
    r"""Cycles' ``energy_scale`` = 1/E(√α, μ_i) of a white Multiscatter GGX, per view cosine
    (``lookup_table_read_2D`` of :func:`albedo_table`: linear in √α within each μ row, then
    linear in μ between the rows).

    >>> float(energy_scale(0.3 ** 2, 1.0)) > 1.0        # a rough lobe loses energy to G
    True
    """
    ix, jx, tx = _lerp_index(np.array(np.sqrt(alpha)))
    col = (1.0 - tx) * _column(int(ix)) + tx * _column(int(jx))        # E per μ row
    iy, jy, ty = _lerp_index(np.asarray(cos_i, dtype=np.float64))
    e = (1.0 - ty) * col[iy] + ty * col[jy]
    return np.where(e > 0, 1.0 / np.where(e > 0, e, 1.0), 0.0)


def multiscatter_or_conductor(bsdf: str, alpha: float, renderer: str):
    """The white conductor a ``--brdf`` name means: ``ggx``/``beckmann`` single scattering,
    ``multiggx`` Cycles' Multiscatter GGX (Cycles only: one-line ParameterError otherwise)."""
    if bsdf == "multiggx":
        if renderer != "cycles":
            raise ParameterError("--brdf multiggx is Cycles' Multiscatter GGX (the Principled "
                                 "and Glossy BSDF nodes' default): --renderer cycles")
        return Conductor("ggx", alpha, "cycles", multiscatter=True)
    return Conductor(bsdf, alpha, renderer=renderer)
