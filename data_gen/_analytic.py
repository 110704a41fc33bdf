r"""Analytic environment maps with known shading integrals (ground truth for Eq. 17).

All maps live in the map's *local frame*: direction
:math:`u = (\sin\theta\cos\varphi, \sin\theta\sin\varphi, \cos\theta)`, z up (docs/HELPERS.md).
Each map is a frozen dataclass with

* ``values(theta, phi)`` / ``values_at(u)``: point values, shape (…, C);
* ``render(height, mode="average")``: an H×2H×C lat-long map. ``"average"`` gives each pixel
  the mean radiance over its cell (exact for the constant, gradient and step maps;
  supersampled for the sun's hard edge, see :class:`SunSkyMap`); ``"point"`` gives the value
  at the pixel centre θ_i = π(i+½)/H, φ_j = 2π(j+½)/W;
* ``diffuse_integral(axes)`` and ``glossy_integral(axes, shininess)``: the normalised shading
  integral of Eq. 17 about each unit axis (local frame), shape (C,) or (N, C):

.. math::  I = \frac{1}{2\pi r_s}\int_{S^2} f(u)\,p(u)\,dS(u)                      \quad (17)

with, for the diffuse case, :math:`p(u) = \max(u\cdot n, 0)`, :math:`r_s = 1/2`, and for the
glossy case (Eq. 25, errata: integrated over the hemisphere about the lobe axis a)
:math:`p(u) = e^{n(u\cdot a - 1)}` for :math:`u\cdot a > 0` (else 0),
:math:`r_s = (1 - e^{-n})/n`. So I = 1 for f ≡ 1, and I is a weighted mean of f.

Closed forms used (each checked against brute-force 2-D quadrature in the tests):

* :math:`\frac1\pi\int_{H_n} (u\cdot n)\,u\,dS = \frac23 n` and
  :math:`\frac{1}{2\pi r_s}\int_{H_a} e^{n(u\cdot a-1)}\,u\,dS = \mu(n)\,a`,
  :math:`\mu(n) = \frac{1}{1-e^{-n}} - \frac1n` (:func:`glossy_mean_cosine`): exact
  integrals of linear maps, hemisphere cut included.
* A spherical cap of angular radius ρ about c (the sun disk; the bright region of the step),
  diffuse: :func:`diffuse_cap_integral`, the closed-form irradiance of a horizon-clipped
  cap (Snyder 1996, "Area light sources for real-time graphics"; the form used in
  Lagarde & de Rousiers 2014, "Moving Frostbite to PBR", Sec. 4.7), extended to ρ > π/2 by
  complement. Fully visible cap: :math:`\sin^2\rho\,(n\cdot c)`, since
  :math:`\int_{cap} u\,dS = \pi\sin^2\rho\,c`.
* Cap, glossy: no elementary closed form (a von Mises–Fisher cap probability, cut by the
  hemisphere). :func:`glossy_cap_integral` reduces it *exactly* to a 1-D integral over
  t = u·a, :math:`\int_0^1 e^{n(t-1)}\,2\psi(t)\,dt` with :math:`2\psi(t)` the azimuthal
  length of the circle {u·a = t} inside the cap (closed form), evaluated with
  ``scipy.integrate.quad`` to ~1e-12 relative, the kinks of ψ as break points.

These closed forms live in :mod:`envfit.data_gen._caps` (re-exported here).

Example
-------
>>> sky = SkyGradientMap(horizon=1.0, zenith=2.0)
>>> round(float(sky.diffuse_integral([0.0, 0.0, 1.0])[0]), 12)      # a + (2/3) b = 1 + 2/3
1.666666666667
>>> StepMap(low=0.0, high=1.0, theta_edge=np.pi / 2).diffuse_integral([0, 0, 1.0])
array([1.])
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from envfit.data_gen import _sht as sht
from envfit.data_gen._caps import (_angle, _axes, _shininess, diffuse_cap_integral, direction,
                                   glossy_cap_integral, glossy_mean_cosine, glossy_normalisation)
from envfit.data_gen._errors import SyntheticMapError

__all__ = ["AnalyticMap", "ConstantMap", "SkyGradientMap", "SunSkyMap", "StepMap",
           "diffuse_cap_integral", "glossy_cap_integral", "glossy_mean_cosine",
           "glossy_normalisation", "direction"]


# ----------------------------------------------------------------------------- helpers


def _colour(value, name: str) -> np.ndarray:
    a = np.atleast_1d(np.asarray(value, dtype=np.float64))
    if a.ndim != 1 or a.size < 1:
        raise SyntheticMapError(f"{name} must be a scalar or a 1-D colour tuple, got {value!r}")
    if not np.all(np.isfinite(a)):
        raise SyntheticMapError(f"{name} must be finite, got {value!r}")
    return a


def _broadcast_colours(*pairs) -> list[np.ndarray]:
    arrs = [_colour(v, n) for v, n in pairs]
    try:
        shape = np.broadcast_shapes(*(a.shape for a in arrs))
    except ValueError:
        raise SyntheticMapError(
            "colours must have the same number of channels (or one): "
            + ", ".join(f"{n} has {a.size}" for a, (_, n) in zip(arrs, pairs))) from None
    return [np.broadcast_to(a, shape).copy() for a in arrs]


def _out(per_axis: np.ndarray, single: bool) -> np.ndarray:
    return per_axis[0] if single else per_axis


def _cell_bounds(height: int) -> tuple[np.ndarray, np.ndarray]:
    """z = cos θ at the top and bottom edge of each row (H,)."""
    h = sht._check_height(height)
    i = np.arange(h)
    return np.cos(np.pi * i / h), np.cos(np.pi * (i + 1) / h)


# ----------------------------------------------------------------------------- maps

class AnalyticMap:
    """Common interface; subclasses define ``channels``, ``values_at``, ``_row_average`` or
    ``_average``, ``diffuse_integral`` and ``glossy_integral``."""

    channels: int

    def values(self, theta, phi) -> np.ndarray:
        """Point values at local angles (θ from up, φ azimuth), shape broadcast(θ, φ) + (C,)."""
        return self.values_at(direction(theta, phi))

    def values_at(self, u) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _average(self, height: int) -> np.ndarray:
        """Exact cell averages (H, 2H, C) for maps that only depend on θ."""
        zt, zb = _cell_bounds(height)
        row = self._row_average(zt, zb)                                # (H, C)
        return np.broadcast_to(row[:, None, :], (row.shape[0], 2 * row.shape[0],
                                                 row.shape[1])).copy()

    def render(self, height: int, *, mode: str = "average") -> np.ndarray:
        """H×2H×C lat-long map in the local frame: cell averages (default) or centre values."""
        h = sht._check_height(height)
        if mode == "point":
            return self.values_at(sht.grid_directions(h))
        if mode != "average":
            raise SyntheticMapError(f"mode must be 'average' or 'point', got {mode!r}")
        return self._average(h)


@dataclass(frozen=True)
class ConstantMap(AnalyticMap):
    """f(u) = value (scalar or colour tuple). Every normalised shading integral equals value."""

    value: object = 1.0
    colour: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "colour", _colour(self.value, "value"))

    @property
    def channels(self) -> int:
        return self.colour.size

    def values_at(self, u) -> np.ndarray:
        u = np.asarray(u, dtype=np.float64)
        return np.broadcast_to(self.colour, u.shape[:-1] + (self.channels,)).copy()

    def _row_average(self, zt, zb):
        return np.broadcast_to(self.colour, (zt.size, self.channels)).copy()

    def diffuse_integral(self, axes_local) -> np.ndarray:
        """I = value for every axis (Eq. 17 with f constant)."""
        a, single = _axes(axes_local)
        return _out(np.broadcast_to(self.colour, (a.shape[0], self.channels)).copy(), single)

    def glossy_integral(self, axes_local, shininess: float) -> np.ndarray:
        """I = value for every axis and shininess."""
        _shininess(shininess)
        return self.diffuse_integral(axes_local)


@dataclass(frozen=True)
class SkyGradientMap(AnalyticMap):
    r"""Sky linear in the up component: :math:`f(u) = a + b\,(u\cdot z)`, a = horizon, b = zenith − horizon.

    So f = horizon at θ = π/2, zenith at θ = 0 and ``2·horizon − zenith`` at the nadir (the
    linear continuation; negative if zenith > 2·horizon—keep it positive for real maps).
    Linear maps have exact closed-form integrals with the hemisphere cut (module doc):
    diffuse :math:`a + \frac23 b\,(n\cdot z)`; glossy :math:`a + b\,\mu(n)\,(a\cdot z)`.
    Exact cell average of a row: :math:`a + b\,(z_{top} + z_{bottom})/2`.
    """

    horizon: object = 1.0
    zenith: object = 1.0
    a: np.ndarray = field(init=False, repr=False, compare=False)
    b: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        h, z = _broadcast_colours((self.horizon, "horizon"), (self.zenith, "zenith"))
        object.__setattr__(self, "a", h)
        object.__setattr__(self, "b", z - h)

    @property
    def channels(self) -> int:
        return self.a.size

    @property
    def nadir(self) -> np.ndarray:
        """Value at θ = π: a − b."""
        return self.a - self.b

    def values_at(self, u) -> np.ndarray:
        u = np.asarray(u, dtype=np.float64)
        return self.a + self.b * u[..., 2:3]

    def _row_average(self, zt, zb):
        return self.a + self.b * (0.5 * (zt + zb))[:, None]

    def diffuse_integral(self, axes_local) -> np.ndarray:
        r""":math:`I = a + \frac23 b\,(n\cdot z)` for every unit n (exact, any tilt)."""
        n, single = _axes(axes_local)
        return _out(self.a + (2.0 / 3.0) * self.b * n[:, 2:3], single)

    def glossy_integral(self, axes_local, shininess: float) -> np.ndarray:
        r""":math:`I = a + b\,\mu(n)\,(a\cdot z)`, :math:`\mu(n) = 1/(1-e^{-n}) - 1/n` (exact)."""
        ax, single = _axes(axes_local)
        mu = glossy_mean_cosine(shininess)
        return _out(self.a + mu * self.b * ax[:, 2:3], single)


def _as_sky(sky) -> AnalyticMap:
    if isinstance(sky, (ConstantMap, SkyGradientMap)):
        return sky
    if isinstance(sky, AnalyticMap):
        raise SyntheticMapError("sky must be a ConstantMap, a SkyGradientMap or a colour")
    return ConstantMap(sky)


@dataclass(frozen=True)
class StepMap(AnalyticMap):
    r"""Discontinuous map: f = high for θ < theta_edge, low otherwise (0 < theta_edge < π).

    f = low + (high − low)·1_cap with the cap of radius θ_e about z, so (module doc)
    diffuse :math:`I = low + (high-low)\,D(n\cdot z, \theta_e)` in closed form
    (:func:`diffuse_cap_integral`), glossy by the exact 1-D reduction
    (:func:`glossy_cap_integral`). Cell averages are exact: the bright fraction of row i is
    :math:`(z_{top} - \mathrm{clip}(\cos\theta_e, z_{bot}, z_{top}))/(z_{top} - z_{bot})`.
    """

    low: object = 0.0
    high: object = 1.0
    theta_edge: float = np.pi / 2
    lo: np.ndarray = field(init=False, repr=False, compare=False)
    hi: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        lo, hi = _broadcast_colours((self.low, "low"), (self.high, "high"))
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)
        object.__setattr__(self, "theta_edge", _angle(self.theta_edge, "theta_edge", 0.0, np.pi))

    @property
    def channels(self) -> int:
        return self.lo.size

    def values_at(self, u) -> np.ndarray:
        u = np.asarray(u, dtype=np.float64)
        bright = np.arccos(np.clip(u[..., 2:3], -1.0, 1.0)) < self.theta_edge
        return np.where(bright, self.hi, self.lo)

    def _row_average(self, zt, zb):
        ze = np.cos(self.theta_edge)
        frac = (zt - np.clip(ze, zb, zt)) / (zt - zb)
        return self.lo + (self.hi - self.lo) * frac[:, None]

    def diffuse_integral(self, axes_local) -> np.ndarray:
        n, single = _axes(axes_local)
        d = diffuse_cap_integral(n[:, 2], self.theta_edge)
        return _out(self.lo + (self.hi - self.lo) * d[:, None], single)

    def glossy_integral(self, axes_local, shininess: float) -> np.ndarray:
        ax, single = _axes(axes_local)
        g = np.atleast_1d(glossy_cap_integral(ax, [0.0, 0.0, 1.0], self.theta_edge, shininess))
        return _out(self.lo + (self.hi - self.lo) * g[:, None], single)


@dataclass(frozen=True)
class SunSkyMap(AnalyticMap):
    r"""A sky plus a uniform sun disk: :math:`f = sky(u) + L\,\mathbf 1[\angle(u, c) \le \rho]`.

    ``sun_theta``, ``sun_phi``: local angles of the disk centre c; ``sun_radius`` ρ ∈ (0, π/2]
    (angular radius, hard edge); ``sun_radiance`` L is the radiance *added* to the sky inside
    the disk; ``sky`` a :class:`ConstantMap`, a :class:`SkyGradientMap` or a colour.

    Integrals: sky part as above; the disk's diffuse part in closed form,
    :math:`L\sin^2\rho\,(n\cdot c)` when the disk is entirely above the horizon of n, 0 when
    entirely below, Snyder's horizon-clipped formula in between
    (:func:`diffuse_cap_integral`); glossy by the exact 1-D reduction (:func:`glossy_cap_integral`).

    ``render(mode="average")``: the sky part is averaged exactly; the disk's coverage of a
    pixel is 1 or 0 when the pixel lies entirely inside or outside the disk (decided with the
    pixel's exact corner radius, the farthest point of a lat-long cell from its centre being
    a corner), and otherwise the mean of ``subsamples**2`` equal-area subcells (uniform in
    cos θ and φ) — so pixel values are cell averages up to a coverage error ≲ 1/subsamples
    on the edge pixels only.
    """

    sun_theta: float = 0.5
    sun_phi: float = 0.0
    sun_radius: float = 0.05
    sun_radiance: object = 100.0
    sky: object = 1.0
    subsamples: int = 8
    radiance: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        sky = _as_sky(self.sky)
        object.__setattr__(self, "sky", sky)
        object.__setattr__(self, "sun_theta", _angle(self.sun_theta, "sun_theta", 0.0, np.pi,
                                                     lo_open=False, hi_open=False))
        try:
            phi = float(self.sun_phi)
        except (TypeError, ValueError):
            raise SyntheticMapError(f"sun_phi must be a number, got {self.sun_phi!r}") from None
        if not np.isfinite(phi):
            raise SyntheticMapError(f"sun_phi must be finite, got {self.sun_phi!r}")
        object.__setattr__(self, "sun_phi", phi)
        object.__setattr__(self, "sun_radius", _angle(self.sun_radius, "sun_radius", 0.0,
                                                      np.pi / 2, hi_open=False))
        if int(self.subsamples) != self.subsamples or self.subsamples < 1:
            raise SyntheticMapError(f"subsamples must be a positive integer, got {self.subsamples!r}")
        probe = sky.colour if isinstance(sky, ConstantMap) else sky.a
        L, _ = _broadcast_colours((self.sun_radiance, "sun_radiance"), (probe, "sky"))
        object.__setattr__(self, "radiance", L)

    @property
    def channels(self) -> int:
        return self.radiance.size

    @property
    def sun_direction(self) -> np.ndarray:
        """Local unit vector of the disk centre."""
        return direction(self.sun_theta, self.sun_phi)

    def _in_disk(self, u) -> np.ndarray:
        return np.asarray(u, dtype=np.float64) @ self.sun_direction >= np.cos(self.sun_radius)

    def values_at(self, u) -> np.ndarray:
        u = np.asarray(u, dtype=np.float64)
        sky = np.broadcast_to(self.sky.values_at(u), u.shape[:-1] + (self.channels,))
        return sky + self.radiance * self._in_disk(u)[..., None]

    def disk_coverage(self, height: int) -> np.ndarray:
        """Fraction (H, 2H) of each pixel's solid angle inside the disk (see class doc)."""
        h = sht._check_height(height)
        w = 2 * h
        theta, phi = sht.grid_angles(h)
        centres = sht.grid_directions(h)
        c = self.sun_direction
        dist = np.arccos(np.clip(centres @ c, -1.0, 1.0))
        # farthest point of row i's cell from its centre: a corner (same for every column)
        corners = direction(np.stack([np.pi * np.arange(h) / h, np.pi * (np.arange(h) + 1) / h]),
                            np.full((2, h), np.pi / w))
        centre0 = direction(theta, 0.0)
        r_pix = np.arccos(np.clip(np.einsum("krd,rd->kr", corners, centre0), -1.0, 1.0)).max(0)
        r_pix = r_pix[:, None] + 1e-12
        rho = self.sun_radius
        cov = (dist + r_pix <= rho).astype(np.float64)
        edge = np.nonzero((dist + r_pix > rho) & (dist - r_pix < rho))
        if edge[0].size:
            k = int(self.subsamples)
            zt, zb = _cell_bounds(h)
            frac = (np.arange(k) + 0.5) / k
            zs = zt[edge[0]][:, None] - frac[None, :] * (zt - zb)[edge[0]][:, None]   # (E, k)
            ps = 2 * np.pi * (edge[1][:, None] + frac[None, :]) / w                   # (E, k)
            st = np.sqrt(np.maximum(1.0 - zs * zs, 0.0))
            dots = (c[0] * st[:, :, None] * np.cos(ps)[:, None, :]
                    + c[1] * st[:, :, None] * np.sin(ps)[:, None, :] + c[2] * zs[:, :, None])
            cov[edge] = np.mean(dots >= np.cos(rho), axis=(1, 2))
        return cov

    def _average(self, height: int) -> np.ndarray:
        sky = self.sky.render(height, mode="average")
        return sky + self.radiance * self.disk_coverage(height)[..., None]

    def diffuse_integral(self, axes_local) -> np.ndarray:
        n, single = _axes(axes_local)
        sky = np.atleast_2d(self.sky.diffuse_integral(n))
        d = diffuse_cap_integral(n @ self.sun_direction, self.sun_radius)
        return _out(sky + self.radiance * d[:, None], single)

    def glossy_integral(self, axes_local, shininess: float) -> np.ndarray:
        ax, single = _axes(axes_local)
        sky = np.atleast_2d(self.sky.glossy_integral(ax, shininess))
        g = np.atleast_1d(glossy_cap_integral(ax, self.sun_direction, self.sun_radius, shininess))
        return _out(sky + self.radiance * g[:, None], single)
