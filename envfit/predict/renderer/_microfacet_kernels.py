r"""Compiled (numba) forms of the microfacet model's per-frame hot loops, each the same
arithmetic as its numpy reference, which the tests compare it with:

* :func:`conductor_eval_pdf` — a white conductor's f·cos and its sampling pdf at many light
  directions for one view (:meth:`envfit.shading.microfacet.Conductor.eval` and ``pdf`` with
  Fresnel 1: D, Smith Λ of GGX or Beckmann's rational fit, separable G and the view's χ⁺
  masking or height-correlated G, as the conductor's ``separable_g`` says);
* :func:`conductor_proxies` — the same at a map table's directions for many frames at once,
  reduced to each frame's emitter and visible-normal sampling variances (the frames'
  importance proxies);
* :func:`accumulate_parts` — the five parts of one normal (map, brdf and MIS's weighted
  parts) added to the frame's sums in one pass.

The conductor's sampling is compiled in ``_vndf_kernels``.

On city.exr (1024 × 512), one frame's tables at level 10 (1 M points per part) took 4.3 s in
numpy on the loaded 2-core machine; these two loops were most of it.
"""
from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["conductor_eval_pdf", "conductor_proxies", "compiled_conductor"]

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


@numba.njit(cache=True)
def _fc_pdf(view, o, alpha, kind, separable):  # pragma: no cover - numba
    """(f·cos, pdf) at the local light direction ``o`` for ``view`` = (ω_i, Λ(ω_i))."""
    ix, iy, iz, lam_i = view
    ox, oy, oz = o
    hx, hy, hz = ix + ox, iy + oy, iz + oz
    n = math.sqrt(hx * hx + hy * hy + hz * hz)
    if n <= 0.0 or iz <= 0.0:
        return 0.0, 0.0
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
    fc = pdf = 0.0
    if oz > 0.0:
        v = d * g / (4.0 * iz)
        fc = v if math.isfinite(v) else 0.0
        if dot_i > 0.0 and dot_o > 0.0:
            q = d * gview / (4.0 * iz)
            pdf = q if math.isfinite(q) else 0.0
    return fc, pdf


@numba.njit(cache=True)
def _local(d, rows):  # pragma: no cover - numba
    """``rows @ d``: a world direction in the frame whose axes are ``rows``."""
    return (d[0] * rows[0, 0] + d[1] * rows[0, 1] + d[2] * rows[0, 2],
            d[0] * rows[1, 0] + d[1] * rows[1, 1] + d[2] * rows[1, 2],
            d[0] * rows[2, 0] + d[1] * rows[2, 1] + d[2] * rows[2, 2])


@numba.njit(cache=True, parallel=True)
def _eval_pdf(wi, dirs, rows, alpha, kind, separable, out):  # pragma: no cover - numba
    view = (wi[0], wi[1], wi[2], _lambda(wi[0], wi[1], wi[2], alpha, kind))
    for p in numba.prange(dirs.shape[0]):
        out[p, 0], out[p, 1] = _fc_pdf(view, _local(dirs[p], rows), alpha, kind, separable)


@numba.njit(cache=True, parallel=True)
def _proxies(wis, frames, dirs, table, consts, out):  # pragma: no cover - numba
    alpha, kind, separable = consts[0], int(consts[1]), consts[2] > 0.0
    size = dirs.shape[0]
    for a in numba.prange(wis.shape[0]):
        wi = wis[a]
        view = (wi[0], wi[1], wi[2], _lambda(wi[0], wi[1], wi[2], alpha, kind))
        acc = np.zeros(5)
        for p in range(size):
            fc, pb = _fc_pdf(view, _local(dirs[p], frames[a]), alpha, kind, separable)
            _proxy_add(acc, table[p], fc, pb)
        _proxy_out(acc, size, out[a])


@numba.njit(cache=True)
def _proxy_add(acc, row, fc, pb):  # pragma: no cover - numba
    """Add one table point (``row`` = π·base (3), map pdf) with the BSDF's f·cos ``fc`` and
    pdf ``pb`` to a frame's sums ``acc``: Σ b f per channel, Σ |b|² f², Σ |b|² p f²/p_b."""
    if fc == 0.0:
        return
    acc[0] += row[0] * fc
    acc[1] += row[1] * fc
    acc[2] += row[2] * fc
    b2 = row[0] ** 2 + row[1] ** 2 + row[2] ** 2
    acc[3] += b2 * fc * fc
    if pb > 0.0:
        acc[4] += b2 * row[3] * fc * fc / pb


@numba.njit(cache=True)
def _proxy_out(acc, size, out):  # pragma: no cover - numba
    """A frame's (v_e, v_b) into ``out`` (2) from its sums over ``size`` points."""
    mean2 = (acc[0] / size) ** 2 + (acc[1] / size) ** 2 + (acc[2] / size) ** 2
    out[0] = max(0.0, acc[3] / size - mean2)
    out[1] = max(0.0, acc[4] / size - mean2)


def conductor_proxies(conductor, wis, frames, dirs, base, pdf) -> np.ndarray:
    r"""Per frame a: (v_e, v_b) (K, 2), the variances of emitter and visible-normal sampling
    on a map table (``MicrofacetModel._proxies``): with :math:`b = \pi\,` ``base`` (P, 3),
    :math:`f` the white ``conductor``'s f·cos and :math:`p_b` its pdf at the table's world
    ``dirs`` (P, 3) in frame a (``frames`` (K, 3, 3), axes as rows; views ``wis`` (K, 3)
    local), :math:`v_e = \overline{|b|^2 f^2} - |\overline{b f}|^2` and
    :math:`v_b = \overline{|b|^2 p\, f^2/p_b} - |\overline{b f}|^2` (``pdf`` the map's),
    clipped at 0."""
    d = conductor.distribution
    table = np.ascontiguousarray(np.column_stack([np.pi * base, pdf]), dtype=np.float64)
    out = np.zeros((len(wis), 2))
    consts = np.array([d.alpha, _KINDS[d.kind], conductor.separable_g], float)
    _proxies(np.ascontiguousarray(wis, dtype=np.float64),
             np.ascontiguousarray(frames, dtype=np.float64),
             np.ascontiguousarray(dirs, dtype=np.float64), table, consts, out)
    return out


def compiled_conductor(conductor) -> bool:
    """Whether :func:`conductor_eval_pdf` repeats ``conductor`` (Fresnel 1)."""
    return getattr(conductor, "white", False) and conductor.distribution.kind in _KINDS


def conductor_eval_pdf(conductor, wi, dirs, rows=None) -> tuple[np.ndarray, np.ndarray]:
    """(f·cos, pdf) of a white ``conductor`` for the one view ``wi`` (3,) and light
    directions ``dirs`` (P, 3): local, or world with ``rows`` the local frame's axes (t, b, n)
    as rows (local = ``dirs @ rows.T``)."""
    out = np.empty((2, len(dirs)))
    d = conductor.distribution
    rows = np.eye(3) if rows is None else np.ascontiguousarray(rows, dtype=np.float64)
    _eval_pdf(np.ascontiguousarray(wi, dtype=np.float64),
              np.ascontiguousarray(dirs, dtype=np.float64), rows, float(d.alpha),
              _KINDS[d.kind], conductor.separable_g, out.T)
    return out[0], out[1]


# Parts, in the order of the accumulator's first axis (the diffuse model's names).
PARTS = ("map", "brdf", "mis_e", "mis_b", "mis_t")
_HEURISTIC_CODES = {"power": 0, "balance": 1}


@numba.njit(cache=True, error_model="numpy")
def _heuristic(pa, pb, fa, fb, power):  # pragma: no cover - numba
    """``power_heuristic`` / ``balance_heuristic``: technique a's weight, 0 if not finite."""
    a, b = fa * pa, fb * pb
    if power:
        a, b = a * a, b * b
    w = a / (a + b)
    return w if math.isfinite(w) else 0.0


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _accumulate(base, mvals, rad, bvals, consts, acc, sums):  # pragma: no cover - numba
    fc, pb, tpdf = mvals[0], mvals[1], mvals[2]
    weight, bpdf, pe = bvals[0], bvals[1], bvals[2]
    fa, fb, power = consts[0], consts[1], consts[2] > 0.0
    p_total = acc.shape[1]
    chunks = sums.shape[0]
    size = (p_total + chunks - 1) // chunks
    has_map, has_bsdf = fc.shape[0] > 0, weight.shape[0] > 0
    for k in numba.prange(chunks):
        for p in range(k * size, min(p_total, (k + 1) * size)):
            we = _heuristic(tpdf[p], pb[p], fa, fb, power) if has_map else 0.0
            wb = _heuristic(bpdf[p], pe[p], fb, fa, power) if has_bsdf else 0.0
            for c in range(3):
                he = base[p, c] * (math.pi * fc[p]) if has_map else 0.0
                hb = rad[p, c] * weight[p] if has_bsdf else 0.0
                g = (he, hb, he * we, hb * wb, he * we + hb * wb)
                for i in range(5):
                    acc[i, p, c] += g[i]
                    sums[k, i, 0, c] += g[i]
                    sums[k, i, 1, c] += g[i] * g[i]


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _bsdf_parts(rad, bvals, consts, brdf, mis_b):  # pragma: no cover - numba
    weight, bpdf, pe = bvals[0], bvals[1], bvals[2]
    fa, fb, power = consts[0], consts[1], consts[2] > 0.0
    for p in numba.prange(rad.shape[0]):
        wb = _heuristic(bpdf[p], pe[p], fb, fa, power)
        for c in range(3):
            hb = rad[p, c] * weight[p]
            brdf[p, c] = 0.0 + hb
            mis_b[p, c] = 0.0 + hb * wb


def bsdf_parts(bsdf_side, fractions, heuristic, brdf, mis_b) -> None:
    r"""The BSDF side's ``brdf`` and ``mis_b`` parts alone, into ``brdf`` and ``mis_b``
    (P, 3): what :func:`accumulate_parts` adds to a zeroed accumulator's ``brdf`` and
    ``mis_b`` without a map side (the same numbers), without the other parts or the sums."""
    consts = np.array([fractions[0], fractions[1], _HEURISTIC_CODES[heuristic] == 0], float)
    _bsdf_parts(np.ascontiguousarray(bsdf_side[0], dtype=np.float64),
                np.ascontiguousarray(np.stack(bsdf_side[1:]), dtype=np.float64), consts,
                brdf, mis_b)


def accumulate_parts(acc, map_side, bsdf_side, fractions, heuristic) -> np.ndarray:
    r"""Add one normal's parts (:data:`PARTS`) to ``acc`` (5, P, 3) in one pass and return
    their sums :math:`\sum_P g`, :math:`\sum_P g^2` (5, 2, 3).

    ``map_side`` = (base (P, 3), f·cos (P,), conductor pdf (P,), map pdf (P,)) at the map
    table's directions: map part :math:`h_e = \pi\,f\cos\cdot` base; ``bsdf_side`` =
    (radiance (P, 3), weight (P,), conductor pdf (P,), map pdf (P,)) at the BSDF table's
    samples: :math:`h_b` = radiance · weight; either None. The MIS parts weight each by the
    renderer's ``heuristic`` with the sample ``fractions`` (``Renderer.mis_weights``),
    and ``mis_t`` is their sum — the diffuse model's ``_part_values``, fused.
    """
    def packed(side):
        if side is None:
            return np.zeros((0, 3)), np.zeros((3, 0))
        return (np.ascontiguousarray(side[0], dtype=np.float64),
                np.ascontiguousarray(np.stack(side[1:]), dtype=np.float64))

    base, mvals = packed(map_side)
    rad, bvals = packed(bsdf_side)
    consts = np.array([fractions[0], fractions[1], _HEURISTIC_CODES[heuristic] == 0], float)
    sums = np.zeros((64, 5, 2, 3))                    # per chunk of the table
    _accumulate(base, mvals, rad, bvals, consts, acc, sums)
    return sums.sum(axis=0)
