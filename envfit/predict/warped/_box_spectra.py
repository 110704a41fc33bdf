r"""The warped integrands' Fourier coefficients :math:`\hat h_i(k)` on the box
:math:`|k_0|, |k_1| \le B = G/4`, for one axis.

* The map technique's from exact per-pixel quadrature nodes (:class:`_MapNodes`): the sampler
  maps each pixel onto a rectangle of the square, where h is smooth; a midpoint rule per
  rectangle with at most one radian of the phase between nodes, and one type-1 non-uniform
  FFT (ducc0) — free of the aliasing of a uniform grid.
* The lobe technique's from :math:`h_i` at the midpoints of a :data:`LOBE_OVERSAMPLING`·B
  square grid (:class:`_Grid`, a real FFT, :func:`_box`): aliasing comes only from
  frequencies above 7B. The lobe part jumps where the map pdf of MIS does, and the glossy
  warp compresses the grazing directions, so a 4B grid over-counts the box — on a 128-row
  sun + GP map by 3–8 % for MIS with a diffuse lobe and 3–27 % for glossy BRDF sampling at
  N = 256–1024, against a 16B grid; 8B is within 1–2 % of it.

With the point set's exponential sums :math:`S_i(k)` these give the box term of the error,
:math:`\sum_{k\ne0}|\sum_i\hat h_i(k)S_i(k)|^2` on the box (:mod:`._prediction_sums`).

Reference: R. Cranley, T. N. L. Patterson, SIAM J. Numer. Anal. 13 (1976) (the shifted
estimator's error on the torus).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envfit.base import check_memory
from envfit.maps import EnvMap
from envfit.maps import rows_dot, rows_times
from envfit.sampling import MapSampler
from envfit.sampling import brdf_pdf
from envfit.theory import lambert_to_hemisphere

__all__ = ["LOBE_OVERSAMPLING", "NUFFT_EPSILON", "LOBE_CUTOFF", "BoxInputs"]

#: the lobe technique's grid is this many times the box B per side (see the module docstring)
LOBE_OVERSAMPLING = 8
#: relative accuracy of the map part's single-precision non-uniform FFT
NUFFT_EPSILON = 1e-5
#: nodes whose lobe value is below this fraction of the lobe's peak are left out of the NUFFT
#: (their share of any coefficient is below it too: far below NUFFT_EPSILON)
LOBE_CUTOFF = 1e-9


class _Grid:
    """The G×G midpoint grid of the square and the lobe technique's directions on it."""

    def __init__(self, weight, g: int):
        t = (np.arange(g) + 0.5) / g
        U = np.column_stack([np.repeat(t, g), np.tile(t, g)])    # u0 slow (rows), u1 fast
        self.g = g
        self.local = lambert_to_hemisphere(U, morph=weight.morph)
        self.lobe = brdf_pdf(weight, self.local[:, 2])


class _MapNodes:
    r"""Quadrature nodes of the map technique in the square, for exact Fourier coefficients.

    The sampler maps pixel (i, j) onto the rectangle :math:`[R_i, R_{i+1}]\times[C_{ij},
    C_{i,j+1}]` of the square (marginal and conditional CDFs), linearly in (cos θ, φ); there
    :math:`h = f\rho_a/p_{ij}` is smooth (f bilinear, p constant), and jumps only at the
    rectangles' edges. Each rectangle gets the :math:`n_0\times n_1` midpoint rule with
    :math:`n = \lceil 2\pi B w\rceil + 1` for a side w — at most one radian of the phase
    :math:`e^{-2\pi i k\cdot u}`, |k| ≤ B, between nodes: a sun's pixels, stretched over much
    of the square, get many nodes, a dark pixel one; in all about
    :math:`(2\pi B)^2 + 2\pi B(H + \sum_i W) + HW` nodes (the rectangles tile the square).
    Then :math:`\hat h(k) = \sum_q h(u_q)\,w_q\,e^{-2\pi i k\cdot u_q}` is a type-1
    non-uniform FFT (ducc0), free of the aliasing of a uniform grid (which needs ~2048² points
    on a 1024×512 map with a sun to agree to 5 %). Lobe-independent: the map and MIS spectra
    of every lobe share them (:class:`._spectrum_inputs.SpectrumInputs`).
    """

    def __init__(self, envmap: EnvMap, sampler: MapSampler, band: int):
        R, C = sampler._row_cdf, sampler._col_cdf
        dR, dC = np.diff(R), np.diff(C, axis=1)                        # (H,), (H, W)
        i, j = np.nonzero((dR[:, None] > 0) & (dC > 0))
        n0 = np.maximum(np.ceil(2.0 * np.pi * band * dR[i]), 1).astype(np.int64)
        n1 = np.maximum(np.ceil(2.0 * np.pi * band * dC[i, j]), 1).astype(np.int64)
        count = n0 * n1
        check_memory(int(count.sum()) * 8 * (12 + 2 * envmap.channels),
                     f"the map technique's {int(count.sum())} nodes",
                     hint="use a smaller grid")
        pix = np.repeat(np.arange(i.size), count)
        local = np.arange(pix.size) - np.repeat(np.cumsum(count) - count, count)
        a, b = local // n1[pix], local % n1[pix]
        x, y = (a + 0.5) / n0[pix], (b + 0.5) / n1[pix]
        ip, jp = i[pix], j[pix]
        self.u = np.column_stack([R[ip] + dR[ip] * x, C[ip, jp] + dC[ip, jp] * y])
        self.weight = (dR[ip] * dC[ip, jp]) / count[pix]
        self.dirs = sampler.pixel_point(ip, jp, x, y)
        self.pdf = sampler.pixel_pdf[ip, jp]
        #: (C, Q) f times the node weight; the coordinates 2πu in float32 for the NUFFT
        self.fw = np.ascontiguousarray((envmap.lookup(self.dirs) * self.weight[:, None]).T)
        self.coord = (2.0 * np.pi * self.u).astype(np.float32)
        self.band = band

    def box(self, factor: np.ndarray, active: np.ndarray, band: int,
            nthreads: int = 1) -> np.ndarray:
        r""":math:`\hat h(k)` on the half box (C, 2B+1, B+1) of :math:`h = f\cdot` ``factor``
        at the ``active`` nodes (the others hold h = 0): one type-1 non-uniform FFT of all
        channels (ducc0, single precision, :data:`NUFFT_EPSILON` relative to
        :math:`\sum_q |h_q| w_q` — far below the axis-sampling error the prediction keeps)."""
        import ducc0

        size = 2 * band + 2
        idx = np.flatnonzero(active)
        pts = np.zeros((self.fw.shape[0], idx.size), dtype=np.complex64)
        for c in range(pts.shape[0]):
            np.multiply(self.fw[c].take(idx), factor, out=pts.real[c], casting="same_kind")
        grid = ducc0.nufft.nu2u(points=pts, coord=self.coord.take(idx, axis=0), forward=True,
                                epsilon=NUFFT_EPSILON, nthreads=nthreads,
                                out=np.empty((pts.shape[0], size, size), dtype=np.complex64))
        return grid[:, 1:, band + 1:].astype(np.complex128)


def _box(h: np.ndarray, g: int, band: int) -> np.ndarray:
    r""":math:`\hat h(k)` on the half box, (C, 2B+1, B+1), of h (G², C) at the grid midpoints
    (the midpoint phase :math:`e^{-\pi i(k_0+k_1)/G}` is common to all parts and dropped)."""
    c = h.shape[1]
    F = np.fft.rfft2(h.T.reshape(c, g, g), axes=(1, 2)) / (g * g)
    rows = np.r_[g - band:g, 0:band + 1]
    return F[:, rows, :band + 1]


@dataclass(frozen=True, eq=False)
class BoxInputs:
    """What :func:`_axis_spectra` needs besides the axis: the map and its sampler, the
    technique (:class:`._techniques.Technique`), the box B, the lobe part's grid
    (:class:`_Grid`, None for map sampling), the map part's nodes (:class:`_MapNodes`, None
    for BRDF sampling) and the NUFFT's threads."""

    envmap: EnvMap
    sampler: MapSampler
    technique: object
    band: int
    grid: _Grid | None
    nodes: _MapNodes | None
    nthreads: int = 1


def _axis_spectra(box: BoxInputs, R: np.ndarray) -> list[np.ndarray]:
    """:math:`\\hat h_i` on the half box for one axis (frame R, third column the axis): a
    list over parts of (C, 2B+1, B+1) — the map part from its nodes (:class:`_MapNodes`;
    those outside the lobe, :data:`LOBE_CUTOFF`, hold h = 0 and are left out), the lobe
    part from the grid."""
    a = R[:, 2]
    tech, weight, out = box.technique, box.technique.weight, []
    if tech.samples_map:
        nodes = box.nodes
        rho = brdf_pdf(weight, rows_dot(nodes.dirs, a))
        active = rho > LOBE_CUTOFF * float(brdf_pdf(weight, 1.0))
        part = tech.map_part(rho[active], nodes.pdf[active])
        out.append(nodes.box(part.factor, active, box.band, box.nthreads))
    if tech.samples_lobe:
        grid = box.grid
        d = rows_times(grid.local, R.T)
        f = box.envmap.lookup(d)
        pm = box.sampler.pdf(d) if tech.name == "mis" else np.ones_like(grid.lobe)
        part = tech.lobe_part(grid.lobe, pm)
        out.append(_box(f * part.factor[:, None], grid.g, box.band))
    return out
