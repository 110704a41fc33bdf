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
  exact per-pixel quadrature nodes (:class:`._box_spectra._MapNodes`), the lobe technique's
  from :math:`h_i` at the midpoints of a :data:`._box_spectra.LOBE_OVERSAMPLING`·B square
  grid (a real FFT; aliasing comes only from frequencies above 7B: the lobe part jumps
  where the map pdf of MIS does, and the glossy warp compresses the grazing directions, so
  a 4B grid over-counts the box — on a 128-row sun + GP map by 3–8 % for MIS with a diffuse
  lobe and 3–27 % for glossy BRDF sampling at N = 256–1024, against a 16B grid; 8B is
  within 1–2 % of it);
* :math:`V_i = \int h_i^2 - (\int h_i)^2` by *pixel quadrature in direction space* (each pixel's
  cell integral of the bilinear interpolant's square, exactly :math:`v^\top(M\otimes M)v` over
  its 3×3 neighbourhood, times its solid angle, lobe and pdf at its centre) — exact at a sun a
  few pixels wide, which a grid in the square would sample with a handful of points;
* the frequencies above the box get their share of the variance,
  :math:`V_i - \sum_{box}|\hat h_i|^2`: on the strips beside the axes of frequency space
  (where the square's edges and the sampler's row boundaries put it, and where QMC sets'
  stratified projections have tiny sums) continued as a power law with the set's own sums,
  the rest at the Monte Carlo weight :math:`1/n_i` (the mean of :math:`|S_i|^2` over high
  frequencies for every set; :mod:`envfit.predict.warped._spectral_tail`): so the prediction is
  exact for random points and for QMC sets up to :math:`N \approx (B/2)^2`, and beyond it
  tends to the Monte Carlo rate (an extrapolation, not a bound: a night map with lamps
  measured 1.48× it; :func:`envfit.advisor._rule_rows.extrapolation_note`);
* the mean over axes (uniform on the sphere) by importance: ``axes`` axes drawn systematically
  from 2048 spherical Fibonacci axes with probability ⅓ uniform + ⅓ ∝ a proxy of BRDF
  sampling's and ⅓ of map sampling's second moment (an 8×8-pixel-block quadrature of the
  luminance), each weighted by :math:`1/(2048\,\pi_a)` — so the few axes whose lobe holds a sun
  are not missed.

The pieces, one module each (the spectrum's public names are all reachable from this one):

* :mod:`._techniques` — the techniques' parts: :math:`h_i = f\cdot\mathrm{factor}_i`, density
  :math:`p_i` (:class:`~._techniques.Technique`);
* :mod:`._box_spectra` — :math:`\hat h_i(k)` on the box for one axis (map nodes, lobe grid);
* :mod:`._pixel_moments` — :math:`V_i` by pixel quadrature, and its exact axis means;
* :mod:`._axis_proposal` — the importance sample of axes (:func:`proposal_axes`);
* :mod:`._axis_mean` — the per-axis terms (:class:`~._axis_mean.AxisTerms`), their weighted
  sums and calibration;
* :mod:`._spectrum_inputs` — :class:`SpectrumInputs`, what the spectra of one map share
  (nodes, pixel quadrature, exact means, axis proxies), built once per map by the caller;
* :mod:`._prediction_sums` — the error of a point set from a spectrum (:func:`shifted_rmse`);
* :mod:`._warped_integrand` — :math:`h_i(u)` itself at given points (:func:`warped_integrand`).

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

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from envfit.defaults import DEFAULT_SHININESS, REFERENCE_SPECTRUM_AXES, RENDERER_GRID
from envfit.base import ParameterError
from envfit.base import as_unit_vectors, check_int
from envfit.base import check_memory
from envfit.maps import EnvMap
from envfit.sampling import MapSampler
from envfit.shading import weight_function
from envfit.predict.warped._axis_mean import AxisSums, _accumulate
from envfit.predict.warped._axis_proposal import proposal_axes
from envfit.predict.warped._pixel_moments import cell_square_average
from envfit.predict.warped._prediction_sums import (_box_sum, random_mse, shifted_mse_terms,
                                                      shifted_rmse)
from envfit.predict.warped._spectral_tail import strip_fits
from envfit.predict.warped._spectrum_inputs import SpectrumInputs
from envfit.predict.warped._techniques import TECHNIQUES, Technique, check_options
from envfit.predict.warped._warped_integrand import warped_integrand

__all__ = [
    "SPECTRUM_FORMAT",
    "TECHNIQUES",
    "SpectrumInputs",
    "WarpedSpectrum",
    "cell_square_average",
    "proposal_axes",
    "random_mse",
    "shifted_mse_per_axis",
    "shifted_mse_terms",
    "shifted_rmse",
    "spectrum_nbytes",
    "warped_integrand",
    "warped_spectrum",
]

#: the algorithm's version, in the keys of cached spectra (2: the axis proxy's blocks at their
#: Y²ω centroid)
SPECTRUM_FORMAT = 2


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
        (:func:`envfit.predict.warped._spectral_tail.strip_fits`), fitted once per spectrum."""
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




def _inputs(envmap: EnvMap, sampler: MapSampler | None,
            inputs: SpectrumInputs | None) -> SpectrumInputs:
    """The given ``inputs`` (checked against the map and sampler), or new ones."""
    if inputs is None:
        return SpectrumInputs.of(envmap, sampler)
    if not isinstance(inputs, SpectrumInputs):
        raise ParameterError(f"inputs must be SpectrumInputs, got {type(inputs).__name__}")
    inputs.check(envmap, sampler)
    return inputs


def _spectrum(sums: AxisSums, technique: Technique, brdf, shininess, heuristic: str,
              g: int, axes: int) -> WarpedSpectrum:
    """The :class:`WarpedSpectrum` of the calibrated sums over ``axes`` axes."""
    return WarpedSpectrum(technique=technique.name, brdf=str(brdf),
                          shininess=None if str(brdf) == "diffuse" else float(shininess),
                          heuristic=heuristic, fraction=float(technique.nu[0]),
                          band=sums.band, grid=g, variance=sums.variance, power=sums.power,
                          cross=sums.cross, mean=float(sums.mean), axes=int(axes))


def warped_spectrum(envmap: EnvMap, technique: str = "mis", brdf="diffuse",
                    shininess: float = DEFAULT_SHININESS, *, sampler: MapSampler | None = None,
                    grid: int = RENDERER_GRID, axes: int = REFERENCE_SPECTRUM_AXES,
                    heuristic: str = "balance", fraction: float = 0.5,
                    inputs: SpectrumInputs | None = None) -> WarpedSpectrum:
    r"""The warped integrand's spectrum and variance of ``technique`` on ``envmap``, mean
    over uniform axes (module docstring), for :func:`shifted_rmse`.

    Parameters
    ----------
    envmap : the map (its bilinear interpolant is integrated).
    technique : "brdf", "map" or "mis" (:data:`TECHNIQUES`; multi-sample MIS).
    brdf, shininess : the lobe (:func:`envfit.shading.weight_function`).
    sampler : the map's :class:`~envfit.sampling.MapSampler` (its defaults when None) — the
        same one the estimator uses.
    grid : G, a multiple of 4; the box is B = G/4 (QMC predictions exact to N ≈ (B/2)²).
    axes : axes of the importance sample over the sphere (:func:`proposal_axes`).
    heuristic, fraction : MIS heuristic (:data:`envfit.sampling.HEURISTICS`) and the map's
        share ν₁ of the samples.
    inputs : :class:`SpectrumInputs` of this map and sampler, shared by the spectra of one
        map (pass the same object to each: the map nodes, pixel quadrature, exact means and
        axis proxies are then computed once); new ones when None.

    Work: per axis (2G)² lookups and a real FFT of (2G)² per channel for the lobe part (BRDF,
    MIS), one single-precision NUFFT of the map part's nodes (map, MIS; ≈ (2πB)² + πB(H + W)
    + HW of them, 1.5 M on a 1024×512 map at G = 512), and a pass over the pixels; the axes
    run on all cores.

    >>> m = EnvMap(np.full((8, 16, 1), 2.0))
    >>> s = warped_spectrum(m, "brdf", grid=16, axes=4)
    >>> s.power.shape, float(s.variance[0]) < 1e-20, round(s.mean, 12)
    ((1, 9, 5), True, 2.0)
    """
    g = check_options(envmap, technique, grid, heuristic, fraction)
    check_memory(spectrum_nbytes(envmap.height, g),
                 f"the warped spectrum ({technique}) of a {envmap.width}x{envmap.height} map at "
                 f"grid {g}", hint="use a smaller grid or downsample the map (--max-height)")
    tech = Technique.of(technique, weight_function(brdf, shininess), heuristic, fraction)
    shared = _inputs(envmap, sampler, inputs)
    A, wts = shared.axes(tech.weight, check_int(axes, "axes", 1))
    sums = _accumulate(shared, tech, g, A, wts, calibrate=True)
    return _spectrum(sums, tech, brdf, shininess, heuristic, g, A.shape[0])


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
    g = check_options(envmap, technique, grid, heuristic, fraction)
    tech = Technique.of(technique, weight_function(brdf, shininess), heuristic, fraction)
    shared = SpectrumInputs.of(envmap, sampler)
    A = as_unit_vectors(axes, name="axes")
    out = np.empty(A.shape[0])
    for m in range(A.shape[0]):
        sums = _accumulate(shared, tech, g, A[m:m + 1], np.ones(1))
        spec = WarpedSpectrum(technique, str(brdf), None, heuristic, float(tech.nu[0]),
                              sums.band, g, sums.variance, sums.power, sums.cross, sums.mean, 1)
        t = shifted_mse_terms(spec, u)
        out[m] = t["box"] + t["tail"]
    return out
