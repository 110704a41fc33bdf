r"""Compiled (numba) forms of the microfacet model's per-frame hot loops, each the same
arithmetic as its numpy reference, which the tests compare it with:

* :func:`conductor_eval_pdf` — a white conductor's f·cos and its sampling pdf at many light
  directions for one view (:meth:`envfit.shading.microfacet.Conductor.eval` and ``pdf`` with
  Fresnel 1: D, Smith Λ of GGX or Beckmann's rational fit, separable G and the view's χ⁺
  masking for Mitsuba 3, height-correlated G for pbrt-v4 and Cycles);
* :func:`mitsuba_eval_pdf` — Mitsuba 3 ``envmap``'s radiance and emitter pdf at world
  directions (``Mitsuba3Envmap.eval`` and ``pdf``, through the diffuse model's
  ``_mitsuba_eval``).

On city.exr (1024 × 512), one frame's tables at level 10 (1 M points per part) took 4.3 s in
numpy on the loaded 2-core machine; these two loops were most of it.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from envfit.predict.renderer._preset_integrand import _mitsuba_eval

__all__ = ["conductor_eval_pdf", "mitsuba_eval_pdf", "compiled_conductor"]

_KINDS = {"ggx": 0, "beckmann": 1}


@numba.njit(cache=True)
def _lambda(x, y, z, alpha, kind):  # pragma: no cover - numba
    """Smith Λ as ``MicrofacetDistribution.lambda_`` (GGX exact, Beckmann rational)."""
    xy2 = x * x + y * y
    if xy2 == 0.0:
        return 0.0
    z2 = z * z
    if z2 == 0.0:
        return np.inf
    t2 = alpha * alpha * xy2 / z2
    if kind == 0:
        return 0.5 * (math.sqrt(1.0 + t2) - 1.0)
    a = 1.0 / math.sqrt(t2)
    if a >= 1.6:
        return 0.0
    return (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a)


@numba.njit(cache=True)
def _d(mx, my, mz, alpha, kind):  # pragma: no cover - numba
    """D(m), 0 below the surface (``MicrofacetDistribution.D``)."""
    if mz <= 0.0:
        return 0.0
    a2 = alpha * alpha
    z2 = mz * mz
    if kind == 0:
        q = (mx * mx + my * my) / a2 + z2
        return 1.0 / (math.pi * a2 * q * q)
    return math.exp(-(mx * mx + my * my) / (a2 * z2)) / (math.pi * a2 * z2 * z2)


@numba.njit(cache=True, parallel=True)
def _eval_pdf(wi, dirs, alpha, kind, separable, out):  # pragma: no cover - numba
    ix, iy, iz = wi[0], wi[1], wi[2]
    lam_i = _lambda(ix, iy, iz, alpha, kind)
    for p in numba.prange(dirs.shape[0]):
        ox, oy, oz = dirs[p, 0], dirs[p, 1], dirs[p, 2]
        hx, hy, hz = ix + ox, iy + oy, iz + oz
        n = math.sqrt(hx * hx + hy * hy + hz * hz)
        out[p, 0] = 0.0
        out[p, 1] = 0.0
        if n <= 0.0 or iz <= 0.0:
            continue
        mx, my, mz = hx / n, hy / n, hz / n
        d = _d(mx, my, mz, alpha, kind)
        dot_i = ix * mx + iy * my + iz * mz
        dot_o = ox * mx + oy * my + oz * mz
        lam_o = _lambda(ox, oy, oz, alpha, kind)
        if separable:
            g1i = 0.0 if dot_i * iz <= 0.0 else 1.0 / (1.0 + lam_i)
            g1o = 0.0 if dot_o * oz <= 0.0 else 1.0 / (1.0 + lam_o)
            g, gview = g1i * g1o, g1i
        else:
            g, gview = 1.0 / (1.0 + lam_i + lam_o), 1.0 / (1.0 + lam_i)
        if oz > 0.0:
            v = d * g / (4.0 * iz)
            out[p, 0] = v if math.isfinite(v) else 0.0
            if dot_i > 0.0 and dot_o > 0.0:
                q = d * gview / (4.0 * iz)
                out[p, 1] = q if math.isfinite(q) else 0.0


def compiled_conductor(conductor) -> bool:
    """Whether :func:`conductor_eval_pdf` repeats ``conductor`` (Fresnel 1)."""
    return conductor.eta is None and conductor.distribution.kind in _KINDS


def conductor_eval_pdf(conductor, wi, dirs) -> tuple[np.ndarray, np.ndarray]:
    """(f·cos, pdf) of a white ``conductor`` for the one view ``wi`` (3,) and light
    directions ``dirs`` (P, 3), local frame."""
    out = np.empty((len(dirs), 2))
    d = conductor.distribution
    _eval_pdf(np.ascontiguousarray(wi, dtype=np.float64),
              np.ascontiguousarray(dirs, dtype=np.float64), float(d.alpha), _KINDS[d.kind],
              conductor.renderer == "mitsuba3", out)
    return out[:, 0], out[:, 1]


@numba.njit(cache=True, parallel=True)
def _mitsuba_dirs(dirs, to_native, rgb, warp, out):  # pragma: no cover - numba
    for p in numba.prange(dirs.shape[0]):
        x = dirs[p, 0] * to_native[0, 0] + dirs[p, 1] * to_native[1, 0] + dirs[p, 2] * to_native[2, 0]
        y = dirs[p, 0] * to_native[0, 1] + dirs[p, 1] * to_native[1, 1] + dirs[p, 2] * to_native[2, 1]
        z = dirs[p, 0] * to_native[0, 2] + dirs[p, 1] * to_native[1, 2] + dirs[p, 2] * to_native[2, 2]
        nrm = math.sqrt(x * x + y * y + z * z)
        out[p, 3] = _mitsuba_eval(x / nrm, y / nrm, z / nrm, rgb, 1.0, warp, out, p)


def mitsuba_eval_pdf(technique, dirs) -> tuple[np.ndarray, np.ndarray]:
    """(radiance (P, 3), emitter pdf (P,)) of a ``Mitsuba3Envmap`` at world directions."""
    out = np.empty((len(dirs), 4))
    _mitsuba_dirs(np.ascontiguousarray(dirs, dtype=np.float64),
                  np.ascontiguousarray(technique.native_to_world),
                  technique.rgb * float(technique.scale), technique.warp.data, out)
    return out[:, :3], out[:, 3]
