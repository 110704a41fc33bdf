r"""The mean over uniform axes of a technique's warped spectrum: per-axis terms, their weighted
sums over the importance sample of axes, and the calibration of those sums.

Per axis a (:func:`_axis_terms`): the variances :math:`V_i` and the integral I by pixel
quadrature (:mod:`._pixel_moments`), :math:`|\hat h_i(k)|^2` on the half box and the MIS
cross term :math:`\hat h_1(k_0,0)\overline{\hat h_2(k_0,0)}` (:mod:`._box_spectra`) — all
means over the channels. Over the axes (:func:`_accumulate`): the sums weighted by the
proposal's weights :math:`1/(P\,\pi_a\,\mathrm{count})` (:mod:`._axis_proposal`), then, per
part, the ratio estimator :math:`\overline{V}^\mathrm{exact}/\overline{V}^\mathrm{sampled}` of
the technique the part samples with (:func:`_calibration`, the exact means of
:func:`._pixel_moments.exact_mean_variances`): it removes the axis-sampling error of the
variance and keeps the sample's estimate of the *shape* (the box's share, the QMC gain).
"""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np

from envfit.base import machine_cores
from envfit.shading import twisted_frames
from envfit.predict.warped._box_spectra import LOBE_OVERSAMPLING, BoxInputs, _axis_spectra
from envfit.predict.warped._pixel_moments import _pixel_lobe, _pixel_moments, _Pixels

__all__ = ["AxisTerms", "AxisSums"]


@dataclass(frozen=True)
class AxisTerms:
    """One axis's unweighted terms, means over the channels.

    Attributes
    ----------
    variance : (parts,) :math:`V_i`.
    mean : the shading integral I.
    sampled : with calibration, ``{"brdf": V, "map": V}`` the one-sample variances of BRDF
        and map sampling at the axis; else empty.
    power : (parts, 2B+1, B+1) :math:`|\\hat h_i(k)|^2` on the half box.
    cross : (2B+1,) complex :math:`\\hat h_1(k_0,0)\\overline{\\hat h_2(k_0,0)}` (MIS), else None.
    """

    variance: np.ndarray
    mean: float
    sampled: dict
    power: np.ndarray
    cross: np.ndarray | None


@dataclass(frozen=True)
class AxisSums:
    """The weighted sums over the axes (calibrated when asked): the box ``band`` B,
    ``variance`` (parts,), ``power`` (parts, 2B+1, B+1) and ``cross`` (2B+1,) — 0 at k = 0 —
    and ``mean`` I (the fields of :class:`._warped_spectrum.WarpedSpectrum`)."""

    band: int
    variance: np.ndarray
    power: np.ndarray
    cross: np.ndarray
    mean: float


@dataclass(frozen=True, eq=False)
class _AxisJob:
    """What every axis of one :func:`_accumulate` shares: the box spectra's inputs, the pixel
    quadrature and whether to compute the calibration's sampled variances."""

    box: BoxInputs
    pixels: _Pixels
    calibrate: bool


def _axis_terms(job: _AxisJob, a: np.ndarray, R: np.ndarray) -> AxisTerms:
    """Axis a's unweighted terms (:class:`AxisTerms`); R its frame (third column a)."""
    tech = job.box.technique
    px = job.pixels
    lobe = _pixel_lobe(px, tech.weight, a)
    mom = _pixel_moments(px, tech, a, lobe)
    sampled = {}
    if job.calibrate:
        for t in ("brdf", "map"):
            vt = mom.variance if t == tech.name else \
                _pixel_moments(px, replace(tech, name=t), a, lobe).variance
            sampled[t] = float(vt.mean())
    H = _axis_spectra(job.box, R)
    P = np.stack([(np.abs(h) ** 2).mean(axis=0) for h in H])
    X = (H[0][:, :, 0] * np.conj(H[1][:, :, 0])).mean(axis=0) if len(H) == 2 else None
    return AxisTerms(mom.variance.mean(axis=1), float(mom.mean.mean()), sampled, P, X)


def _all_axes(job: _AxisJob, A: np.ndarray) -> list[AxisTerms]:
    """The terms of every axis of A, on all cores (threads: the work is numpy and ducc0,
    which release the GIL), in axis order."""
    R = twisted_frames(A, None)
    workers = min(machine_cores(), A.shape[0])
    if workers == 1:
        return [_axis_terms(job, A[m], R[m]) for m in range(A.shape[0])]
    with ThreadPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(lambda m: _axis_terms(job, A[m], R[m]), range(A.shape[0])))


def _accumulate(inputs, technique, g: int, A: np.ndarray, wts, calibrate: bool = False
                ) -> AxisSums:
    """Weighted sums over axes A (weights ``wts``) of V, |ĥ|², the k₁ = 0 cross term and I of
    ``technique`` (:class:`._techniques.Technique`) at grid G = ``g``, from the map's shared
    ``inputs`` (:class:`._spectrum_inputs.SpectrumInputs`); with ``calibrate`` rescaled by the
    ratio estimator of :func:`_calibration`. Summed in axis order (the same result for any
    number of threads)."""
    band = g // 4
    weight = technique.weight
    grid = inputs.lobe_grid(weight, LOBE_OVERSAMPLING * band) if technique.samples_lobe \
        else None
    nodes = inputs.nodes(band) if technique.samples_map else None
    workers = min(machine_cores(), A.shape[0])
    box = BoxInputs(inputs.envmap, inputs.sampler, technique, band, grid, nodes,
                    max(1, machine_cores() // workers))
    terms = _all_axes(_AxisJob(box, inputs.pixels(weight), calibrate), A)
    V = sum(w * t.variance for w, t in zip(wts, terms))
    mean = float(sum(w * t.mean for w, t in zip(wts, terms)))
    P = sum(w * t.power for w, t in zip(wts, terms))
    X = (sum(w * t.cross for w, t in zip(wts, terms)) if technique.parts == 2
         else np.zeros(2 * band + 1, dtype=complex))
    P[:, band, 0] = 0.0
    X[band] = 0.0
    if calibrate:
        sampled = {k: sum(w * t.sampled[k] for w, t in zip(wts, terms)) for k in ("brdf", "map")}
        r = _calibration(technique.name, inputs.exact(weight), sampled)
        V, P, X = V * r, P * r[:, None, None], X * (math.sqrt(r[0] * r[-1]))
    return AxisSums(band, V, P, X, mean)


def _calibration(technique: str, exact: dict, sampled: dict) -> np.ndarray:
    r"""Per part, the ratio exact/sampled mean variance of the technique it samples with
    (map part: map sampling, lobe part: BRDF sampling): a ratio estimator that removes the
    axis-sampling error of the importance sample where the closed form of
    :func:`._pixel_moments.exact_mean_variances` is known, and keeps its estimate of the
    *shape* (the box's share of the variance, the QMC gain)."""
    keys = {"brdf": ["brdf"], "map": ["map"], "mis": ["map", "brdf"]}[technique]
    return np.array([exact[k] / sampled[k] if sampled[k] > 0 and exact[k] > 0 else 1.0
                     for k in keys])
