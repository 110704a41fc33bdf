r"""Cycles' *Multiscatter GGX* — the default distribution of Blender's Principled BSDF and
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
instead of copying Cycles' numbers; ``tests/test_multiscatter.py`` checks it against a direction-space
quadrature, and ``tests/test_render_cycles.py`` checks the result by rendering: a white
Multiscatter GGX sphere under a constant map renders 1 at every view.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

__all__ = ["TABLE_SIZE", "albedo_table", "energy_scale", "multiscatter_or_conductor"]

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
    from envfit.shading.microfacet._conductor import Conductor
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
    from envfit.base import ParameterError
    from envfit.shading.microfacet._conductor import Conductor
    if bsdf == "multiggx":
        if renderer != "cycles":
            raise ParameterError("--brdf multiggx is Cycles' Multiscatter GGX (the Principled "
                                 "and Glossy BSDF nodes' default): --renderer cycles")
        return Conductor("ggx", alpha, "cycles", multiscatter=True)
    return Conductor(bsdf, alpha, renderer=renderer)
