r"""A rough plastic BSDF: a rough dielectric coating (GGX or Beckmann, relative index η) over a
Lambertian base, :class:`RoughPlastic`, with the interface of
:class:`~envfit.shading.microfacet.Conductor` (``eval`` = f·cos θ_o, ``pdf``, ``sample``).

Local frame, z = the normal, ω_i towards the viewer; with H = (ω_i + ω_o)/‖ω_i + ω_o‖, F(·)
the dielectric Fresnel of η = int_ior/ext_ior (:func:`fresnel_dielectric`), ρ_s, ρ_d the
specular and diffuse reflectances, separable shadowing-masking (G1 with χ⁺):

.. math::
   f\cos\theta_o = \rho_s\,\frac{F(\omega_i\cdot H)\,D(H)\,G_1(\omega_i,H)G_1(\omega_o,H)}
   {4\cos\theta_i} + \frac{\rho_d}{1 - R_i'}\,\frac{\cos\theta_o}{\pi\eta^2}\,T(\cos\theta_i)
   \,T(\cos\theta_o),

D(H) zeroed where D cos θ_H ≤ 10⁻²⁰, with :math:`R_i' = R_i` (``nonlinear`` false) or
:math:`\rho_d R_i` (true). T and R_i are *not* the smooth-interface Fresnel terms but
rough-interface integrals, tabulated when the BSDF is built (:func:`rough_fresnel_tables`):

* :math:`T(\mu)`: at 64 cosines :math:`\mu_j = \max(10^{-6}, j/63)` (float32),
  ω = (√(1−μ²), 0, μ), the average over visible normals m ~ :math:`D_\omega` of
  :math:`(1 - F(\omega\cdot m))\,G_1(\omega_t, m)` with ω_t the refraction of ω at m (zero
  unless ω_t is below the surface), by a Gauss–Legendre product rule on the unit square of the
  BSDF's visible-normal warp (32² nodes if η > 1, else 128²; nodes and weights rounded to
  float32); looked up by linear interpolation (x = 63 cos θ, index min(⌊x⌋, 62)).
* :math:`R_i` :math:`= 2\,\operatorname{mean}_j\,\mu_j R(\mu_j)` where :math:`R(\mu)` averages
  :math:`F_{1/\eta}(\omega\cdot m)\,G_1(\omega_r, m)` over visible normals (ω_r the mirror
  direction, zero below), with 128² nodes if 1/η ≤ 1.

Sampling (:meth:`RoughPlastic.sample`): the specular lobe with probability
:math:`p_s = \frac{(1 - T_i)\,w}{(1 - T_i)\,w + T_i\,(1 - w)}`, :math:`w = \bar\rho_s/(\bar\rho_d +
\bar\rho_s)` (from the reflectances' means) and :math:`T_i = T(\cos\theta_i)`, chosen when the
lobe number < p_s; then ω_o = reflect(ω_i, m), m by the visible-normal warp
(:func:`~envfit.shading.microfacet.sample_visible_normals`) or, ``sample_visible`` false, by
the D(m)cos θ_m warp. Otherwise ω_o is cosine-distributed by the concentric map. The density
is the mixture

.. math:: p(\omega_o) = p_s\,\frac{D(H)\,G_1(\omega_i,H)}{4\cos\theta_i} + (1 - p_s)\,
   \frac{\cos\theta_o}{\pi}

(``sample_visible`` false: :math:`D(H)\cos\theta_H/(4\,\omega_o\cdot H)` for the first term),
and the weight f·cos/p over both lobes (0 where p = 0, i.e. ω_o below the surface).

Which renderer has this BSDF, read from which source (each step above by file and function),
its folder says (``envfit/renderers/<name>/_bsdf.py``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from envfit.base import ParameterError
from envfit.shading.microfacet._conductor import BSDFSample, _dirs
from envfit.shading.microfacet._distributions import MicrofacetDistribution
from envfit.shading.microfacet._vndf import VNDF_WARPS, concentric_disk, sample_visible_normals

__all__ = ["PlasticSample", "RoughPlastic", "TRANSMITTANCE_RES", "fresnel_dielectric",
           "rough_fresnel_tables", "split_lobe_numbers", "lobe_from_square", "cosine_directions",
           "mixture_sample"]

#: cosines in the transmittance table
TRANSMITTANCE_RES = 64
_ROWS = 8                                     # table cosines integrated per numpy pass


def fresnel_dielectric(cos_theta_i, eta: float):
    r"""The unpolarised reflectance of a dielectric interface and the transmitted cosine.

    With :math:`\eta_{it} = \eta`, :math:`\eta_{ti} = 1/\eta` for cos θ_i ≥ 0 (else swapped),
    :math:`\cos^2\theta_t = 1 - (1 - \cos^2\theta_i)\eta_{ti}^2` (clamped at 0: total
    internal reflection gives F = 1), :math:`a_s = \frac{|c_i| - \eta_{it}c_t}{|c_i| +
    \eta_{it}c_t}`, :math:`a_p = \frac{c_t - \eta_{it}|c_i|}{c_t + \eta_{it}|c_i|}`,
    F = (a_s² + a_p²)/2; F = 0 if η = 1, F = 1 at cos θ_i = 0.

    Returns
    -------
    (F, cos θ_t, η_it, η_ti): arrays; cos θ_t has the sign opposite to cos θ_i.

    >>> f, ct, _, _ = fresnel_dielectric(np.array([1.0]), 1.5)
    >>> round(float(f[0]), 6), float(ct[0])
    (0.04, -1.0)
    """
    c = np.asarray(cos_theta_i, dtype=np.float64)
    outside = c >= 0.0
    eta_it = np.where(outside, eta, 1.0 / eta)
    eta_ti = np.where(outside, 1.0 / eta, eta)
    ci = np.abs(c)
    ct = np.sqrt(np.maximum(1.0 - (1.0 - c * c) * eta_ti * eta_ti, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        a_s = (ci - eta_it * ct) / (ci + eta_it * ct)
        a_p = (ct - eta_it * ci) / (ct + eta_it * ci)
    r = 0.5 * (a_s * a_s + a_p * a_p)
    if eta == 1.0:
        r = np.zeros_like(r)
    r = np.where(ci == 0.0, 0.0 if eta == 1.0 else 1.0, r)
    return r, np.copysign(ct, -c), eta_it, eta_ti


def _gauss_legendre_square(res: int) -> tuple[np.ndarray, np.ndarray]:
    """The nodes (res², 2) in [0, 1]² and weights (res²,) of the tables' product rule, rounded
    to float32 (Gauss–Legendre on [−1, 1], node·½ + ½)."""
    x, w = np.polynomial.legendre.leggauss(res)
    x32, w32 = x.astype(np.float32), w.astype(np.float32)
    node = x32 * np.float32(0.5) + np.float32(0.5)
    ux, uy = np.meshgrid(node, node)
    wx, wy = np.meshgrid(w32, w32)
    u = np.stack([ux.ravel(), uy.ravel()], axis=1).astype(np.float64)
    return u, ((wx * wy).ravel() * np.float32(0.25)).astype(np.float64)


def _rough_fresnel_integral(dist: MicrofacetDistribution, mu: np.ndarray, eta: float,
                            transmit: bool, vndf: str) -> np.ndarray:
    """The rough transmittance (``transmit``) or reflectance at cosines ``mu``, by the
    ``vndf`` warp."""
    u, w = _gauss_legendre_square(32 if eta > 1.0 else 128)
    out = np.empty(len(mu))
    for j in range(0, len(mu), _ROWS):
        rows = mu[j:j + _ROWS]
        wi1 = np.stack([np.sqrt(1.0 - rows * rows), np.zeros_like(rows), rows], axis=1)
        wi = np.repeat(wi1, len(u), axis=0)
        uu = np.tile(u, (len(rows), 1))
        m = sample_visible_normals(vndf, dist.kind, dist.alpha, wi, uu)
        dot = np.einsum("ij,ij->i", wi, m)
        f, cos_t, _, eta_ti = fresnel_dielectric(dot, eta)
        if transmit:
            wo = m * (dot * eta_ti + cos_t)[:, None] - wi * eta_ti[:, None]
            val = np.where(wo[:, 2] * wi[:, 2] >= 0.0, 0.0, dist.g1(wo, m) * (1.0 - f))
        else:
            wo = 2.0 * dot[:, None] * m - wi
            val = np.where((wo[:, 2] <= 0.0) | (wi[:, 2] <= 0.0), 0.0, dist.g1(wo, m) * f)
        out[j:j + _ROWS] = (val.reshape(len(rows), len(u)) * w).sum(axis=1)
    return out


@lru_cache(maxsize=32)
def rough_fresnel_tables(kind: str, alpha: float, eta: float,
                         vndf: str = "slope_space") -> tuple[np.ndarray, float]:
    """The coating's tables: the rough external transmittance T(μ_j) at
    μ_j = max(1e-6, j/63), j = 0…63 (read-only array), and the internal reflectance
    R_i = 2·mean_j(μ_j R_{1/η}(μ_j)), each by the ``vndf`` warp. Cached per (kind, α, η,
    warp).

    >>> t, ri = rough_fresnel_tables("ggx", 0.3, 1.49)
    >>> t.shape, round(float(t[-1]), 3), round(ri, 3)     # T(1) < 1 − F(1) = 0.96: rough
    ((64,), 0.954, 0.409)
    """
    dist = MicrofacetDistribution(kind, alpha)
    mu32 = np.maximum(np.float32(1e-6), np.linspace(0, 1, TRANSMITTANCE_RES, dtype=np.float32))
    mu = mu32.astype(np.float64)
    table = _rough_fresnel_integral(dist, mu, eta, True, vndf)
    table.setflags(write=False)
    internal = 2.0 * float(np.mean(_rough_fresnel_integral(dist, mu, 1.0 / eta, False, vndf)
                                   * mu))
    return table, internal


def _lerp_gather(table: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The table linearly interpolated at x ∈ [0, 1] (index min(⌊x·63⌋, 62))."""
    x = np.clip(x, 0.0, 1.0) * (len(table) - 1)
    idx = np.minimum(x.astype(np.int64), len(table) - 2)
    return table[idx] + (x - idx) * (table[idx + 1] - table[idx])


def _half(wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    h = wi + wo
    n = np.sqrt(np.einsum("ij,ij->i", h, h))[:, None]        # np.linalg.norm, 3x faster
    return np.divide(h, n, out=np.zeros_like(h), where=n > 0)


def _reflectance(value, name: str) -> float:
    try:
        r = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number, got {value!r}") from None
    if not (math.isfinite(r) and r >= 0.0):
        raise ParameterError(f"{name} must be finite and >= 0, got {value!r}")
    return r


def _normals_all(kind: str, alpha: float, u: np.ndarray) -> np.ndarray:
    """Sampling all normals (not the visible ones; isotropic): m ~ D(m)cos θ_m;
    φ = 2πu_y, Beckmann cos θ = (1 − α² ln(1 − u_x))^(−½), GGX tan²θ = α²u_x/(1 − u_x)."""
    phi = 2.0 * math.pi * u[:, 1]
    with np.errstate(divide="ignore"):
        if kind == "beckmann":
            cos_t = 1.0 / np.sqrt(1.0 - alpha * alpha * np.log(1.0 - u[:, 0]))
        else:
            cos_t = 1.0 / np.sqrt(1.0 + alpha * alpha * u[:, 0] / (1.0 - u[:, 0]))
    sin_t = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0))
    return np.stack([np.cos(phi) * sin_t, np.sin(phi) * sin_t, cos_t], axis=1)


def split_lobe_numbers(u, u1) -> tuple[np.ndarray, np.ndarray]:
    """(sample1 (K,), sample2 (K, 2)) of a two-lobe BSDF's ``sample``: ``u`` (K, 3), or ``u``
    (K, 2) with ``u1`` (K,)."""
    u = np.asarray(u, dtype=np.float64)
    if u1 is None:
        if u.ndim != 2 or u.shape[1] != 3:
            raise ParameterError(f"u must have shape (K, 3) (sample1, sample2) when u1 is "
                                 f"not given, got {u.shape}")
        return u[:, 0], u[:, 1:]
    if u.ndim != 2 or u.shape[1] != 2:
        raise ParameterError(f"u must have shape (K, 2) when u1 is given, got {u.shape}")
    u1 = np.asarray(u1, dtype=np.float64).reshape(-1)
    if len(u1) != len(u):
        raise ParameterError(f"u and u1 must have as many rows, got {len(u)} and {len(u1)}")
    return u1, u


def cosine_directions(u) -> np.ndarray:
    """Cosine-distributed directions (K, 3) of points ``u`` (K, 2): the concentric disk
    lifted to the hemisphere, z = √(1 − x² − y²)."""
    p = concentric_disk(u)
    return np.column_stack([p, np.sqrt(np.maximum(1.0 - (p * p).sum(axis=1), 0.0))])


def mixture_sample(bsdf, wi, wo, m, first, dead=None):
    """The :class:`PlasticSample` of a two-lobe ``bsdf`` whose lobes drew ``wo`` (K, 3) for
    views ``wi``: a non-finite direction (a warp's NaN on the square's edge) or one marked
    ``dead`` becomes a dead sample (the pole below: pdf and weight 0); pdf the mixture's,
    weight eval/pdf; ``m`` the sampled normal where ``first`` (K,) is the specular lobe, the
    half vector elsewhere."""
    bad = ~np.all(np.isfinite(wo), axis=1)
    if dead is not None:
        bad |= dead
    wo[bad] = (0.0, 0.0, -1.0)
    pdf = bsdf.pdf(wi, wo)
    with np.errstate(divide="ignore", invalid="ignore"):
        weight = np.where(pdf > 0, bsdf.eval(wi, wo) / pdf, 0.0)
    m = np.where(first[:, None], m, _half(wi, wo))
    return PlasticSample(wo=wo, pdf=pdf, weight=np.nan_to_num(weight), m=m, specular=first)


def lobe_from_square(u, p) -> tuple[np.ndarray, np.ndarray]:
    """(sample2 (K, 2), sample1 (K,)) of a two-lobe BSDF's ``sample`` from points ``u`` (K, 2)
    of the square: the first lobe (sample1 0) where u_x < p, else the second (1), u_x rescaled
    to [0, 1] within its lobe."""
    u = np.asarray(u, dtype=np.float64).reshape(-1, 2)
    first = u[:, 0] < p
    with np.errstate(divide="ignore", invalid="ignore"):
        x = np.where(first, u[:, 0] / p, (u[:, 0] - p) / (1.0 - p))
    return (np.column_stack([np.clip(np.nan_to_num(x), 0.0, 1.0), u[:, 1]]),
            np.where(first, 0.0, 1.0))


@dataclass(frozen=True)
class PlasticSample(BSDFSample):
    """A :class:`BSDFSample` that also says which lobe drew each sample: ``specular`` (K,) bool
    (the specular component); ``m`` is the sampled normal for specular samples, the
    half vector of (ω_i, ω_o) for diffuse ones."""

    specular: np.ndarray


class RoughPlastic:
    r"""A rough dielectric coating over a diffuse base (module docstring), with the interface
    of :class:`~envfit.shading.microfacet.Conductor`.

    Parameters
    ----------
    distribution : "beckmann" (default) or "ggx"
    alpha : the coating's roughness α in [1e-4, 1] (default 0.1)
    vndf : the visible-normal warp of the tables and the specular sampling, a name of
        :data:`~envfit.shading.microfacet.VNDF_WARPS` (default ``slope_space``)
    int_ior, ext_ior : the indices of refraction inside (polypropylene, 1.49) and outside (air,
        1.000277) the coating; η = int_ior/ext_ior
    diffuse_reflectance : the base's albedo ρ_d (default 0.5; envfit's white base: 1)
    specular_reflectance : the factor ρ_s on the specular term (1: physical)
    nonlinear : divide ρ_d by 1 − ρ_d R_i instead of 1 − R_i (internal scattering's colour shift)
    sample_visible : sample visible normals (default) or D(m)cos θ_m

    >>> p = RoughPlastic("ggx", 0.3, diffuse_reflectance=1.0)
    >>> wi = np.array([[0.6, 0.0, 0.8]])
    >>> s = p.sample(wi, np.array([[0.9, 0.3, 0.7]]))          # columns: sample1, sample2
    >>> bool(np.isclose(s.weight[0], p.eval(wi, s.wo)[0] / p.pdf(wi, s.wo)[0]))
    True
    """

    def __init__(self, distribution: str = "beckmann", alpha: float = 0.1, *,
                 vndf: str = "slope_space", int_ior: float = 1.49, ext_ior: float = 1.000277,
                 diffuse_reflectance: float = 0.5, specular_reflectance: float = 1.0,
                 nonlinear: bool = False, sample_visible: bool = True) -> None:
        if vndf not in VNDF_WARPS or (vndf == "hemisphere_polar" and distribution != "ggx"):
            raise ParameterError(f"vndf must be one of {VNDF_WARPS} (hemisphere_polar: GGX "
                                 f"only), got {vndf!r} for {distribution!r}")
        n_i, n_e = _reflectance(int_ior, "int_ior"), _reflectance(ext_ior, "ext_ior")
        if n_i <= 0.0 or n_e <= 0.0 or n_i == n_e:
            raise ParameterError(f"int_ior and ext_ior must be positive and differ, got "
                                 f"{int_ior!r} and {ext_ior!r}")
        self.distribution = MicrofacetDistribution(distribution, alpha)
        self.vndf = vndf
        self.eta = n_i / n_e
        self.diffuse_reflectance = _reflectance(diffuse_reflectance, "diffuse_reflectance")
        self.specular_reflectance = _reflectance(specular_reflectance, "specular_reflectance")
        if self.diffuse_reflectance + self.specular_reflectance == 0.0:
            raise ParameterError("diffuse_reflectance and specular_reflectance are both 0")
        self.nonlinear, self.sample_visible = bool(nonlinear), bool(sample_visible)
        s = self.specular_reflectance
        self.specular_sampling_weight = s / (self.diffuse_reflectance + s)
        self.transmittance_table, self.internal_reflectance = rough_fresnel_tables(
            self.distribution.kind, self.distribution.alpha, self.eta, vndf)

    def __repr__(self) -> str:
        d = self.distribution
        return (f"RoughPlastic({d.kind!r}, {d.alpha:g}, eta={self.eta:g}, "
                f"diffuse_reflectance={self.diffuse_reflectance:g}, "
                f"specular_reflectance={self.specular_reflectance:g}, "
                f"nonlinear={self.nonlinear}, sample_visible={self.sample_visible})")

    @property
    def alpha(self) -> float:
        return self.distribution.alpha

    def transmittance(self, cos_theta) -> np.ndarray:
        """T(cos θ): the rough coating's tabulated transmittance, interpolated."""
        return _lerp_gather(self.transmittance_table, np.asarray(cos_theta, dtype=np.float64))

    def prob_specular(self, cos_theta_i) -> np.ndarray:
        """p_s = (1 − T_i)w / ((1 − T_i)w + T_i(1 − w)), the specular lobe's sampling chance."""
        t = self.transmittance(cos_theta_i)
        w = self.specular_sampling_weight
        ps, pd = (1.0 - t) * w, t * (1.0 - w)
        return ps / (ps + pd)

    def lobe_probability(self, cos_theta_i) -> np.ndarray:
        """The chance that ``sample1`` picks the first lobe (sample1 below it): the specular
        one, :meth:`prob_specular` (a two-lobe BSDF's interface)."""
        return self.prob_specular(cos_theta_i)

    def _D(self, m: np.ndarray) -> np.ndarray:  # noqa: N802
        """D(m), zeroed where D cos θ_m ≤ 1e-20."""
        d = self.distribution.D(m)
        return np.where(d * m[:, 2] > 1e-20, d, 0.0)

    def _specular_pdf(self, wi: np.ndarray, wo: np.ndarray, h: np.ndarray) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.sample_visible:
                p = self._D(h) * self.distribution.g1(wi, h) / (4.0 * wi[:, 2])
            else:
                p = self._D(h) * h[:, 2] / (4.0 * np.einsum("ij,ij->i", wo, h))
        return np.nan_to_num(p)

    def eval(self, wi, wo) -> np.ndarray:
        """f(ω_i, ω_o)·cos θ_o (K,): the specular and the diffuse term."""
        wi, wo = _dirs(wi, "wi"), _dirs(wo, "wo")
        ci, co = wi[:, 2], wo[:, 2]
        ok = (ci > 0) & (co > 0)
        h = _half(wi, wo)
        f = fresnel_dielectric(np.einsum("ij,ij->i", wi, h), self.eta)[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            spec = (self.specular_reflectance * f * self._D(h)
                    * self.distribution.g_separable(wi, wo, h) / (4.0 * ci))
        rho = self.diffuse_reflectance
        ri = rho * self.internal_reflectance if self.nonlinear else self.internal_reflectance
        diff = (rho / (1.0 - ri) / math.pi / (self.eta * self.eta) * co
                * self.transmittance(ci) * self.transmittance(co))
        return np.where(ok, np.nan_to_num(spec) + diff, 0.0)

    def pdf(self, wi, wo) -> np.ndarray:
        """The solid-angle density (K,) of ``sample``: the two lobes' mixture."""
        wi, wo = _dirs(wi, "wi"), _dirs(wo, "wo")
        ok = (wi[:, 2] > 0) & (wo[:, 2] > 0)
        ps = self.prob_specular(wi[:, 2])
        p = ps * self._specular_pdf(wi, wo, _half(wi, wo)) + (1.0 - ps) * wo[:, 2] / math.pi
        return np.where(ok, p, 0.0)

    def sample(self, wi, u, u1=None) -> PlasticSample:
        """Draw ω_o for views ``wi`` (K, 3): the lobe, then the direction in it.

        ``u`` is (K, 3): column 0 is the lobe number ``sample1`` (specular where it is below
        :meth:`prob_specular`), columns 1–2 the direction's point ``sample2``. Alternatively
        ``u`` (K, 2) is ``sample2`` and ``u1`` (K,) is ``sample1``; a (K, 2) ``u`` without
        ``u1`` is an error (the lobe choice needs its own uniform number, a 1-D draw).
        pdf and weight are those of the mixture (:meth:`pdf`, :meth:`eval` / :meth:`pdf`).
        """
        wi = _dirs(wi, "wi")
        s1, s2 = split_lobe_numbers(u, u1)
        if len(s2) != len(wi):
            raise ParameterError(f"wi and u must have as many rows, got {len(wi)} and {len(s2)}")
        d = self.distribution
        spec = (wi[:, 2] > 0) & (s1 < self.prob_specular(wi[:, 2]))
        wo = np.zeros((len(wi), 3))
        m = np.zeros((len(wi), 3))
        if np.any(spec):                                  # each lobe's warp where it is drawn
            ws, us = wi[spec], s2[spec]
            m[spec] = (sample_visible_normals(self.vndf, d.kind, d.alpha, ws, us)
                       if self.sample_visible else _normals_all(d.kind, d.alpha, us))
            wo[spec] = 2.0 * np.einsum("ij,ij->i", ws, m[spec])[:, None] * m[spec] - ws
        if not np.all(spec):
            wo[~spec] = cosine_directions(s2[~spec])
        return mixture_sample(self, wi, wo, m, spec)

    def sample_square(self, wi, u) -> PlasticSample:
        r""":meth:`sample` driven by two uniform numbers instead of three: the lobe by
        :math:`u_x < p_s` and :math:`u_x` rescaled to [0, 1) within its lobe
        (:math:`u_x/p_s` or :math:`(u_x - p_s)/(1 - p_s)`) as ``sample2``'s first coordinate.

        The pair (lobe, ω_o) has the same distribution as :meth:`sample`'s (its lobe drawn from
        a third number, ``sample1``), so an estimator of i.i.d. samples has the same variance
        (the noise model of the independent sampler); a QMC point set's error is not the
        same, since a renderer's lobe dimension is a separate one.

        >>> p = RoughPlastic("ggx", 0.2)
        >>> wi = np.tile([0.0, 0.6, 0.8], (3, 1))
        >>> u = np.array([[0.01, 0.5], [0.99, 0.5], [0.5, 0.5]])
        >>> p.sample_square(wi, u).specular.tolist()     # p_s ≈ 0.097 at cos θ_i = 0.8
        [True, False, False]
        """
        wi = _dirs(wi, "wi")
        return self.sample(wi, *lobe_from_square(u, self.lobe_probability(wi[:, 2])))
