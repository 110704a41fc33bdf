r"""Ground truth of the microfacet shading integral on a map, for any (normal, view):

.. math:: I(n, \omega_i) = \int_{H^2(n)} f(\omega_i, \omega_o)\,\cos\theta_o\,L(\omega_o)
   \,d\omega_o,

L the map's bilinear interpolant (:meth:`envfit.maps.EnvMap.lookup`) or any callable of
directions, f·cos the BSDF's ``eval`` (:class:`~envfit.shading.microfacet.Conductor`).

The change of variables to the microfacet normal, ω_o = 2(ω_i·m)m − ω_i,
dω_o = 4(ω_o·m) dω_m, and to its slope :math:`\tilde x = -m_{xy}/m_z = \alpha\,t`
(:math:`D(m)\cos\theta_m\,d\omega_m = P_{22}(\tilde x)\,d^2\tilde x`) gives

.. math:: I = \int_{\mathbb R^2} p(t)\;\frac{F\,G_2\,(\omega_i\cdot m)}{\cos\theta_i\,\cos\theta_m}
   \,L(\omega_o)\,d^2t,\qquad p(t) = \frac{1}{\pi(1 + |t|^2)^2}\ (\text{GGX}),\
   \frac{e^{-|t|^2}}{\pi}\ (\text{Beckmann}),

and the radial CDF of p, :math:`v = \rho^2/(1+\rho^2)` (GGX) or :math:`1 - e^{-\rho^2}`
(Beckmann), maps it to the unit square (v, φ/2π) with unit density. The integrand is then
bounded and as smooth as L: the lobe's peak, however narrow (α = 0.05 is narrower than a pixel
of a 1024×512 map), is spread over the whole square. It is integrated by a Gauss–Legendre
rule in v times the periodic trapezoid rule in φ (2n nodes), n per axis.

**Resolution rule.** n starts from the lobe's footprint on the map: the angle
:math:`\Delta = 4\arctan(\rho_{.99}\,\alpha)` spanned by 99 % of the normals' mass, in pixels
of the map (π/H rad each), times ``nodes_per_pixel``; then n doubles until two successive
values agree to ``rtol`` (relative to the largest channel) or n reaches ``max_nodes``
(``converged`` False). Between kinks of the bilinear interpolant the rule converges
geometrically; across them as O(n⁻²), so the doubling test over-estimates the error by ~3×.
On a 1024×512 HDR map a GGX lobe's long tail crosses hundreds of pixel kinks: at α = 0.05
the default ``max_nodes`` = 1024 stops at a relative change of ~2e-4, at α = 0.3 ~3e-3
(Beckmann, with no tail, converges at n ≈ 140) — read ``converged`` and ``change``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from envfit.base import ParameterError
from envfit.maps import EnvMap

__all__ = ["GroundTruthOptions", "MicrofacetShading", "microfacet_shading_integral"]

_CHUNK = 1 << 17     # quadrature nodes per block (memory: ~100 bytes each)


@dataclass(frozen=True)
class GroundTruthOptions:
    """The resolution rule: relative tolerance ``rtol`` of two successive doublings, the
    starting density ``nodes_per_pixel`` (nodes per map pixel across the lobe), and the bounds
    ``min_nodes``, ``max_nodes`` of n (Gauss nodes in v; 2n trapezoid nodes in φ)."""

    rtol: float = 1e-5
    nodes_per_pixel: float = 1.0
    min_nodes: int = 16
    max_nodes: int = 1024

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rtol) and self.rtol > 0):
            raise ParameterError(f"rtol must be a finite number > 0, got {self.rtol!r}")
        if not (math.isfinite(self.nodes_per_pixel) and self.nodes_per_pixel > 0):
            raise ParameterError(f"nodes_per_pixel must be > 0, got {self.nodes_per_pixel!r}")
        if not (2 <= self.min_nodes <= self.max_nodes):
            raise ParameterError(f"need 2 <= min_nodes <= max_nodes, got {self.min_nodes}, "
                                 f"{self.max_nodes}")


@dataclass(frozen=True)
class MicrofacetShading:
    """Ground-truth shading integrals: ``values`` (K, C); per frame the final ``nodes`` n, the
    last relative ``change`` between doublings and whether it ``converged`` (≤ rtol)."""

    values: np.ndarray
    nodes: np.ndarray
    change: np.ndarray
    converged: np.ndarray = field(repr=False)


def _frames(normals, views) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal frames (K, 3, 3) (rows t, b, n) and the local views (K, 3)."""
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    v = np.asarray(views, dtype=np.float64).reshape(-1, 3)
    if n.shape != v.shape:
        raise ParameterError(f"normals and views must have the same shape, got {n.shape}, "
                             f"{v.shape}")
    for name, a in (("normals", n), ("views", v)):
        norm = np.linalg.norm(a, axis=1)
        if not np.all(np.isfinite(a)) or np.any(norm == 0):
            raise ParameterError(f"{name} must be finite non-zero 3-vectors")
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    v = v / np.linalg.norm(v, axis=1, keepdims=True)
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t = np.cross(helper, n)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    b = np.cross(n, t)
    frames = np.stack([t, b, n], axis=1)
    return frames, np.einsum("kij,kj->ki", frames, v)


def _radial(kind: str, v: np.ndarray) -> np.ndarray:
    """ρ(v): the inverse radial CDF of p(t)."""
    if kind == "ggx":
        return np.sqrt(v / (1.0 - v))
    return np.sqrt(-np.log1p(-v))


def _start_nodes(bsdf, height: int | None, opts: GroundTruthOptions) -> int:
    """n from the lobe's footprint in map pixels (``min_nodes`` for a callable), leaving room
    for one doubling below ``max_nodes``."""
    n = opts.min_nodes
    if height is not None:
        rho = _radial(bsdf.distribution.kind, np.array([0.99]))[0]
        span = 4.0 * math.atan(rho * bsdf.alpha)
        n = max(n, math.ceil(opts.nodes_per_pixel * span / (math.pi / height)))
    return int(max(min(n, opts.max_nodes // 2), 1))


def _rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights on [0, 1]."""
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


def _panels(kind: str, alpha: float, wi: np.ndarray) -> list[tuple[float, float, bool]]:
    r"""The v panels (v_a, v_b, full ring?) of the lobe's support.

    On the ring |t| = ρ, ω_o is above the surface iff cos(φ − φ_i) < K(ρ) =
    cos θ_i (1 − α²ρ²)/(2αρ sin θ_i): the whole ring for ρ ≤ ρ₁ = (1 − sin θ_i)/(α cos θ_i),
    an arc about φ_i + π for ρ₁ < ρ < ρ₂ = (1 + sin θ_i)/(α cos θ_i), nothing beyond — so the
    horizon's kink falls on panel and arc ends, never inside a rule."""
    s = math.hypot(wi[0], wi[1])
    z = wi[2]
    if kind == "ggx":
        def to_v(r):
            return r * r / (1.0 + r * r)
    else:
        def to_v(r):
            return -math.expm1(-r * r)
    cap = 1e7 if kind == "ggx" else 6.0          # Beckmann: e^{-36} ≈ 2e-16 of the mass beyond
    v1 = to_v(min((1.0 - s) / (alpha * z), cap))
    out = [(0.0, v1, True)] if v1 > 0 else []
    if s > 1e-12 and v1 < to_v(cap):
        out.append((v1, to_v(min((1.0 + s) / (alpha * z), cap)), False))
    return out


def _ring_angles(alpha: float, wi: np.ndarray, rho: np.ndarray, n: int):
    """Angles (R, 2n) and weights (R, 2n) (summing to the arc's share of 1) on the rings ρ."""
    s = math.hypot(wi[0], wi[1])
    k = wi[2] * (1.0 - (alpha * rho) ** 2) / (2.0 * alpha * rho * max(s, 1e-300))
    half = np.arccos(np.clip(-k, -1.0, 1.0))
    x, w = np.polynomial.legendre.leggauss(2 * n)
    phi = math.atan2(wi[1], wi[0]) + math.pi + half[:, None] * x
    return phi, half[:, None] * w / (2.0 * math.pi)


def _integrand_rows(bsdf, radiance, frame, wi, rho, phi, wphi) -> np.ndarray:
    """Σ over the ring nodes of weight × integrand at the radii ``rho`` (R,) → (R, C)."""
    r = (bsdf.alpha * rho)[:, None]
    phi = np.broadcast_to(phi, (len(rho), phi.shape[-1]))
    m = np.stack(np.broadcast_arrays(-r * np.cos(phi), -r * np.sin(phi), 1.0), axis=-1)
    m = (m / np.sqrt(1.0 + r * r)[..., None]).reshape(-1, 3)
    wis = np.broadcast_to(wi, m.shape)
    wo, w = _transfer(bsdf, wis, m)
    w = w * np.broadcast_to(wphi, phi.shape).ravel()
    live = w != 0
    out = np.zeros((m.shape[0], _channels(radiance)))
    if live.any():
        out[live] = w[live, None] * np.asarray(radiance(wo[live] @ frame), dtype=np.float64)
    return out.reshape(phi.shape[0], phi.shape[1], -1).sum(axis=1)


def _transfer(bsdf, wi: np.ndarray, m: np.ndarray):
    """ω_o(m) and F G2 (ω_i·m)/(cos θ_i cos θ_m) (0 where ω_o is below the surface)."""
    dot = np.einsum("ij,ij->i", wi, m)
    wo = 2.0 * dot[:, None] * m - wi
    ok = (dot > 0) & (wo[:, 2] > 0)
    g2 = bsdf.shadowing_masking(wi, wo, m)
    w = bsdf.fresnel(dot) * g2 * dot / (wi[:, 2] * m[:, 2])
    return wo, np.where(ok, w, 0.0)


def _channels(radiance) -> int:
    return int(getattr(radiance, "channels_", 1))


def _integral(bsdf, radiance, frame, wi, n: int) -> np.ndarray:
    """The product rule with n Gauss nodes per v panel and 2n per ring."""
    kind, alpha = bsdf.distribution.kind, bsdf.alpha
    x, wx = _rule(n)
    rows = max(1, _CHUNK // (2 * n))
    total = np.zeros(_channels(radiance))
    full_phi = 2.0 * math.pi * (np.arange(2 * n) + 0.5) / (2 * n)
    full_w = np.full(2 * n, 1.0 / (2 * n))
    for va, vb, full in _panels(kind, alpha, wi):
        v, wv = va + (vb - va) * x, (vb - va) * wx
        rho = _radial(kind, v)
        for s in range(0, n, rows):
            sl = slice(s, s + rows)
            phi, wphi = (full_phi, full_w) if full else _ring_angles(alpha, wi, rho[sl], n)
            total += wv[sl] @ _integrand_rows(bsdf, radiance, frame, wi, rho[sl], phi, wphi)
    return total


class _Radiance:
    """A map (bilinear lookup) or a callable, as dirs (M, 3) → (M, C)."""

    def __init__(self, radiance, probe: np.ndarray) -> None:
        if isinstance(radiance, EnvMap):
            self.fn: Callable = radiance.lookup
            self.height = radiance.height
        elif callable(radiance):
            self.fn = radiance
            self.height = None
        else:
            raise ParameterError("radiance must be an EnvMap or a callable of directions")
        out = np.asarray(self.fn(probe), dtype=np.float64)
        self.channels_ = 1 if out.ndim == 1 else out.shape[-1]

    def __call__(self, dirs: np.ndarray) -> np.ndarray:
        out = np.asarray(self.fn(dirs), dtype=np.float64)
        return out.reshape(len(dirs), self.channels_)


def microfacet_shading_integral(radiance, bsdf, normals, views,
                                options: GroundTruthOptions | None = None) -> MicrofacetShading:
    r"""Exact :math:`\int f(\omega_i, \omega_o)\cos\theta_o L(\omega_o)\,d\omega_o` per frame.

    Parameters
    ----------
    radiance : EnvMap (its bilinear interpolant) or a callable dirs (M, 3) → (M,) or (M, C)
        (for a callable, n starts at ``min_nodes``)
    bsdf : a :class:`~envfit.shading.microfacet.Conductor` (its G and Fresnel)
    normals, views : (K, 3) world directions: the surface normals and the directions to the
        viewer (ω_i); frames with views below the surface give 0
    options : :class:`GroundTruthOptions` (the resolution rule)

    Returns
    -------
    :class:`MicrofacetShading`
    """
    opts = options or GroundTruthOptions()
    frames, wis = _frames(normals, views)
    rad = _Radiance(radiance, np.array([[0.0, 0.0, 1.0]]))
    n0 = _start_nodes(bsdf, rad.height, opts)
    k = len(frames)
    values = np.zeros((k, rad.channels_))
    nodes = np.zeros(k, dtype=np.int64)
    change = np.zeros(k)
    for i in range(k):
        if wis[i, 2] <= 0:
            continue
        values[i], nodes[i], change[i] = _converge(bsdf, rad, frames[i], wis[i], n0, opts)
    return MicrofacetShading(values=values, nodes=nodes, change=change,
                             converged=change <= opts.rtol)


def _converge(bsdf, rad, frame, wi, n: int, opts: GroundTruthOptions):
    """Double n until two successive values agree to rtol (or n reaches max_nodes)."""
    prev = _integral(bsdf, rad, frame, wi, n)
    rel = math.inf
    while True:
        n2 = min(2 * n, opts.max_nodes)
        if n2 == n:
            return prev, n, rel
        cur = _integral(bsdf, rad, frame, wi, n2)
        scale = max(float(np.max(np.abs(cur))), 1e-300)
        rel = float(np.max(np.abs(cur - prev))) / scale
        if rel <= opts.rtol:
            return cur, n2, rel
        prev, n = cur, n2
