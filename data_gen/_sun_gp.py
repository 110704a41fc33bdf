r"""A sun of known radiance on a Gaussian-process background: test maps for bright-source
detection and for the source / rest split of the shading estimators.

The map is, in the map's local frame (z up, see :mod:`envfit.data_gen._analytic`),

.. math::  f(u) = b(u) + L\,\mathbf 1[\angle(u, c) \le \rho],

with :math:`b` a GP sample of smoothness :math:`s_0` (:func:`envfit.data_gen._gp.gaussian_process_map`,
``offset + scale * GP``) at the pixel centres, and the disc of :class:`~envfit.data_gen._analytic.SunSkyMap`
(centre :math:`c`, angular radius :math:`\rho`, radiance :math:`L` *added* to the
background) rendered as cell averages (:meth:`SunSkyMap.disk_coverage`: exact 0/1 away from
the edge, ``subsamples``² equal-area subcells on the edge pixels).

What is known exactly (:class:`SunRecord`):

* the disc's solid angle :math:`\Omega_\odot = 2\pi(1-\cos\rho)`;
* its power per channel :math:`P_\odot = L\,\Omega_\odot` and in luminance
  :math:`Y(L)\,\Omega_\odot` (Rec. 709 for ≥ 3 channels, channel 0 otherwise, as
  ``EnvMap.luminance``);
* the map's power :math:`P = \sum_{ij} Y(b_{ij})\,\Omega_{ij} + Y(L)\,\Omega_\odot` (the
  background's pixel sum — the integral of the piecewise-constant background — plus the
  disc's exact power) and the sun's share :math:`Y(L)\Omega_\odot / P`;
* the disc's own shading integrals in closed form (``record.sun.diffuse_integral``,
  ``glossy_integral``; the sky of ``record.sun`` is 0).

The rendered disc's pixel sum :math:`\sum_{ij} \mathrm{cov}_{ij}\,\Omega_{ij}`
(``rendered_solid_angle``) differs from :math:`\Omega_\odot` only by the supersampling error
of the edge pixels, :math:`\lesssim` (edge solid angle)/``subsamples``.

Example
-------
>>> f, sun = sun_gp_map(16, seed=0, sun_theta=1.0, sun_phi=2.0, sun_radius=0.2,
...                     sun_radiance=500.0, offset=4.0)
>>> f.shape
(16, 32, 1)
>>> round(sun.solid_angle, 6)                          # 2π(1 − cos 0.2)
0.125245
>>> bool(abs(sun.rendered_solid_angle / sun.solid_angle - 1) < 0.01), bool(0.5 < sun.share < 1)
(True, True)
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envfit.data_gen import _sht as sht
from envfit.data_gen._analytic import SunSkyMap, direction
from envfit.data_gen._errors import SyntheticMapError
from envfit.data_gen._gp import gaussian_process_map

__all__ = ["SunGPOptions", "SunRecord", "sun_gp_map", "luminance", "pixel_solid_angles"]

_REC709 = (0.2126, 0.7152, 0.0722)


def luminance(values) -> np.ndarray:
    """Rec. 709 luminance of (..., C) values for C ≥ 3, else channel 0 (as ``EnvMap.luminance``).

    >>> luminance([[1.0, 1.0, 1.0]]).tolist()
    [1.0]
    """
    v = np.asarray(values, dtype=np.float64)
    if v.shape[-1] >= 3:
        return _REC709[0] * v[..., 0] + _REC709[1] * v[..., 1] + _REC709[2] * v[..., 2]
    return v[..., 0].copy()


def pixel_solid_angles(height: int) -> np.ndarray:
    r"""Exact pixel solid angles (H, 2H): :math:`\frac{2\pi}{W}(\cos\theta_{top} - \cos\theta_{bottom})`.

    >>> bool(np.isclose(pixel_solid_angles(8).sum(), 4 * np.pi))
    True
    """
    h = sht._check_height(height)
    i = np.arange(h)
    row = (np.pi / h) * (np.cos(np.pi * i / h) - np.cos(np.pi * (i + 1) / h))   # 2π/W, W = 2H
    return np.repeat(row[:, None], 2 * h, axis=1)


@dataclass(frozen=True)
class SunRecord:
    r"""The sun of a :func:`sun_gp_map` and its exact quantities (local frame, z up).

    Attributes
    ----------
    direction : (3,) local unit vector of the disc centre c
    theta, phi : its local angles
    radius : angular radius ρ (radians)
    radiance : (C,) radiance L added inside the disc
    solid_angle : :math:`2\pi(1-\cos\rho)` (exact)
    rendered_solid_angle : :math:`\sum_{ij}\mathrm{cov}_{ij}\Omega_{ij}` of the rendered disc
    power : (C,) :math:`L\,\Omega_\odot`
    luminance_power : :math:`Y(L)\,\Omega_\odot`
    background_power : :math:`\sum_{ij} Y(b_{ij})\Omega_{ij}`
    share : :math:`Y(L)\Omega_\odot / (Y(L)\Omega_\odot + \text{background\_power})`
    coverage : (H, W) the rendered disc's pixel coverage in [0, 1]
    sun : the :class:`SunSkyMap` of the disc alone (sky 0): its closed-form integrals
    """

    direction: np.ndarray
    theta: float
    phi: float
    radius: float
    radiance: np.ndarray
    solid_angle: float
    rendered_solid_angle: float
    power: np.ndarray
    luminance_power: float
    background_power: float
    share: float
    coverage: np.ndarray
    sun: SunSkyMap


@dataclass(frozen=True)
class SunGPOptions:
    """Numerical settings of :func:`sun_gp_map` (the defaults suit every use so far).

    Attributes
    ----------
    lmax : band limit of the GP background (``method="sht"``; default H − 1, the grid's
        Nyquist degree), as :func:`envfit.data_gen._gp.gaussian_process_map`.
    method : ``"sht"`` (band-limited synthesis) or ``"exact"`` (Cholesky, H ≤ 48).
    subsamples : per-axis supersampling of the disc's edge pixels
        (:meth:`SunSkyMap.disk_coverage`).
    """

    lmax: int | None = None
    method: str = "sht"
    subsamples: int = 32


def sun_gp_map(height: int, *, seed, s0: float = 1.5, sun_theta: float = 0.6,
               sun_phi: float = 1.0, sun_radius: float = 0.1, sun_radiance=1000.0,
               channels: int = 1, offset=4.0, scale=1.0,
               options: SunGPOptions | None = None) -> tuple[np.ndarray, SunRecord]:
    r"""H×2H×C map "sun on a GP background" and the record of its sun (local frame).

    :math:`f_{ij} = b_{ij} + L\,\mathrm{cov}_{ij}`, b = ``gaussian_process_map(s0, height,
    seed=seed, channels, offset, scale, lmax, method)``, cov the disc's coverage
    (:meth:`SunSkyMap.disk_coverage` with ``subsamples``; ``lmax``, ``method`` and
    ``subsamples`` are those of ``options``, a :class:`SunGPOptions`).

    Parameters
    ----------
    height : H (the width is 2H).
    seed : the GP's seed (``numpy.random.default_rng``).
    s0 : the background's smoothness, 1 < s0 < 2.
    sun_theta, sun_phi : local angles of the disc centre (θ from up).
    sun_radius : angular radius ρ ∈ (0, π/2].
    sun_radiance : L, scalar or one value per channel (added to the background).
    channels, offset, scale : of the GP background. Keep ``offset`` a few standard
        deviations (:func:`envfit.data_gen._gp.expected_variance`) above 0 for a positive
        background.
    options : :class:`SunGPOptions` (the background's ``lmax`` and ``method``, the edge's
        ``subsamples``); default ``SunGPOptions()``.

    Returns
    -------
    (array (H, 2H, C) float64, :class:`SunRecord`)

    >>> f, sun = sun_gp_map(8, seed=1, channels=3, sun_radiance=(300.0, 200.0, 100.0))
    >>> f.shape, sun.radiance.tolist()
    ((8, 16, 3), [300.0, 200.0, 100.0])
    """
    opts = SunGPOptions() if options is None else options
    h = sht._check_height(height)
    bg = gaussian_process_map(s0, h, seed=seed, channels=channels, offset=offset, scale=scale,
                              lmax=opts.lmax, method=opts.method)
    c = bg.shape[-1]
    L = np.atleast_1d(np.asarray(sun_radiance, dtype=np.float64))
    if L.ndim != 1 or L.size not in (1, c) or not np.all(np.isfinite(L)):
        raise SyntheticMapError(f"sun_radiance must be a finite scalar or one value per channel "
                                f"({c}), got {sun_radiance!r}")
    L = np.broadcast_to(L, (c,)).copy()
    sun = SunSkyMap(sun_theta=sun_theta, sun_phi=sun_phi, sun_radius=sun_radius,
                    sun_radiance=L, sky=np.zeros(c), subsamples=opts.subsamples)
    cov = sun.disk_coverage(h)
    f = bg + cov[..., None] * L
    om = pixel_solid_angles(h)
    omega = float(4.0 * np.pi * np.sin(0.5 * sun.sun_radius) ** 2)          # 2π(1 − cos ρ), no cancellation
    yl = float(luminance(L[None, :])[0])
    p_bg = float(np.sum(luminance(bg) * om))
    p_sun = yl * omega
    rec = SunRecord(direction=direction(sun.sun_theta, sun.sun_phi), theta=sun.sun_theta,
                    phi=sun.sun_phi, radius=sun.sun_radius, radiance=L, solid_angle=omega,
                    rendered_solid_angle=float(np.sum(cov * om)), power=L * omega,
                    luminance_power=p_sun, background_power=p_bg,
                    share=p_sun / (p_sun + p_bg), coverage=cov, sun=sun)
    return f, rec
