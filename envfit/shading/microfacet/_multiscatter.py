r"""Multiple scattering of a white GGX conductor as an energy scale on its single-scatter lobe:
eval and sample weight times

.. math::  s(\mu_i) = 1 + \frac{1 - E}{E} = \frac1{E},\qquad
           E = \mathrm{lerp}_{2D}\big(E_{\text{table}};\ \sqrt\alpha,\ \mu_i\big),

:math:`\mu_i` = cos of the view angle, the table the lobe's single-scatter albedo
:math:`E(r, \mu) = \int f\cos\theta_o\,d\omega_o` (F = 1) on the 32 × 32 nodes
:math:`r = \mathrm{clamp}(x/31, 10^{-4}, 1)`, :math:`\mu = \mathrm{clamp}(y/31, 10^{-4}, 1)`,
clamped to [0, 1]; looked up linearly in μ between rows and linearly in r within a row, the
indices truncated. For a white metal (F ≡ 1) this is the whole change; the pdf is the
single-scatter one. A coloured lobe whose Fresnel has the hemispherical average
:math:`F_{ss}` (an F82 metal: :func:`~envfit.shading.microfacet._fresnel.f82_average`) gains
only the energy its multiple bounces keep (Kulla & Conty, "Revisiting Physically Based
Shading at Imageworks", 2017, appendix, one :math:`F_{ss}` cancelled against the single
scatter's own Fresnel):

.. math::  s(\mu_i) = 1 + F_{ms}\,\frac{1 - E}{E},\qquad
           F_{ms} = \frac{F_{ss}\,E_{avg}}{1 - F_{ss}(1 - E_{avg})},

:math:`E_{avg}(r) = \int_0^1 2\mu E(r, \mu)\,d\mu` on the same 32 roughness nodes, looked up
linearly (:func:`average_albedo`); :math:`F_{ss} = 1` gives 1/E again.

envfit computes the table itself (:func:`albedo_table`: the sample weight of the lobe's own
:class:`~envfit.shading.microfacet.Conductor` — its shadowing form and visible-normal warp —
at α = r², integrated over the unit square by a 48 × 48 Gauss–Legendre rule on each of
4 × 4 panels; rules of 24–96 nodes on 4–16 panels agree to 5 × 10⁻⁴);
``tests/test_multiscatter.py`` checks it against a direction-space quadrature, and the
renderer whose BSDF this is checks the result by rendering (its folder,
``envfit/renderers/<name>/_bsdf.py``, cites the table, its lookup and its precomputation).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from envfit.shading.microfacet._conductor import Conductor

__all__ = ["TABLE_SIZE", "albedo_table", "average_albedo", "energy_scale"]

#: nodes per axis of the albedo table (roughness r = √α, then μ)
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


@lru_cache(maxsize=4 * TABLE_SIZE)
def _column(shadowing: str, vndf: str, x: int) -> np.ndarray:
    """E at the 32 μ nodes of roughness node x (one column of :func:`albedo_table`) of the
    white GGX lobe with the ``shadowing`` form and the ``vndf`` warp."""
    pts, wts = _square_rule()
    grid = np.clip(np.arange(TABLE_SIZE) / (TABLE_SIZE - 1.0), 1e-4, 1.0)
    c = Conductor("ggx", max(float(grid[x]) ** 2, 1e-4), shadowing=shadowing, vndf=vndf)
    out = np.empty(TABLE_SIZE)
    for y, mu in enumerate(grid):
        wi = np.broadcast_to([np.sqrt(1.0 - mu * mu), 0.0, mu], (len(pts), 3))
        out[y] = wts @ c.sample(wi, pts).weight
    out = np.clip(out, 0.0, 1.0)
    out.flags.writeable = False
    return out


@lru_cache(maxsize=4 * TABLE_SIZE)
def _average(shadowing: str, vndf: str, x: int) -> float:
    """E_avg at roughness node x: ∫ 2μ E dμ by a 32-node Gauss–Legendre rule in μ, each E by
    the square rule of :func:`_column` (its clamp to [0, 1] too)."""
    pts, wts = _square_rule()
    r = float(np.clip(x / (TABLE_SIZE - 1.0), 1e-4, 1.0))
    c = Conductor("ggx", max(r * r, 1e-4), shadowing=shadowing, vndf=vndf)
    mu, w = np.polynomial.legendre.leggauss(32)
    mu, w = (mu + 1.0) / 2.0, w / 2.0
    e = [min(max(wts @ c.sample(np.broadcast_to([np.sqrt(1.0 - m * m), 0.0, m], (len(pts), 3)),
                                 pts).weight, 0.0), 1.0) for m in mu]
    return float(np.sum(w * 2.0 * mu * np.asarray(e)))


def average_albedo(alpha: float, *, shadowing: str, vndf: str) -> float:
    """E_avg(√α) of the white GGX lobe, linear between the 32 roughness nodes."""
    ix, jx, tx = _lerp_index(np.array(np.sqrt(alpha)))
    return float((1.0 - tx) * _average(shadowing, vndf, int(ix))
                 + tx * _average(shadowing, vndf, int(jx)))


def albedo_table(*, shadowing: str, vndf: str) -> np.ndarray:
    r"""E[y, x]: the single-scatter albedo of the white GGX lobe (``shadowing`` form, ``vndf``
    warp) at :math:`\mu = \mathrm{clamp}(y/31, 10^{-4}, 1)`, :math:`r = \sqrt\alpha =
    \mathrm{clamp}(x/31, 10^{-4}, 1)` (one row per μ), clamped to [0, 1] (α below 10⁻⁴, the
    first column only, is taken at 10⁻⁴, :class:`~envfit.shading.microfacet.Conductor`'s
    floor)."""
    return np.stack([_column(shadowing, vndf, x) for x in range(TABLE_SIZE)], axis=1)


def _lerp_index(v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The table's (index, next index, t) for values ``v`` in [0, 1]."""
    x = np.clip(v, 0.0, 1.0) * (TABLE_SIZE - 1)
    i = np.minimum(x.astype(np.int64), TABLE_SIZE - 1)
    return i, np.minimum(i + 1, TABLE_SIZE - 1), x - i


def energy_scale(alpha: float, cos_i, *, shadowing: str, vndf: str,
                 fss: float = 1.0) -> np.ndarray:
    r"""The energy scale 1/E(√α, μ_i) of a white GGX lobe (``shadowing`` form, ``vndf`` warp),
    per view cosine (:func:`albedo_table` looked up linearly in √α within each μ row, then
    linearly in μ between the rows); with a Fresnel average ``fss`` < 1, 1 + F_ms(1 − E)/E
    (module docstring).

    >>> s = energy_scale(0.3 ** 2, 1.0, shadowing="height_correlated",
    ...                  vndf="hemisphere_concentric")
    >>> float(s) > 1.0                                  # a rough lobe loses energy to G
    True
    """
    ix, jx, tx = _lerp_index(np.array(np.sqrt(alpha)))
    col = ((1.0 - tx) * _column(shadowing, vndf, int(ix))
           + tx * _column(shadowing, vndf, int(jx)))                    # E per μ row
    iy, jy, ty = _lerp_index(np.asarray(cos_i, dtype=np.float64))
    e = (1.0 - ty) * col[iy] + ty * col[jy]
    inv = np.where(e > 0, 1.0 / np.where(e > 0, e, 1.0), 0.0)
    if fss == 1.0:
        return inv
    avg = average_albedo(alpha, shadowing=shadowing, vndf=vndf)
    fms = fss * avg / (1.0 - fss * (1.0 - avg))
    return np.where(e > 0, 1.0 + fms * (inv - 1.0), 0.0)
