r"""The warped integrands of a real renderer's direct-light estimator on a white diffuse
surface, tabulated at the midpoints of a dyadic grid of the sample square.

For a normal n, albedo 1 and one 2-D sample u per technique (:mod:`envfit.renderers`):

* the **map part** :math:`h_e(u) = w_e(\omega)\,L(\omega)\,\max(0, n\cdot\omega)/(\pi\,p_e(\omega))`
  at :math:`\omega = \mathrm{technique.sample}(u)`;
* the **BSDF part** :math:`h_b(u) = w_b(\omega)\,L(\omega)` at
  :math:`\omega = \mathrm{frame}_n(\mathrm{cosine}(u))` (the diffuse BSDF's weight
  :math:`f\cos/p = 1`),

with L the renderer's radiance lookup (``technique.eval``), :math:`p_e` its density
(``technique.pdf``), :math:`p_b = \cos/\pi` and w the renderer's MIS weights with its sample
fractions (:meth:`~envfit.renderers.Renderer.mis_weights`; 1 for a strategy with
one technique). Per channel (RGB).

The map part's :math:`\omega(u)`, :math:`L(\omega)/(\pi p_e)` and :math:`p_e` do not depend on
n: :class:`MapTable` computes them once per grid and every normal only takes a dot product and
a weight (:func:`map_values`). The BSDF part's local directions are fixed (:class:`BsdfTable`);
per normal they are turned into the world frame and looked up (:func:`bsdf_values`) — by the
technique's own compiled ``bsdf_lookup`` where it has one (each checked against the technique's
numpy methods in the tests), for any other technique through its ``eval`` and ``pdf``; the map
part likewise by its ``sample_table`` where it has one.

The tables hold the integrand at the midpoints of the :math:`2^F \times 2^F` cells, axis 1 of
each array along ``u[:, 0]`` (the :class:`~envfit.predict.renderer.randomisation.DyadicGrid`
convention); :func:`cell_moments` aggregates them to the cell means of h and h² of a coarser
level, i.e. the midpoint rule on the fine level inside every coarse cell.

References: E. Veach, PhD thesis (1997), §9.2; the renderer's integrator, emitter and diffuse
BSDF as its folder cites them (``envfit/renderers/<name>``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from envfit.base import ParameterError

__all__ = ["MapTable", "BsdfTable", "map_values", "bsdf_values", "mis_parts", "cell_moments",
           "moment_pyramid", "midpoints"]

#: points per call of a technique's numpy methods (generic path)
_CHUNK = 1 << 18


def midpoints(level: int) -> np.ndarray:
    """The midpoints (4^level, 2) of the 2^level × 2^level cells, row-major with ``u[:, 0]``
    the slow index (so that a reshape to (M, M) puts ``u[:, 0]`` on axis 0)."""
    m = 1 << int(level)
    c = (np.arange(m) + 0.5) / m
    u = np.empty((m, m, 2))
    u[..., 0] = c[:, None]
    u[..., 1] = c[None, :]
    return u.reshape(-1, 2)


@dataclass(frozen=True)
class MapTable:
    """The map part's normal-independent factors at the midpoints of level ``level``:
    directions (P, 3), :math:`L/(\\pi p_e)` (P, 3) and :math:`p_e` (P,) (0 where the
    technique's density is 0)."""

    level: int
    directions: np.ndarray
    base: np.ndarray
    pdf: np.ndarray

    @classmethod
    def build(cls, technique, level: int) -> "MapTable":
        """The table at the midpoints of level ``level``."""
        t = cls.at(technique, midpoints(level))
        return cls(int(level), t.directions, t.base, t.pdf)

    @classmethod
    def at(cls, technique, u: np.ndarray) -> "MapTable":
        """The table at the square points ``u`` (P, 2) (``level`` −1: no grid)."""
        table = getattr(technique, "sample_table", None)     # a compiled sample_direction
        if table is not None:
            d, p, rad = table(u)
            with np.errstate(divide="ignore", invalid="ignore"):
                b = np.where(p[:, None] > 0, rad / (np.pi * p[:, None]), 0.0)
            return cls(-1, d, b, p)
        dirs, pdf, base = [], [], []
        for i in range(0, len(u), _CHUNK):
            s, rad = technique.sample_radiance(u[i:i + _CHUNK])
            p = np.asarray(s.pdf, dtype=np.float64)
            with np.errstate(divide="ignore", invalid="ignore"):
                b = np.where(p[:, None] > 0, rad / (np.pi * p[:, None]), 0.0)
            dirs.append(s.directions)
            pdf.append(p)
            base.append(b)
        return cls(-1, np.concatenate(dirs), np.concatenate(base), np.concatenate(pdf))


@dataclass(frozen=True)
class BsdfTable:
    """The BSDF part's local directions (P, 3) (normal +z) at the midpoints of level
    ``level``, by the renderer's cosine map."""

    level: int
    local: np.ndarray

    @classmethod
    def build(cls, renderer, level: int) -> "BsdfTable":
        """The table at the midpoints of level ``level``."""
        return cls(int(level), cls.at(renderer, midpoints(level)).local)

    @classmethod
    def at(cls, renderer, u: np.ndarray) -> "BsdfTable":
        """The table at the square points ``u`` (P, 2) (``level`` −1: no grid)."""
        return cls(-1, np.asarray(renderer.cosine(u).directions))


@numba.njit(cache=True, parallel=True)
def _map_kernel(dirs, base, pdf, n, fe, fb, out_h, out_w):  # pragma: no cover - numba
    for p in numba.prange(dirs.shape[0]):
        c = n[0] * dirs[p, 0] + n[1] * dirs[p, 1] + n[2] * dirs[p, 2]
        if c <= 0.0 or pdf[p] <= 0.0:
            for k in range(3):
                out_h[p, k] = 0.0
            out_w[p] = 0.0
            continue
        for k in range(3):
            out_h[p, k] = base[p, k] * c
        a = (fe * pdf[p]) ** 2
        b = (fb * c / np.pi) ** 2
        out_w[p] = a / (a + b) if a + b > 0.0 else 0.0


def map_values(table: MapTable, normal, fractions) -> tuple[np.ndarray, np.ndarray]:
    r"""The map part at one normal: :math:`L\max(0, n\cdot\omega)/(\pi p_e)` (P, 3) and the
    power-heuristic MIS weight :math:`w_e` (P,) with the sample ``fractions`` (emitter,
    BSDF) — multiply them for :math:`h_e`."""
    n = np.ascontiguousarray(normal, dtype=np.float64)
    h = np.empty_like(table.base)
    w = np.empty_like(table.pdf)
    _map_kernel(table.directions, table.base, table.pdf, n, float(fractions[0]),
                float(fractions[1]), h, w)
    return h, w


def bsdf_values(technique, renderer, table: BsdfTable, normal,
                fractions) -> tuple[np.ndarray, np.ndarray]:
    r"""The BSDF part at one normal: the radiance :math:`L(\omega)` (P, 3) at
    :math:`\omega = \mathrm{frame}_n(\mathrm{local})` and the MIS weight :math:`w_b` (P,) with
    the sample ``fractions`` (emitter, BSDF) — multiply them for :math:`h_b`."""
    n = np.asarray(normal, dtype=np.float64).reshape(1, 3)
    frame = np.ascontiguousarray(renderer.tangent_frame(n)[0])
    fe, fb = float(fractions[0]), float(fractions[1])
    p = table.local.shape[0]
    lookup = getattr(technique, "bsdf_lookup", None)
    if lookup is not None and renderer.heuristic == "power":
        return lookup(table.local, frame, fe, fb)
    rad, wts = [], []
    for i in range(0, p, _CHUNK):
        loc = table.local[i:i + _CHUNK]
        d = loc @ frame
        rad.append(technique.eval_unit(d))
        w = renderer.mis_weights(technique.pdf_unit(d), loc[:, 2] / np.pi, "mis")[1] \
            if fe > 0 else np.ones(len(loc))
        wts.append(w)
    return np.concatenate(rad), np.concatenate(wts)


def mis_parts(h: np.ndarray, we: np.ndarray, rad: np.ndarray,
              wb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The weighted parts of MIS at one normal, in one compiled pass: :math:`w_e h_e`,
    :math:`w_b h_b` and their sum, from :func:`map_values` (h (P, C), w_e (P,)) and
    :func:`bsdf_values` (L (P, C), w_b (P,)).

    >>> e, b, t = mis_parts(np.ones((2, 1)), np.array([0.25, 1.0]), np.full((2, 1), 2.0),
    ...                     np.array([0.5, 0.0]))
    >>> e[:, 0].tolist(), b[:, 0].tolist(), t[:, 0].tolist()
    ([0.25, 1.0], [1.0, 0.0], [1.25, 1.0])
    """
    h, rad = np.asarray(h, np.float64), np.asarray(rad, np.float64)    # views are read as such
    out = np.empty((3,) + h.shape)
    _mis_parts_kernel(h, np.asarray(we, np.float64), rad, np.asarray(wb, np.float64), out)
    return out[0], out[1], out[2]


@numba.njit(cache=True, parallel=True)
def _mis_parts_kernel(h, we, rad, wb, out):  # pragma: no cover - numba
    for p in numba.prange(h.shape[0]):
        for c in range(h.shape[1]):
            e, b = h[p, c] * we[p], rad[p, c] * wb[p]
            out[0, p, c], out[1, p, c], out[2, p, c] = e, b, e + b


def cell_moments(values: np.ndarray, fine_level: int, level: int) -> tuple[np.ndarray, np.ndarray]:
    """The cell means of h and of h² (C, M, M), M = 2^level, from h at the midpoints of the
    fine level (P, C) (:func:`midpoints` order): each coarse cell is the mean over its
    :math:`4^{F-L}` fine midpoints."""
    if level > fine_level or level < 0:
        raise ParameterError(f"level {level} must be between 0 and the table's {fine_level}")
    mf, m = 1 << fine_level, 1 << level
    k = mf // m
    v = np.moveaxis(values.reshape(mf, mf, -1), -1, 0).reshape(-1, m, k, m, k)
    return v.mean(axis=(2, 4)), (v * v).mean(axis=(2, 4))


@numba.njit(cache=True)
def _halve_row(a, b, out_a, out_b, r):  # pragma: no cover - numba
    """Row ``r`` (channel r // m, row r % m) of :func:`_halve`."""
    m = out_a.shape[1]
    c, i = r // m, r % m
    for j in range(m):
        out_a[c, i, j] = 0.25 * ((a[c, 2 * i, 2 * j] + a[c, 2 * i, 2 * j + 1])
                                 + (a[c, 2 * i + 1, 2 * j] + a[c, 2 * i + 1, 2 * j + 1]))
        out_b[c, i, j] = 0.25 * ((b[c, 2 * i, 2 * j] + b[c, 2 * i, 2 * j + 1])
                                 + (b[c, 2 * i + 1, 2 * j] + b[c, 2 * i + 1, 2 * j + 1]))


@numba.njit(cache=True, parallel=True)
def _halve(a, b, out_a, out_b):  # pragma: no cover - numba
    """The 2 × 2 block means of ``a`` and ``b`` (C, 2m, 2m) into ``out_a``, ``out_b``
    (C, m, m), rows in parallel."""
    for r in numba.prange(out_a.shape[0] * out_a.shape[1]):
        _halve_row(a, b, out_a, out_b, r)


@numba.njit(cache=True)
def _halve_small(a, b, out_a, out_b):  # pragma: no cover - numba
    """:func:`_halve` in one thread (the same numbers): a coarse level's few cells, where
    starting the threads costs more than the work."""
    for r in range(out_a.shape[0] * out_a.shape[1]):
        _halve_row(a, b, out_a, out_b, r)


#: the cells (channels × M²) of a pyramid level below which it is halved in one thread
SERIAL_CELLS = 1 << 16


@numba.njit(cache=True, parallel=True)
def _halve_values(v, out_a, out_b):  # pragma: no cover - numba
    """The 2 × 2 block means of h and of h² from the fine values ``v`` (2m, 2m, C) into
    ``out_a``, ``out_b`` (C, m, m): the first level of the pyramid without a channel-first
    copy of the fine table or its square."""
    chans, m = out_a.shape[0], out_a.shape[1]
    for r in numba.prange(chans * m):
        c, i = r // m, r % m
        for j in range(m):
            x0, x1 = v[2 * i, 2 * j, c], v[2 * i, 2 * j + 1, c]
            x2, x3 = v[2 * i + 1, 2 * j, c], v[2 * i + 1, 2 * j + 1, c]
            out_a[c, i, j] = 0.25 * ((x0 + x1) + (x2 + x3))
            out_b[c, i, j] = 0.25 * ((x0 * x0 + x1 * x1) + (x2 * x2 + x3 * x3))


def moment_pyramid(values: np.ndarray, fine_level: int, levels) -> dict:
    """:func:`cell_moments` at every level of ``levels`` at once: {level: (A, B)}, each level
    the 2 × 2 block means of the one below (one compiled pass per level over the fine
    values; :func:`cell_moments` is the tests' reference)."""
    levels = sorted(set(int(x) for x in levels))
    if not levels or levels[0] < 0 or levels[-1] > fine_level:
        raise ParameterError(f"levels must lie between 0 and the table's {fine_level}")
    mf = 1 << fine_level
    v = values.reshape(mf, mf, -1)
    if fine_level in levels or fine_level == 0:
        a = np.ascontiguousarray(np.moveaxis(v, -1, 0), dtype=np.float64)
        b = a * a
        start = fine_level
    else:
        m = mf // 2
        a, b = np.empty((v.shape[-1], m, m)), np.empty((v.shape[-1], m, m))
        _halve_values(np.ascontiguousarray(v, dtype=np.float64), a, b)
        start = fine_level - 1
    out = {}
    for lev in range(start, levels[0] - 1, -1):
        if lev < start:
            m = 1 << lev
            na, nb = np.empty((a.shape[0], m, m)), np.empty((a.shape[0], m, m))
            (_halve_small if na.size <= SERIAL_CELLS else _halve)(a, b, na, nb)
            a, b = na, nb
        if lev in levels:
            out[lev] = (a, b)
    return out
