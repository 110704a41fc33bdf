r"""The exact error of a Cranley–Patterson-shifted estimator from the spectrum of its *warped
integrand*: the prediction of envfit for every renderer estimator (map importance sampling,
BRDF sampling, MIS) driven by *any* point set, random or quasi-random.

Every estimator of :mod:`envfit.sampling._importance` is a mean over square points,
:math:`F = \sum_i \frac{1}{n_i}\sum_{j} h_i(u_{ij} + \Delta)`, where technique i (one for map
or BRDF sampling, two for multi-sample MIS) has its *warped integrand*
:math:`h_i(u) = w_i(\omega)\,f(\omega)\rho_a(\omega)/p_i(\omega)` at :math:`\omega = T_i(u)`
(its sampler :math:`T_i`, pdf :math:`p_i`, MIS weight :math:`w_i`; 1 without MIS) and Δ the
shift, uniform on the torus, shared by all points of an axis (:mod:`envfit.sampling._importance`,
``shift=True``). With :math:`h_i(u) = \sum_k \hat h_i(k)e^{2\pi i k\cdot u}` and the point set's
exponential sums :math:`S_i(k) = \frac1{n_i}\sum_j e^{2\pi i k\cdot u_{ij}}`,

.. math::  F - I = \sum_{k\ne0} e^{2\pi i k\cdot\Delta}\sum_i \hat h_i(k) S_i(k), \qquad
           \mathbb E_\Delta (F-I)^2 = \sum_{k\ne 0}\Big|\sum_i \hat h_i(k)S_i(k)\Big|^2

(Parseval on the torus; Cranley & Patterson 1976; for a lattice this is the classical variance
of a randomly shifted lattice rule, Sloan & Joe 1994, Lemma 2.3 — :math:`|S|^2` is 1 on the dual
lattice and 0 elsewhere). The twist α of the BRDF frame about the axis (uniform, as the
estimators draw it) shifts the lobe technique's :math:`u_1` by α/2π, so the cross terms of two
techniques survive only on the column :math:`k_1 = 0`. For i.i.d. uniform points
:math:`\mathbb E|S_i(k)|^2 = 1/n_i` and the formula is the Monte Carlo variance
:math:`\sum_i V_i/n_i`, :math:`V_i = \mathrm{Var}\,h_i` — the exact variance of
:mod:`oracles.is_variance`, which this module reproduces by a second algorithm.

Computation (:func:`warped_spectrum`, once per map, lobe and technique; :func:`shifted_rmse`
then costs one non-uniform FFT per point set):

* :math:`\hat h_i(k)` on the box :math:`|k_0|, |k_1| \le B = G/4`: the map technique's from
  exact per-pixel quadrature nodes (:class:`_MapNodes`), the lobe technique's from :math:`h_i`
  at the midpoints of a :data:`LOBE_OVERSAMPLING`·B square grid (a real FFT; aliasing comes
  only from frequencies above 7B: the lobe part jumps where the map pdf of MIS does, and the
  glossy warp compresses the grazing directions, so a 4B grid over-counts the box — on a
  128-row sun + GP map by 3–8 % for MIS with a diffuse lobe and 3–27 % for glossy BRDF
  sampling at N = 256–1024, against a 16B grid; 8B is within 1–2 % of it);
* :math:`V_i = \int h_i^2 - (\int h_i)^2` by *pixel quadrature in direction space* (each pixel's
  cell integral of the bilinear interpolant's square, exactly :math:`v^\top(M\otimes M)v` over
  its 3×3 neighbourhood, times its solid angle, lobe and pdf at its centre) — exact at a sun a
  few pixels wide, which a grid in the square would sample with a handful of points;
* the frequencies above the box get their share of the variance,
  :math:`V_i - \sum_{box}|\hat h_i|^2`: on the strips beside the axes of frequency space
  (where the square's edges and the sampler's row boundaries put it, and where QMC sets'
  stratified projections have tiny sums) continued as a power law with the set's own sums,
  the rest at the Monte Carlo weight :math:`1/n_i` (the mean of :math:`|S_i|^2` over high
  frequencies for every set; :mod:`envfit.predict.renderer._spectral_tail`): so the prediction is
  exact for random points and for QMC sets up to :math:`N \approx (B/2)^2`, and beyond it
  tends to the Monte Carlo rate (an extrapolation, not a bound: a night map with lamps
  measured 1.48× it; :func:`envfit.advisor._renderer.extrapolation_note`);
* the mean over axes (uniform on the sphere) by importance: ``axes`` axes drawn systematically
  from 2048 spherical Fibonacci axes with probability ⅓ uniform + ⅓ ∝ a proxy of BRDF
  sampling's and ⅓ of map sampling's second moment (an 8×8-pixel-block quadrature of the
  luminance), each weighted by :math:`1/(2048\,\pi_a)` — so the few axes whose lobe holds a sun
  are not missed.

References: R. Cranley, T. N. L. Patterson, "Randomization of number theoretic methods for
multiple integration", SIAM J. Numer. Anal. 13 (1976); I. H. Sloan, S. Joe, *Lattice Methods
for Multiple Integration* (1994); E. Veach, PhD thesis (1997), ch. 9 (MIS).

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> from envfit.theory._pointsets import square_points
>>> m = EnvMap(np.full((8, 16, 3), 0.5))
>>> spec = warped_spectrum(m, "brdf", grid=32, axes=8)       # the lobe sampled exactly
>>> round(shifted_rmse(spec, square_points("sobol", 16)), 6)    # on a constant map: no error
0.0
>>> spec = warped_spectrum(m, "map", grid=32, axes=8)        # uniform directions, cosine lobe
>>> t = shifted_mse_terms(spec, square_points("sobol", 16))
>>> bool(t["box"] + t["tail"] < t["random"])                 # Sobol beats random points
True
"""
from __future__ import annotations

import math
from functools import cached_property
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from scipy import special

from envfit.defaults import DEFAULT_SHININESS, REFERENCE_SPECTRUM_AXES, RENDERER_GRID
from envfit.base._checks import check_int
from envfit.base._resources import check_memory, machine_cores
from envfit.base._errors import ParameterError
from envfit.maps import _latlong as latlong
from envfit.maps._envmap import EnvMap
from envfit.shading._estimators import twisted_frames
from envfit.shading._ground_truth import weight_function
from envfit.sampling._importance import HEURISTICS, brdf_pdf
from envfit.sampling._map_sampler import MapSampler, _bilinear_cell_average, _square
from envfit.sampling._proxies import normalised_moments, proxy_second_moments
from envfit.predict.renderer._spectral_tail import strip_fits, strip_tail
from envfit.theory._pointsets import lambert_to_hemisphere
from envfit.theory._sphere_points import spherical_fibonacci_sphere

__all__ = [
    "SPECTRUM_FORMAT",
    "TECHNIQUES",
    "WarpedSpectrum",
    "cell_square_average",
    "proposal_axes",
    "random_mse",
    "shifted_mse_per_axis",
    "shifted_mse_terms",
    "shifted_rmse",
    "spectrum_nbytes",
    "warped_spectrum",
]

#: the algorithm's version, in the keys of cached spectra (2: the axis proxy's blocks at their
#: Y²ω centroid)
SPECTRUM_FORMAT = 2
#: the strips of the tail are skipped where the power above the box at 1/n is below this
#: fraction of the part's box term (the prediction then moves by less than it)
STRIPS_NEGLIGIBLE = 1e-3
#: the techniques and their number of parts (sample streams)
TECHNIQUES = {"brdf": 1, "map": 1, "mis": 2}
#: spherical Fibonacci axes the importance sample of axes is drawn from
AXIS_POOL = 2048
#: a variance m2 - m1² at most this fraction of m2 is rounding (16 ulps), counted as 0
_ROUNDING = 16.0 * np.finfo(np.float64).eps
#: the lobe technique's grid is this many times the box B per side (see the module docstring)
LOBE_OVERSAMPLING = 8
#: relative accuracy of the map part's single-precision non-uniform FFT
NUFFT_EPSILON = 1e-5
#: nodes whose lobe value is below this fraction of the lobe's peak are left out of the NUFFT
#: (their share of any coefficient is below it too: far below NUFFT_EPSILON)
LOBE_CUTOFF = 1e-9
#: per kind, the last (objects, values, result) of :func:`_last_call`
_LAST: dict = {}


def _last_call(kind: str, objects: tuple, values, make):
    """``make()``, or its result of the last call of this ``kind`` when that call had the
    same ``objects`` (identity) and ``values`` (equality): the spectra of one map and lobe
    (BRDF, map, MIS) share the map technique's nodes (~100 bytes each), the axes, the pixel
    quadrature and the exact axis means. Only the last result of a kind is kept."""
    hit = _LAST.get(kind)
    if hit is not None and all(a is b for a, b in zip(hit[0], objects)) and hit[1] == values:
        return hit[2]
    _LAST.pop(kind, None)                                   # free the old result first
    result = make()
    _LAST[kind] = (objects, values, result)
    return result

# the 1-D mass matrix of a cell [-1/2, 1/2] of a piecewise-linear interpolant of (a, b, c)
# at (-1, 0, 1): ∫ L² = 1/24 a² + 7/12 b² + 1/24 c² + 1/6 (ab + bc)
_MASS = np.array([[1 / 24, 1 / 12, 0.0], [1 / 12, 7 / 12, 1 / 12], [0.0, 1 / 12, 1 / 24]])


# ----------------------------------------------------------------------------- results

@dataclass(frozen=True)
class WarpedSpectrum:
    r"""What :func:`shifted_rmse` needs of a map, lobe and technique (axis- and channel-means).

    Attributes
    ----------
    technique, brdf, shininess, heuristic, fraction : the estimator (``fraction`` = share
        :math:`\nu_1` of the samples given to the map in MIS).
    band : B, the box :math:`|k_0|, |k_1| \le B`; ``grid`` = G = 4B.
    variance : (parts,) :math:`\overline{V_i}`, the mean over axes and channels of
        :math:`\mathrm{Var}\,h_i` (one sample of part i).
    power : (parts, 2B+1, B+1) the mean of :math:`|\hat h_i(k)|^2` on the half box
        :math:`k_1 \ge 0` (row :math:`k_0 + B`), 0 at k = 0.
    cross : (2B+1,) complex, the mean of :math:`\hat h_1(k_0,0)\overline{\hat h_2(k_0,0)}`
        (MIS; zeros otherwise), 0 at :math:`k_0 = 0`.
    mean : the mean over axes and channels of the shading integral I.
    axes : the number of axes sampled.
    """

    technique: str
    brdf: str
    shininess: float | None
    heuristic: str
    fraction: float
    band: int
    grid: int
    variance: np.ndarray
    power: np.ndarray
    cross: np.ndarray
    mean: float
    axes: int

    @cached_property
    def strip_fits(self) -> list:
        """Per part, the power laws of the strips above the box
        (:func:`envfit.predict.renderer._spectral_tail.strip_fits`), fitted once per spectrum."""
        return [strip_fits(p) for p in self.power]

    def to_json(self) -> dict:
        """Every field as JSON-able values, the cache format of :data:`SPECTRUM_FORMAT`
        (arrays as nested float64 lists, ``cross`` as ``{"real": …, "imag": …}``);
        :meth:`from_json` inverts it exactly."""
        return {"technique": self.technique, "brdf": self.brdf, "shininess": self.shininess,
                "heuristic": self.heuristic, "fraction": float(self.fraction),
                "band": int(self.band), "grid": int(self.grid),
                "variance": np.asarray(self.variance, dtype=np.float64).tolist(),
                "power": np.asarray(self.power, dtype=np.float64).tolist(),
                "cross": {"real": np.real(self.cross).astype(np.float64).tolist(),
                          "imag": np.imag(self.cross).astype(np.float64).tolist()},
                "mean": float(self.mean), "axes": int(self.axes)}

    @classmethod
    def from_json(cls, d: dict) -> "WarpedSpectrum":
        """The spectrum of :meth:`to_json`'s dict.

        Raises
        ------
        envfit.base._errors.ParameterError
            A dict whose arrays do not have the shapes of its band and technique.
        """
        try:
            band = int(d["band"])
            power = np.asarray(d["power"], dtype=np.float64)
            variance = np.asarray(d["variance"], dtype=np.float64)
            re = np.asarray(d["cross"]["real"], dtype=np.float64)
            im = np.asarray(d["cross"]["imag"], dtype=np.float64)
            parts = variance.shape[0]
            if power.shape != (parts, 2 * band + 1, band + 1) or re.shape != (2 * band + 1,) \
                    or im.shape != re.shape:
                raise ValueError("shapes")
            cross = np.empty(re.shape, dtype=np.complex128)
            cross.real, cross.imag = re, im
            return cls(technique=str(d["technique"]), brdf=str(d["brdf"]),
                       shininess=None if d["shininess"] is None else float(d["shininess"]),
                       heuristic=str(d["heuristic"]), fraction=float(d["fraction"]),
                       band=band, grid=int(d["grid"]), variance=variance, power=power,
                       cross=cross, mean=float(d["mean"]), axes=int(d["axes"]))
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise ParameterError(f"not a stored warped spectrum ({exc})") from None

    def to_dict(self) -> dict:
        """The scalars (not the spectra), for JSON reports (:meth:`to_json`: the whole
        spectrum, for the cache)."""
        return {"technique": self.technique, "brdf": self.brdf, "shininess": self.shininess,
                "heuristic": self.heuristic, "fraction": self.fraction, "band": self.band,
                "grid": self.grid, "variance": [float(v) for v in self.variance],
                "box_share": [float(_box_sum(p) / v) if v > 0 else 0.0
                              for p, v in zip(self.power, self.variance)],
                "mean": self.mean, "axes": self.axes}


# ----------------------------------------------------------------------------- pixels

def _neighbours(y: np.ndarray) -> list[list[np.ndarray]]:
    """The 3×3 neighbourhood of every pixel (H, W, …), rows across the poles at φ + π."""
    w = y.shape[1]
    up = np.concatenate([np.roll(y[:1], w // 2, axis=1), y[:-1]], axis=0)
    down = np.concatenate([y[1:], np.roll(y[-1:], w // 2, axis=1)], axis=0)
    return [[np.roll(r, 1, axis=1), r, np.roll(r, -1, axis=1)] for r in (up, y, down)]


def cell_square_average(data: np.ndarray) -> np.ndarray:
    r"""Mean of the *square* of the bilinear interpolant over each pixel cell, (H, W, …).

    In pixel coordinates the interpolant is :math:`\sum v_{kl}\phi_k(x)\phi_l(y)` with hat
    functions, so over the cell :math:`[-\frac12,\frac12]^2` of a pixel
    :math:`\int L^2 = \sum_{ijkl} v_{ij}v_{kl}M_{ik}M_{jl}` over its 3×3 neighbourhood, M the
    1-D mass matrix (1/24, 7/12, 1/24 on the diagonal, 1/12 beside it); columns wrap and the
    rows beyond the poles are the edge rows at φ + π (as the lookup).

    >>> a = np.zeros((4, 8)); a[1, 2] = 1.0
    >>> round(float(cell_square_average(a).sum()), 12)            # ∫ hat² = (2/3)²
    0.444444444444
    """
    v = _neighbours(np.asarray(data, dtype=np.float64))
    out = np.zeros_like(v[1][1])
    for i in range(3):
        for k in range(3):
            if _MASS[i, k] == 0.0:
                continue
            for j in range(3):
                for m in range(3):
                    if _MASS[j, m] != 0.0:
                        out += _MASS[i, k] * _MASS[j, m] * v[i][j] * v[k][m]
    return out


def _cell_average(data: np.ndarray) -> np.ndarray:
    """Mean of the bilinear interpolant over each pixel cell, (H, W, C): the sampler's own
    :func:`envfit.sampling._map_sampler._bilinear_cell_average`, per channel."""
    d = np.asarray(data, dtype=np.float64)
    return np.stack([_bilinear_cell_average(d[..., c]) for c in range(d.shape[-1])], axis=-1)


def _subdivision(envmap: EnvMap, weight) -> int:
    r"""Sub-nodes per pixel side so that a pixel is at most 1/8 of the lobe's angular width
    (glossy :math:`\sqrt{2/n}`, diffuse 1 rad), at most 16 and ~4M nodes."""
    width = min(1.0, math.sqrt(2.0 / weight.shininess)) if getattr(weight, "shininess", None) \
        else 1.0
    sub = math.ceil(8.0 * (math.pi / envmap.height) / width)
    cap = max(1, int(math.sqrt(4e6 / (envmap.height * envmap.width))))
    return int(max(1, min(sub, 16, cap)))


class _Pixels:
    """Direction-space quadrature nodes: directions (P, 3), ∫L and ∫L² per node cell (P, C),
    the map pdf (P,). One node per pixel with the cell-exact moments of the bilinear
    interpolant, or ``sub``² nodes per pixel (L looked up) where the lobe is narrow."""

    def __init__(self, envmap: EnvMap, sampler: MapSampler, sub: int = 1):
        h, w, c = envmap.data.shape
        if sub == 1:
            om = latlong.pixel_solid_angles(h, w).reshape(-1, 1)
            self.dirs = latlong.pixel_directions(h, w, up=envmap.up).reshape(-1, 3)
            self.first = _cell_average(envmap.data).reshape(-1, c) * om
            self.second = cell_square_average(envmap.data).reshape(-1, c) * om
            self.pdf = sampler.pixel_pdf.reshape(-1)
            self.area = om[:, 0]
            return
        hs, ws = h * sub, w * sub
        om = latlong.pixel_solid_angles(hs, ws).reshape(-1, 1)
        self.dirs = latlong.pixel_directions(hs, ws, up=envmap.up).reshape(-1, 3)
        L = envmap.lookup(self.dirs)
        self.first, self.second, self.area = L * om, L * L * om, om[:, 0]
        self.pdf = np.repeat(np.repeat(sampler.pixel_pdf, sub, axis=0), sub, axis=1).reshape(-1)


# ----------------------------------------------------------------------------- techniques

def _over(heur, q, i):
    return heur.over_q(q, i)


def _part_terms(technique: str, weight, nu, heur, rho, pm):
    r"""Per part i: (factor, pdf) with :math:`h_i = f\cdot` factor and :math:`p_i` = pdf.

    ``rho`` = :math:`\rho_a` and ``pm`` = map pdf at the same directions; for the map part
    its pdf is ``pm``, for the lobe part ρ (the lobe is sampled exactly).
    """
    if technique == "map":
        return [(np.divide(rho, pm, out=np.zeros_like(rho), where=pm > 0), pm)]
    if technique == "brdf":
        return [(np.where(rho > 0, 1.0, 0.0), rho)]
    q = np.stack([nu[0] * pm, nu[1] * rho])
    return [(nu[0] * rho * _over(heur, q, 0), pm), (nu[1] * rho * _over(heur, q, 1), rho)]


@dataclass(frozen=True)
class _Lobe:
    """The pixels in an axis' lobe (``on``) and, there, ρ_a, the map pdf and the moments."""
    on: np.ndarray
    rho: np.ndarray
    pdf: np.ndarray
    first: np.ndarray
    second: np.ndarray
    area: np.ndarray


def _pixel_lobe(px: _Pixels, weight, a) -> _Lobe:
    """The pixels in the lobe of axis a, gathered once for every technique's moments."""
    rho = brdf_pdf(weight, latlong.rows_dot(px.dirs, a))
    on = np.flatnonzero(rho > 0)
    return _Lobe(on, rho[on], px.pdf[on], px.first[on], px.second[on], px.area[on])


def _pixel_moments(px: _Pixels, technique, weight, nu, heur, a, lobe: _Lobe | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    r"""(V (parts, C), I (C,)) for axis a by direction-space quadrature Q: with
    :math:`h_i = f\,\mathrm{factor}_i` sampled with density :math:`p_i`,
    :math:`V_i = Q[h_i^2p_i]/Q[p_i] - (Q[h_ip_i]/Q[p_i])^2` — the variance under the
    normalised discrete measure (never negative), free of the error
    :math:`\int h^2 - (\int h)^2` would take from a quadrature of :math:`\int p_i` off 1
    (a narrow lobe on a coarse map). ``lobe``: :func:`_pixel_lobe` of a, when known."""
    lb = _pixel_lobe(px, weight, a) if lobe is None else lobe
    V, total = [], 0.0
    for i, (factor, p) in enumerate(_part_terms(technique, weight, nu, heur, lb.rho, lb.pdf)):
        lobe_part = technique == "brdf" or (technique == "mis" and i == 1)
        q = float(p @ lb.area) if lobe_part else float(px.pdf @ px.area)
        fp = factor * p                           # einsum, not BLAS: see latlong.rows_dot
        m1 = np.einsum("i,ic->c", fp, lb.first) / q
        m2 = np.einsum("i,ic->c", fp * factor, lb.second) / q
        # m2 - m1² below the rounding of m2 is no variance (a constant integrand)
        V.append(np.where(m2 - m1 * m1 > _ROUNDING * m2, m2 - m1 * m1, 0.0))
        total = total + m1
    return np.array(V), total


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
    on a 1024×512 map with a sun to agree to 5 %).
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

    @classmethod
    def of(cls, envmap: EnvMap, sampler: MapSampler, band: int) -> "_MapNodes":
        """The nodes of ``sampler``'s map for box ``band``, reused from the last call for the
        same map, sampler and band (the map and MIS spectra share them)."""
        return _last_call("nodes", (envmap, sampler), band, lambda: cls(envmap, sampler, band))

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


def _axis_spectra(grid: _Grid, nodes, envmap, sampler, technique, weight, nu, heur, R, band,
                  nthreads: int = 1):
    """:math:`\\hat h_i` on the half box for one axis (frame R, third column the axis): a
    list over parts of (C, 2B+1, B+1) — the map part from its nodes (:class:`_MapNodes`;
    those outside the lobe, :data:`LOBE_CUTOFF`, hold h = 0 and are left out), the lobe
    part from the grid."""
    a = R[:, 2]
    out = []
    if technique in ("map", "mis"):
        rho = brdf_pdf(weight, latlong.rows_dot(nodes.dirs, a))
        active = rho > LOBE_CUTOFF * float(brdf_pdf(weight, 1.0))
        factor, _ = _part_terms(technique, weight, nu, heur, rho[active],
                                nodes.pdf[active])[0]
        out.append(nodes.box(factor, active, band, nthreads))
    if technique in ("brdf", "mis"):
        d = latlong.rows_times(grid.local, R.T)
        f = envmap.lookup(d)
        pm = sampler.pdf(d) if technique == "mis" else np.ones_like(grid.lobe)
        factor, _ = _part_terms(technique, weight, nu, heur, grid.lobe, pm)[-1]
        out.append(_box(f * factor[:, None], grid.g, band))
    return out


# ----------------------------------------------------------------------------- axes

def _fibonacci_axes(m: int) -> np.ndarray:
    """The m spherical Fibonacci axes of :func:`envfit.theory._sphere_points.spherical_fibonacci_sphere`
    in a *serpentine* order: √(m/2) bands of z, φ ascending in even bands and descending in
    odd ones, so that neighbours in the order are neighbours on the sphere and systematic
    sampling along it stratifies the sphere."""
    pts = spherical_fibonacci_sphere(m)
    phi = np.mod(np.arctan2(pts[:, 1], pts[:, 0]), 2.0 * np.pi)
    bands = max(1, round(math.sqrt(m / 2.0)))
    band = np.minimum((0.5 * (1.0 - pts[:, 2]) * bands).astype(int), bands - 1)
    return pts[np.lexsort((np.where(band % 2 == 0, phi, -phi), band))]


def proposal_axes(envmap: EnvMap, sampler: MapSampler, weight, count: int):
    r"""``count`` axes and their weights for the mean over uniform axes (weights sum to 1).

    Systematic sampling of the :data:`AXIS_POOL` spherical Fibonacci axes with probability
    :math:`\pi_a = \frac13\frac1P + \frac13\frac{m_a}{\sum m} + \frac13\frac{m'_a}{\sum m'}`
    (m, m′ the BRDF- and map-sampling second moments of the luminance, block quadrature);
    weight :math:`1/(P\pi_a\,\mathrm{count})`. Unbiased for the pool mean; the weights are at
    most 3/count.

    >>> from envfit.maps._envmap import EnvMap
    >>> m = EnvMap(np.ones((8, 16, 1)))
    >>> from envfit.shading._ground_truth import weight_function
    >>> A, wts = proposal_axes(m, MapSampler(m), weight_function("diffuse", 30.0), 16)
    >>> A.shape, round(float(wts.sum()), 9)
    ((16, 3), 1.0)
    """
    pool = _fibonacci_axes(AXIS_POOL)
    lobe = (type(weight).__name__, getattr(weight, "shininess", None))
    moments = _last_call("proxy", (envmap, sampler), lobe,
                         lambda: proxy_second_moments(envmap, sampler, weight, pool))
    pi = (np.full(AXIS_POOL, 1.0 / AXIS_POOL) + sum(normalised_moments(moments))) / 3.0
    cdf = np.cumsum(pi)
    cdf /= cdf[-1]
    idx = np.minimum(np.searchsorted(cdf, (np.arange(count) + 0.5) / count), AXIS_POOL - 1)
    wts = 1.0 / (AXIS_POOL * pi[idx] * count)
    return pool[idx], wts / wts.sum()


# ----------------------------------------------------------------------------- the spectrum

def _check(envmap, technique, grid, heuristic, fraction):
    if not isinstance(envmap, EnvMap):
        raise ParameterError(f"envmap must be an EnvMap, got {type(envmap).__name__}")
    if technique not in TECHNIQUES:
        raise ParameterError(f"technique must be one of {', '.join(TECHNIQUES)}; "
                             f"got {technique!r}")
    g = check_int(grid, "grid", 8)
    if g % 4:
        raise ParameterError(f"grid must be a multiple of 4, got {grid}")
    if heuristic not in HEURISTICS:
        raise ParameterError(f"heuristic must be one of {', '.join(HEURISTICS)}; "
                             f"got {heuristic!r}")
    nu1 = float(fraction)
    if not 0.0 < nu1 < 1.0:
        raise ParameterError(f"fraction must be in (0, 1), got {fraction!r}")
    return g, np.array([nu1, 1.0 - nu1]), HEURISTICS[heuristic]


def _lobe_square_mean(weight) -> float:
    r""":math:`c_2 = \frac1{4\pi}\int_{S^2}\rho_a(\omega)^2\,da = \frac12\int_0^1\rho(z)^2dz`,
    the mean over uniform axes of the squared lobe at a fixed direction (Gauss–Legendre)."""
    x, w = special.roots_legendre(400)
    z = 0.5 * (x + 1.0)
    return float(0.25 * np.sum(w * brdf_pdf(weight, z) ** 2))


def exact_mean_variances(envmap: EnvMap, px: _Pixels, weight) -> dict:
    r"""The mean over *all* axes of the one-sample variances of BRDF and map sampling, in
    closed form — no axis sampling:

    .. math:: \overline{V}_\mathrm{brdf} = \frac1{4\pi}\int f^2\,d\omega - \overline{I^2},
              \qquad
              \overline{V}_\mathrm{map} = c_2\int \frac{f^2}{p}\,d\omega - \overline{I^2},

    since the mean over axes of :math:`\rho_a(\omega)` is :math:`1/4\pi` and of
    :math:`\rho_a(\omega)^2` is :math:`c_2` (:func:`_lobe_square_mean`) at every direction;
    :math:`\int f^2` and :math:`\int f^2/p` by the pixels' cell-exact squares, and
    :math:`\overline{I^2}` over the :data:`AXIS_POOL` Fibonacci axes by the exact SH
    integrator (:func:`envfit.shading._ground_truth.shading_integral`, smooth in the axis).
    Means over channels."""
    from envfit.shading._ground_truth import shading_integral

    I = shading_integral(envmap, _fibonacci_axes(AXIS_POOL), weight)
    i2 = (I * I).mean(axis=0)
    second = px.second.sum(axis=0)
    over_p = (px.second / px.pdf[:, None]).sum(axis=0)
    return {"brdf": float(np.mean(second / (4.0 * np.pi) - i2)),
            "map": float(np.mean(_lobe_square_mean(weight) * over_p - i2))}


def _axis_terms(m, A, R, px, grid, nodes, envmap, sampler, technique, weight, nu, heur, band,
                calibrate, nthreads):
    """Axis m's unweighted terms: V (parts,), I, the sampled BRDF/map variances (calibration),
    |ĥ_i|² (parts, 2B+1, B+1) and the k₁ = 0 cross term — channel means."""
    lobe = _pixel_lobe(px, weight, A[m])
    v, tot = _pixel_moments(px, technique, weight, nu, heur, A[m], lobe)
    sampled = {}
    if calibrate:
        for t in ("brdf", "map"):
            vt = v if t == technique else _pixel_moments(px, t, weight, nu, heur, A[m], lobe)[0]
            sampled[t] = float(vt.mean())
    H = _axis_spectra(grid, nodes, envmap, sampler, technique, weight, nu, heur, R[m], band,
                      nthreads)
    P = np.stack([(np.abs(h) ** 2).mean(axis=0) for h in H])
    X = (H[0][:, :, 0] * np.conj(H[1][:, :, 0])).mean(axis=0) if len(H) == 2 else None
    return v.mean(axis=1), float(tot.mean()), sampled, P, X


def _accumulate(envmap, sampler, technique, weight, nu, heur, g, A, wts, calibrate=False):
    """Weighted sums over axes of V, |ĥ|², the k₁ = 0 cross term and I; with ``calibrate``
    rescaled by the ratio estimator of :func:`_calibration`. The axes run on all cores
    (threads: the work is numpy and ducc0, which release the GIL), summed in axis order
    (the same result for any number of threads)."""
    band = g // 4
    grid = _Grid(weight, LOBE_OVERSAMPLING * band) if technique != "map" else None
    nodes = _MapNodes.of(envmap, sampler, band) if technique != "brdf" else None
    sub = _subdivision(envmap, weight)
    px = _last_call("pixels", (envmap, sampler), sub, lambda: _Pixels(envmap, sampler, sub))
    R = twisted_frames(A, None)
    workers = min(machine_cores(), A.shape[0])
    args = (A, R, px, grid, nodes, envmap, sampler, technique, weight, nu, heur, band,
            calibrate, max(1, machine_cores() // workers))
    if workers == 1:
        terms = [_axis_terms(m, *args) for m in range(A.shape[0])]
    else:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            terms = list(pool.map(lambda m: _axis_terms(m, *args), range(A.shape[0])))
    V = sum(w * t[0] for w, t in zip(wts, terms))
    mean = float(sum(w * t[1] for w, t in zip(wts, terms)))
    P = sum(w * t[3] for w, t in zip(wts, terms))
    X = (sum(w * t[4] for w, t in zip(wts, terms)) if TECHNIQUES[technique] == 2
         else np.zeros(2 * band + 1, dtype=complex))
    P[:, band, 0] = 0.0
    X[band] = 0.0
    if calibrate:
        sampled = {k: sum(w * t[2][k] for w, t in zip(wts, terms)) for k in ("brdf", "map")}
        lobe = (type(weight).__name__, getattr(weight, "shininess", None), sub)
        exact = _last_call("exact", (envmap, sampler), lobe,
                           lambda: exact_mean_variances(envmap, px, weight))
        r = _calibration(technique, exact, sampled)
        V, P, X = V * r, P * r[:, None, None], X * (math.sqrt(r[0] * r[-1]))
    return band, V, P, X, mean


def _calibration(technique: str, exact: dict, sampled: dict) -> np.ndarray:
    r"""Per part, the ratio exact/sampled mean variance of the technique it samples with
    (map part: map sampling, lobe part: BRDF sampling): a ratio estimator that removes the
    axis-sampling error of the importance sample where the closed form of
    :func:`exact_mean_variances` is known, and keeps its estimate of the *shape* (the box's
    share of the variance, the QMC gain)."""
    keys = {"brdf": ["brdf"], "map": ["map"], "mis": ["map", "brdf"]}[technique]
    return np.array([exact[k] / sampled[k] if sampled[k] > 0 and exact[k] > 0 else 1.0
                     for k in keys])


#: bytes per pixel of one spectrum (the map technique's quadrature nodes and their
#: construction, the pixel moments, the per-axis lobe gathers) and per point of the lobe's
#: (2G)² grid: +775 MB on a 1024x512 map and +1359 MB on a 2048x1024 one (MIS, G = 512)
SPECTRUM_BYTES_PER_PIXEL, SPECTRUM_BYTES_PER_GRID_POINT = 370, 550


def spectrum_nbytes(height: int, grid: int) -> int:
    """Predicted peak bytes of one :func:`warped_spectrum` on a 2H x H map at grid G:
    ``370 x 2H^2 + 550 x (2G)^2`` (measured, MIS, the costliest technique).

    >>> round(spectrum_nbytes(1024, 512) / 1e6)
    1353
    """
    h, g = int(height), int(grid)
    return SPECTRUM_BYTES_PER_PIXEL * 2 * h * h + SPECTRUM_BYTES_PER_GRID_POINT * 4 * g * g


def warped_spectrum(envmap: EnvMap, technique: str = "mis", brdf="diffuse",
                    shininess: float = DEFAULT_SHININESS, *, sampler: MapSampler | None = None,
                    grid: int = RENDERER_GRID, axes: int = REFERENCE_SPECTRUM_AXES,
                    heuristic: str = "balance",
                    fraction: float = 0.5) -> WarpedSpectrum:
    r"""The warped integrand's spectrum and variance of ``technique`` on ``envmap``, mean
    over uniform axes (module docstring), for :func:`shifted_rmse`.

    Parameters
    ----------
    envmap : the map (its bilinear interpolant is integrated).
    technique : "brdf", "map" or "mis" (:data:`TECHNIQUES`; multi-sample MIS).
    brdf, shininess : the lobe (:func:`envfit.shading._ground_truth.weight_function`).
    sampler : the map's :class:`MapSampler` (its defaults when None) — the same one the
        estimator uses.
    grid : G, a multiple of 4; the box is B = G/4 (QMC predictions exact to N ≈ (B/2)²).
    axes : axes of the importance sample over the sphere (:func:`proposal_axes`).
    heuristic, fraction : MIS heuristic (:data:`envfit.sampling._importance.HEURISTICS`) and
        the map's share ν₁ of the samples.

    Work: per axis (2G)² lookups and a real FFT of (2G)² per channel for the lobe part (BRDF,
    MIS), one single-precision NUFFT of the map part's nodes (map, MIS; ≈ (2πB)² + πB(H + W)
    + HW of them, 1.5 M on a 1024×512 map at G = 512), and a pass over the pixels; the axes
    run on all cores.

    >>> m = EnvMap(np.full((8, 16, 1), 2.0))
    >>> s = warped_spectrum(m, "brdf", grid=16, axes=4)
    >>> s.power.shape, float(s.variance[0]) < 1e-20, round(s.mean, 12)
    ((1, 9, 5), True, 2.0)
    """
    g, nu, heur = _check(envmap, technique, grid, heuristic, fraction)
    check_memory(spectrum_nbytes(envmap.height, g),
                 f"the warped spectrum ({technique}) of a {envmap.width}x{envmap.height} map at "
                 f"grid {g}", hint="use a smaller grid or downsample the map (--max-height)")
    weight = weight_function(brdf, shininess)
    sampler = MapSampler(envmap) if sampler is None else sampler
    A, wts = proposal_axes(envmap, sampler, weight, check_int(axes, "axes", 1))
    band, V, P, X, mean = _accumulate(envmap, sampler, technique, weight, nu, heur, g, A, wts,
                                      calibrate=True)
    return WarpedSpectrum(technique=technique, brdf=str(brdf),
                          shininess=None if str(brdf) == "diffuse" else float(shininess),
                          heuristic=heuristic, fraction=float(nu[0]), band=band, grid=g,
                          variance=V, power=P, cross=X, mean=float(mean),
                          axes=int(A.shape[0]))


# ----------------------------------------------------------------------------- prediction

def _box_sum(half: np.ndarray) -> float:
    """Sum over the full box of a symmetric quantity given on its half k₁ ≥ 0."""
    return float(half[:, 0].sum() + 2.0 * half[:, 1:].sum())


def _exp_sums(u: np.ndarray, band: int) -> np.ndarray:
    r""":math:`S(k) = \frac1n\sum_j e^{2\pi i k\cdot u_j}` on the half box (2B+1, B+1)."""
    import ducc0

    n = u.shape[0]
    size = 2 * band + 2                                    # modes −B−1 … B
    out = np.zeros((size, size), dtype=np.complex128)
    ducc0.nufft.nu2u(points=np.ones(n, dtype=np.complex128), coord=2.0 * np.pi * u,
                     forward=False, epsilon=1e-10, out=out, nthreads=1)
    return out[1:, band + 1:] / n


def _split_points(spec: WarpedSpectrum, u) -> list[np.ndarray]:
    """The point sets of the parts: one set; for MIS the first round(ν₁N) points and the rest,
    or a given pair (u_map, u_brdf) (as :func:`envfit.sampling._importance.mis_estimates`)."""
    if TECHNIQUES[spec.technique] == 1:
        return [_square(u)]
    if isinstance(u, (tuple, list)) and len(u) == 2 and np.ndim(u[0]) == 2:
        parts = [_square(u[0], "u_map"), _square(u[1], "u_brdf")]
    else:
        U = _square(u)
        n1 = int(np.floor(spec.fraction * U.shape[0] + 0.5))
        parts = [U[:n1], U[n1:]]
    if min(p.shape[0] for p in parts) == 0:
        raise ParameterError("MIS needs at least one point for each technique")
    return parts


def shifted_mse_terms(spec: WarpedSpectrum, u) -> dict:
    r"""The terms of the predicted mean squared error of the shifted estimator with the
    points u: ``box`` :math:`\sum_i\sum_{box}|\hat h_i|^2|S_i|^2` (+ the MIS cross term),
    ``tail`` the power above the box, :math:`\max(V_i - \sum_{box}|\hat h_i|^2, 0)`, with
    the strips along the axes continued with the set's sums and the rest at 1/n_i
    (:func:`envfit.predict.renderer._spectral_tail.strip_tail`), ``random``
    :math:`\sum_i V_i/n_i` (what i.i.d. points would give)."""
    pts = _split_points(spec, u)
    box = tail = rnd = 0.0
    S = []
    for i, p in enumerate(pts):
        n = p.shape[0]
        s = _exp_sums(p, spec.band)
        S.append(s)
        part_box = _box_sum(spec.power[i] * np.abs(s) ** 2)
        box += part_box
        above = strip_tail(spec.power[i], float(spec.variance[i]), p,
                           negligible=STRIPS_NEGLIGIBLE * part_box, fits=spec.strip_fits[i])
        tail += above["strips"] + above["rest"]
        rnd += float(spec.variance[i]) / n
    if len(S) == 2:
        box += 2.0 * float(np.real(spec.cross * S[0][:, 0] * np.conj(S[1][:, 0])).sum())
    return {"box": box, "tail": tail, "random": rnd}


def random_mse(spec: WarpedSpectrum, u) -> float:
    r"""The Monte Carlo variance :math:`\sum_i V_i/n_i` of i.i.d. points of the sizes of u
    (``random`` of :func:`shifted_mse_terms`, without the exponential sums)."""
    return float(sum(float(v) / p.shape[0] for v, p in zip(spec.variance, _split_points(spec, u))))


def shifted_rmse(spec: WarpedSpectrum, u) -> float:
    r"""Predicted RMSE over uniform axes, channels, shifts and twists of the estimator
    ``spec.technique`` with the square points u (any set; a pair (u_map, u_brdf) for MIS):
    :math:`(\text{box} + \text{tail})^{1/2}` of :func:`shifted_mse_terms`.

    >>> m = EnvMap(np.full((8, 16, 1), 2.0))
    >>> shifted_rmse(warped_spectrum(m, "brdf", grid=16, axes=4), np.full((4, 2), 0.3))
    0.0
    """
    t = shifted_mse_terms(spec, u)
    return math.sqrt(max(t["box"] + t["tail"], 0.0))


def shifted_mse_per_axis(envmap: EnvMap, axes, u, technique: str = "mis", brdf="diffuse",
                         shininess: float = DEFAULT_SHININESS, *, sampler: MapSampler | None = None,
                         grid: int = RENDERER_GRID, heuristic: str = "balance",
                         fraction: float = 0.5) -> np.ndarray:
    """The predicted mean squared error (over shifts, twists and channels) at each given
    axis, (M,) — the per-axis form of :func:`shifted_rmse`, for checks against brute force.

    >>> m = EnvMap(np.full((8, 16, 1), 2.0))
    >>> shifted_mse_per_axis(m, [[0, 1.0, 0]], np.full((4, 2), 0.3), "brdf", grid=16).tolist()
    [0.0]
    """
    g, nu, heur = _check(envmap, technique, grid, heuristic, fraction)
    weight = weight_function(brdf, shininess)
    sampler = MapSampler(envmap) if sampler is None else sampler
    from envfit.base._checks import as_unit_vectors

    A = as_unit_vectors(axes, name="axes")
    out = np.empty(A.shape[0])
    for m in range(A.shape[0]):
        band, V, P, X, mean = _accumulate(envmap, sampler, technique, weight, nu, heur, g,
                                          A[m:m + 1], np.ones(1))
        spec = WarpedSpectrum(technique, str(brdf), None, heuristic, float(nu[0]), band, g,
                              V, P, X, mean, 1)
        t = shifted_mse_terms(spec, u)
        out[m] = t["box"] + t["tail"]
    return out
