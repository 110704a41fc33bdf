r"""A rough dielectric specular layer over a Lambertian base, the base weighted by what the
layer's estimated albedo leaves — :class:`AlbedoLayered`, with the interface of
:class:`~envfit.shading.microfacet.RoughPlastic` (``eval`` = f·cos θ_o, ``pdf``, ``sample``,
``sample_square``, :meth:`~AlbedoLayered.lobe_probability`).

Local frame, z = the normal, ω_i towards the viewer, μ = cos θ_i; H the half vector; D, Λ the
GGX distribution of α and its Smith Λ; height-correlated shadowing-masking. The layer's
Fresnel is a Schlick-like blend driven by the real dielectric curve of η:

.. math::
   F(c) = f_0 + (1 - f_0)\,\mathrm{sat}\Big(\frac{F_\eta(c) - F_0(\eta)}{1 - F_0(\eta)}\Big),
   \qquad F_0(\eta) = \Big(\frac{\eta - 1}{\eta + 1}\Big)^2,

:math:`F_\eta` the unpolarised dielectric Fresnel
(:func:`~envfit.shading.microfacet.fresnel_dielectric`), :math:`f_0 = \mathrm{sat}(F_0 t)`
(t the specular tint, :math:`F_0` the reflectance at normal incidence: F(1) = f_0; at tint 1
F is the dielectric's own). With the multiple-scattering scale
:math:`s(\mu) = 1 + F_{ms}(1 - E)/E` of :func:`~envfit.shading.microfacet.energy_scale`
(E the white lobe's single-scatter albedo, :math:`F_{ss} = f_0 + (1 - f_0)\,\mathrm{sat}((\bar
F_\eta - F_0)/(1 - F_0))`, :math:`\bar F_\eta = (\eta - 1)/(4.08567 + 1.00071\eta)` — Kulla &
Conty's fit of the dielectric's hemispherical average),

.. math::
   f\cos\theta_o = s(\mu)\,\frac{F(\omega_i\cdot H)\,D(H)}{4\mu\,(1 + \Lambda_i + \Lambda_o)}
   + k_d(\mu)\,\frac{\cos\theta_o}{\pi},\qquad
   k_d(\mu) = c\;\mathrm{sat}\big(1 - a(\mu)\big),

c the grey base colour and :math:`a(\mu) = \big(f_0 + (1 - f_0)\,S(\sqrt\alpha, \mu, z)\big)\,
s(\mu)\,E(\mu)` the layer's albedo *estimate*: S the tabulated mean of the blend factor
:math:`\mathrm{sat}((F_\eta(\omega_i\cdot m) - F_0)/(1 - F_0))` over the lobe's sampled
normals m (0 where ω_o falls below the surface), at :math:`z = \sqrt{(\eta - 1)/(\eta + 1)}`
(:func:`blend_factor_table`: 16 × 16 × 16 nodes, read by :func:`blend_factor`).

Sampling: the specular lobe when the lobe number is below
:math:`p_s(\mu) = a/(a + k_d)` (each lobe in proportion to its estimated albedo), ω_o the
reflection of a visible normal of the lobe (the ``hemisphere_concentric`` warp), dead below
the surface; else a cosine-distributed ω_o by the concentric map. The density is the mixture
:math:`p_s\,D(H)/(4\mu(1 + \Lambda_i)) + (1 - p_s)\cos\theta_o/\pi`, the weight f·cos/p over
both lobes.

Which renderer has this BSDF, read from which source, its folder says
(``envfit/renderers/<name>/_bsdf.py``); the table is computed here by quadrature, as
:func:`~envfit.shading.microfacet.albedo_table` is.

References: C. Kulla, A. Conty, "Revisiting Physically Based Shading at Imageworks", SIGGRAPH
2017 course notes (the energy compensation and :math:`\bar F_\eta`); E. Heitz, "Sampling the
GGX distribution of visible normals", JCGT 7(4) (2018).
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from envfit.base import ParameterError
from envfit.shading.microfacet._conductor import Conductor, _dirs
from envfit.shading.microfacet._multiscatter import _square_rule, energy_scale
from envfit.shading.microfacet._plastic import (PlasticSample, _half, cosine_directions,
                                               fresnel_dielectric, lobe_from_square,
                                               mixture_sample, split_lobe_numbers)
from envfit.shading.microfacet._vndf import sample_visible_normals

__all__ = ["AlbedoLayered", "BLEND_TABLE_SIZE", "blend_factor", "blend_factor_table",
           "f0_of_ior", "ior_of_f0"]

#: nodes per axis of the blend-factor table (√α, μ, z)
BLEND_TABLE_SIZE = 16
_SHADOWING, _VNDF = "height_correlated", "hemisphere_concentric"


def f0_of_ior(eta: float) -> float:
    """F₀(η) = ((η − 1)/(η + 1))²."""
    return ((eta - 1.0) / (eta + 1.0)) ** 2


def ior_of_f0(f0: float) -> float:
    """η of a reflectance f₀ at normal incidence (f₀ clamped to [0, 0.99]):
    (1 + √f₀)/(1 − √f₀)."""
    s = math.sqrt(min(max(f0, 0.0), 0.99))
    return (1.0 + s) / (1.0 - s)


def _blend(cos_ih, eta: float) -> np.ndarray:
    """sat((F_η(c) − F₀)/(1 − F₀)): where the dielectric curve lies between F₀ and 1."""
    f0 = f0_of_ior(eta)
    f = fresnel_dielectric(np.asarray(cos_ih, dtype=np.float64), eta)[0]
    return np.clip((f - f0) / (1.0 - f0), 0.0, 1.0)


def _grid() -> np.ndarray:
    return np.arange(BLEND_TABLE_SIZE) / (BLEND_TABLE_SIZE - 1.0)


@lru_cache(maxsize=4 * BLEND_TABLE_SIZE ** 2)
def _column(x: int, zi: int) -> np.ndarray:
    """S at the 16 μ nodes of roughness node x and η node zi (one column of
    :func:`blend_factor_table`)."""
    pts, wts = _square_rule()
    g = _grid()
    r = float(np.clip(g[x], 1e-4, 1.0))
    z = float(np.clip(g[zi], 1e-4, 0.99))
    eta = ior_of_f0(z ** 4)
    lobe = Conductor("ggx", max(r * r, 1e-4), shadowing=_SHADOWING, vndf=_VNDF)
    out = np.empty(BLEND_TABLE_SIZE)
    for y, mu in enumerate(np.clip(g, 1e-4, 1.0)):
        wi = np.broadcast_to([math.sqrt(1.0 - mu * mu), 0.0, mu], (len(pts), 3))
        m = sample_visible_normals(_VNDF, "ggx", lobe.alpha, wi, pts)
        c = np.einsum("ij,ij->i", wi, m)
        alive = (2.0 * c * m[:, 2] - wi[:, 2]) >= 0.0
        out[y] = wts @ np.where(alive, _blend(c, eta), 0.0)
    out = np.clip(out, 0.0, 1.0)
    out.flags.writeable = False
    return out


def blend_factor_table() -> np.ndarray:
    r"""S[z, y, x]: the mean over the GGX lobe's sampled visible normals m (height-correlated,
    ``hemisphere_concentric`` warp, F ≡ 1) of the Fresnel blend factor
    :math:`\mathrm{sat}((F_\eta(\omega_i\cdot m) - F_0)/(1 - F_0))`, a normal whose reflection
    falls below the surface counting 0, at :math:`r = \sqrt\alpha = \mathrm{clamp}(x/15,
    10^{-4}, 1)`, :math:`\mu = \mathrm{clamp}(y/15, 10^{-4}, 1)` and
    :math:`\eta = (1 + z'^2)/(1 - z'^2)`, :math:`z' = \mathrm{clamp}(z/15, 10^{-4}, 0.99)`
    (F₀ = z'⁴), by the product Gauss–Legendre rule of
    :func:`~envfit.shading.microfacet.albedo_table` (48 × 48 nodes on each of 4 × 4 panels),
    clamped to [0, 1]. 16³ columns of the full table take minutes; :func:`blend_factor`
    computes the four it reads."""
    n = BLEND_TABLE_SIZE
    return np.stack([np.stack([_column(x, z) for x in range(n)], axis=1) for z in range(n)])


def _lerp_index(v) -> tuple[int, int, float]:
    x = min(max(float(v), 0.0), 1.0) * (BLEND_TABLE_SIZE - 1)
    i = min(int(x), BLEND_TABLE_SIZE - 1)
    return i, min(i + 1, BLEND_TABLE_SIZE - 1), x - i


def blend_factor(alpha: float, cos_i, eta: float) -> np.ndarray:
    """S(√α, μ, z(η)) read from :func:`blend_factor_table` as a 3-D lookup table is read:
    linear in √α within a row, linear in μ between rows, linear in z between slices, each
    index truncated (the four columns it needs computed on first use)."""
    ix, jx, tx = _lerp_index(math.sqrt(alpha))
    iz, jz, tz = _lerp_index(math.sqrt(abs((eta - 1.0) / (eta + 1.0))))

    def col(zi):
        return (1.0 - tx) * _column(ix, zi) + tx * _column(jx, zi)

    per_mu = (1.0 - tz) * col(iz) + tz * col(jz)                        # (16,) over μ
    y = np.clip(np.asarray(cos_i, dtype=np.float64), 0.0, 1.0) * (BLEND_TABLE_SIZE - 1)
    iy = np.minimum(y.astype(np.int64), BLEND_TABLE_SIZE - 1)
    jy = np.minimum(iy + 1, BLEND_TABLE_SIZE - 1)
    ty = y - iy
    return (1.0 - ty) * per_mu[iy] + ty * per_mu[jy]


def _unit_interval(value, name: str, upper: float | None = 1.0) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number, got {value!r}") from None
    if not (math.isfinite(v) and v >= 0.0 and (upper is None or v <= upper)):
        bound = f"in [0, {upper:g}]" if upper is not None else "finite and >= 0"
        raise ParameterError(f"{name} must be {bound}, got {value!r}")
    return v


class AlbedoLayered:
    r"""A rough dielectric specular layer over a Lambertian base (module docstring).

    Parameters
    ----------
    alpha : GGX α of the specular layer, in [1e-4, 1]
    base_color : the grey base colour c, in [0, 1] (default 0.8)
    eta : the layer's relative index η > 1 (default 1.5)
    f0 : the layer's reflectance at normal incidence f₀ = sat(F₀ t) (default F₀(η), tint 1)

    >>> b = AlbedoLayered(0.25)
    >>> round(b.f0, 6), [round(float(p), 3) for p in b.lobe_probability(np.array([0.2, 1.0]))]
    (0.04, [0.173, 0.046])
    >>> wi = np.array([[0.6, 0.0, 0.8]])
    >>> s = b.sample(wi, np.array([[0.01, 0.3, 0.6]]))         # columns: lobe number, square
    >>> bool(s.specular[0]), bool(np.isclose(s.weight[0], b.eval(wi, s.wo)[0] / b.pdf(wi, s.wo)[0]))
    (True, True)
    """

    def __init__(self, alpha: float, *, base_color: float = 0.8, eta: float = 1.5,
                 f0: float | None = None) -> None:
        a = _unit_interval(alpha, "the layer's alpha")
        if a < 1e-4:
            raise ParameterError(f"the layer's alpha must be >= 1e-4, got {alpha!r}")
        self.base_color = _unit_interval(base_color, "the base colour")
        self.eta = _unit_interval(eta, "the layer's eta", None)
        if not self.eta > 1.0:
            raise ParameterError(f"the layer's eta must be > 1 (eta 1 has no specular layer), "
                                 f"got {eta!r}")
        self.f0 = f0_of_ior(self.eta) if f0 is None else _unit_interval(f0, "the layer's f0")
        self.lobe = Conductor("ggx", a, shadowing=_SHADOWING, vndf=_VNDF)
        self.distribution, self.vndf = self.lobe.distribution, _VNDF
        f0r = f0_of_ior(self.eta)
        fbar = (self.eta - 1.0) / (4.08567 + 1.00071 * self.eta)
        self.fss = self.f0 + (1.0 - self.f0) * min(max((fbar - f0r) / (1.0 - f0r), 0.0), 1.0)
        self.params = {"alpha": a, "base_color": self.base_color, "eta": self.eta,
                       "f0": self.f0}

    def __repr__(self) -> str:
        return (f"AlbedoLayered({self.alpha:g}, base_color={self.base_color:g}, "
                f"eta={self.eta:g}, f0={self.f0:g})")

    @property
    def alpha(self) -> float:
        return self.distribution.alpha

    def fresnel(self, cos_ih) -> np.ndarray:
        """F at ω_i·H (module docstring)."""
        return self.f0 + (1.0 - self.f0) * _blend(cos_ih, self.eta)

    def scale(self, cos_i) -> np.ndarray:
        """The specular layer's multiple-scattering scale s(μ) = 1 + F_ms(1 − E)/E."""
        return energy_scale(self.alpha, np.clip(cos_i, 0.0, 1.0), shadowing=_SHADOWING,
                            vndf=_VNDF, fss=self.fss)

    def weights(self, cos_i) -> tuple[np.ndarray, np.ndarray]:
        """(a(μ), k_d(μ)): the layer's estimated albedo and the base's weight (module
        docstring) at view cosines ``cos_i``."""
        c = np.clip(np.asarray(cos_i, dtype=np.float64), 0.0, 1.0)
        inv_e = energy_scale(self.alpha, c, shadowing=_SHADOWING, vndf=_VNDF)   # 1/E
        darkening = np.divide(self.scale(c), inv_e, out=np.zeros_like(c), where=inv_e > 0)
        a = (self.f0 + (1.0 - self.f0) * blend_factor(self.alpha, c, self.eta)) * darkening
        return a, self.base_color * np.clip(1.0 - a, 0.0, 1.0)

    def lobe_probability(self, cos_theta_i) -> np.ndarray:
        """p_s(μ) = a/(a + k_d): the chance that the lobe number picks the specular layer
        (the first lobe: number < p_s)."""
        a, kd = self.weights(cos_theta_i)
        total = a + kd
        return np.divide(a, total, out=np.zeros_like(a), where=total > 0)

    def eval(self, wi, wo) -> np.ndarray:
        """f(ω_i, ω_o)·cos θ_o (K,): the specular layer and the base."""
        wi, wo = _dirs(wi, "wi"), _dirs(wo, "wo")
        ci, co = wi[:, 2], wo[:, 2]
        ok = (ci > 0) & (co > 0)
        h = _half(wi, wo)
        d = self.distribution
        with np.errstate(divide="ignore", invalid="ignore"):
            spec = (self.fresnel(np.einsum("ij,ij->i", wi, h)) * d.D(h)
                    / (4.0 * ci * (1.0 + d.lambda_(wi) + d.lambda_(wo))))
        spec = np.nan_to_num(spec) * self.scale(np.clip(ci, 0.0, 1.0))
        kd = self.weights(ci)[1]
        return np.where(ok, spec + kd * np.clip(co, 0.0, None) / math.pi, 0.0)

    def pdf(self, wi, wo) -> np.ndarray:
        """The solid-angle density (K,) of ``sample``: the two lobes' mixture."""
        wi, wo = _dirs(wi, "wi"), _dirs(wo, "wo")
        ok = (wi[:, 2] > 0) & (wo[:, 2] > 0)
        h = _half(wi, wo)
        d = self.distribution
        with np.errstate(divide="ignore", invalid="ignore"):
            spec = d.D(h) / (4.0 * wi[:, 2] * (1.0 + d.lambda_(wi)))
        ps = self.lobe_probability(wi[:, 2])
        p = ps * np.nan_to_num(spec) + (1.0 - ps) * wo[:, 2] / math.pi
        return np.where(ok, p, 0.0)

    def sample(self, wi, u, u1=None) -> PlasticSample:
        """Draw ω_o for views ``wi`` (K, 3): ``u`` (K, 3) (column 0 the lobe number: the
        specular layer where it is below :meth:`lobe_probability`; columns 1–2 the
        direction's), or (K, 2) with ``u1`` (K,) the lobe number."""
        wi = _dirs(wi, "wi")
        s1, s2 = split_lobe_numbers(u, u1)
        if len(s2) != len(wi):
            raise ParameterError(f"wi and u must have as many rows, got {len(wi)} and {len(s2)}")
        up = wi[:, 2] > 0
        spec = up & (s1 < self.lobe_probability(wi[:, 2]))
        n = np.zeros((len(wi), 3))
        wo = np.zeros((len(wi), 3))
        if np.any(spec):
            ws = wi[spec]
            n[spec] = sample_visible_normals(_VNDF, "ggx", self.alpha, ws, s2[spec])
            wo[spec] = 2.0 * np.einsum("ij,ij->i", ws, n[spec])[:, None] * n[spec] - ws
        diffuse = ~spec
        if np.any(diffuse):
            wo[diffuse] = cosine_directions(s2[diffuse])
        dead = ~up | (wo[:, 2] <= 0.0)
        return mixture_sample(self, wi, wo, n, spec, dead=dead)

    def sample_square(self, wi, u) -> PlasticSample:
        r""":meth:`sample` driven by two uniform numbers: the lobe by :math:`u_x < p_s`, u_x
        rescaled within its lobe (the same distribution of (lobe, ω_o))."""
        wi = _dirs(wi, "wi")
        return self.sample(wi, *lobe_from_square(u, self.lobe_probability(wi[:, 2])))
