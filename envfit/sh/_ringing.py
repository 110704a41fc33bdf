r"""``envfit sh``'s predictions: the truncation error of exported SH coefficients, the fraction
of directions where the windowed, truncated signal goes negative, and the (degree, window)
to use for a target.

Signal
    :math:`S(n) = \sum_{l\le L} w_l g_l \sum_m f_{lm}Y_{lm}(n)` with :math:`g_l = \hat A_l`
    (irradiance, the clamped cosine of Ramamoorthi & Hanrahan 2001) or 1 (the radiance
    reconstruction), :math:`f_{lm}` the exact coefficients of the map's bilinear
    interpolant, :math:`w_l` a window (:data:`envfit.sh._sh_export.WINDOWS`).

Predicted error (:func:`truncation_rmse`)
    By Parseval, the mean over uniformly distributed directions of the squared error
    against the untruncated signal is

    .. math:: R^2(L, w) = \frac1C\sum_c\Big[\sum_{l\le L}(1-w_l)^2 b_l^2\hat P_{l,c}
              + \sum_{l>L} b_l^2\hat P_{l,c}\Big],\qquad b_l = g_l\sqrt{\tfrac{2l+1}{4\pi}},

    :math:`\hat P_{l,c}` the map's realised power per degree to :math:`2H-1` (the advisor's
    prediction (c): the second sum is
    :func:`envfit.predict._spectral.spectral_truncation_curve`; exact for the map itself,
    not only in expectation over rotations, since the kernel is zonal and the axes uniform).
    Reported relative to the signal's mean :math:`g_0 f_{00}/\sqrt{4\pi}` (averaged over
    channels). Measured (:func:`measured_rmse`, ``check``): irradiance — the RMS over
    :data:`CHECK_AXES` spherical Fibonacci directions of the exported coefficients'
    evaluation (:func:`envfit.sh._sh_export.sh_eval`) against π ×
    :func:`envfit.shading._ground_truth.shading_integral`; radiance — the solid-angle
    weighted RMS of the synthesised signal against the bilinear lookup on a 2H-row grid.

Negative fraction
    Predicted (:func:`negative_fraction`): the solid-angle share of a Gauss–Legendre grid
    (``ducc0.sht.synthesis_2d`` of the local complex coefficients, :func:`gl_synthesis`)
    where any channel is below −1e-9 of the mean. Dense check (:func:`dense_negative_fractions`):
    the exported *world-frame real* coefficients summed directly (:func:`sh_eval`, numpy
    recurrences, no ducc0) at every pixel centre of a :data:`DENSE_HEIGHT`-row lat-long
    grid, weighted by the pixels' exact solid angles — a different grid, basis code and frame.

Choice (:func:`choose`)
    Among the rows meeting the target: those with no negative direction, the smallest L,
    then the smallest error; none without negativity: the least negative, then the
    smallest L; none meeting the target: the smallest error. The sentence names the numbers.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from envfit.base import check_int
from envfit.base import progress
from envfit.base import ParameterError
from envfit.maps import EnvMap
from envfit.maps import (local_to_world, pixel_angles, pixel_directions, pixel_solid_angles,
                         row_solid_angles)
from envfit.predict import spectral_truncation_curve
from envfit.shading import shading_integral
from envfit.shading import axes_to_local
from envfit.shading import bilinear_sh_coefficients, synthesize_convolution
from envfit.sh._sh_export import (WINDOWS, gl_synthesis, negative_tolerance, pixel_synthesis,
                                      sh_eval, shading_factors, sloan_lambda, truncate_alm,
                                      window_weights)
from envfit.theory import spherical_fibonacci_sphere

__all__ = ["CHECK_AXES", "DENSE_HEIGHT", "TABLE_LMAX", "DIRECT_LMAX", "RingingRow",
           "signal_mean", "truncation_rmse", "negative_fraction", "dense_negative_fractions",
           "measured_rmse", "ringing_rows", "choose", "check_lmax", "check_degree",
           "BAND_LIMIT"]

#: the words of a degree's input-dependent bound (``envfit sh --help`` states the same)
BAND_LIMIT = "H-1 (the map's band limit)"
#: spherical Fibonacci directions of the measured RMSE
CHECK_AXES = 4096
#: rows of the lat-long grid of the dense negative-fraction check
DENSE_HEIGHT = 512
#: the ringing table's degrees are 1…TABLE_LMAX and the export's
TABLE_LMAX = 8
#: memory of one block of rows of the dense check (directions and values of every export)
DENSE_BLOCK_BYTES = 64 * 2**20
#: the direct per-direction sums (dense check, measured irradiance of the exported numbers)
#: up to this degree; above it the dense check is skipped and the measured irradiance is
#: synthesised from the local coefficients (``synthesis_general``)
DIRECT_LMAX = 32


@dataclass(frozen=True)
class RingingRow:
    """One (degree, window) of the ringing table (relative = over the signal's mean)."""

    L: int
    window: str
    window_lambda: float | None
    predicted_relative_rmse: float
    negative_fraction: float
    dense_negative_fraction: float | None = None
    measured_relative_rmse: float | None = None

    @property
    def label(self) -> str:
        lam = f" (lambda {self.window_lambda:.3g})" if self.window_lambda else ""
        return f"L = {self.L}, window {self.window}{lam}"

    def to_dict(self) -> dict:
        return {"L": self.L, "window": self.window, "window_lambda": self.window_lambda,
                "predicted_relative_rmse": self.predicted_relative_rmse,
                "negative_fraction": self.negative_fraction,
                "dense_negative_fraction": self.dense_negative_fraction,
                "measured_relative_rmse": self.measured_relative_rmse}


def check_lmax(lmax, height: int) -> int:
    """lmax as a whole number in [0, H − 1] (the map's band limit), else ParameterError."""
    return check_degree(lmax, height, "--lmax", 0)


def check_degree(value, height: int, option: str, lo: int) -> int:
    """``value`` as a whole number in [lo, H − 1] (the map's band limit), else ParameterError
    naming ``option`` and the range in ``envfit sh --help``'s words.

    >>> check_degree(64, 64, "--lmax", 0)
    Traceback (most recent call last):
    ...
    envfit.base._errors.ParameterError: --lmax 64 is outside 0 <= L <= H-1 (the map's band limit): H-1 = 63 for this 128x64 map
    """
    from envfit.base import check_int
    v = check_int(value, option, lo)
    if v > height - 1:
        raise ParameterError(f"{option} {v} is outside {lo} <= L <= {BAND_LIMIT}: H-1 = "
                             f"{height - 1} for this {2 * height}x{height} map")
    return v


# ---------------------------------------------------------------- predictions
def signal_mean(alm, g) -> float:
    """The signal's mean over the sphere, averaged over channels: g_0 f_00 / √(4π).

    >>> signal_mean(np.array([[np.sqrt(4 * np.pi), 0.0]]), [np.pi])     # radiance 1 → E = π
    3.141592653589793
    """
    return float(np.mean(np.atleast_2d(alm)[:, 0].real) * g[0] / math.sqrt(4 * math.pi))


def truncation_rmse(map_power, factors, weights) -> float:
    r""":math:`R(L, w)` of the module docstring (absolute), L = len(weights) − 1.

    ``map_power``: (C, L_P + 1); ``factors``: :math:`g_l` for l ≤ L_P; ``weights``: w_l.

    >>> P = np.array([[4.0, 1.0, 0.5]])
    >>> round(truncation_rmse(P, [1.0, 1.0, 1.0], [1.0, 1.0]) ** 2 * 4 * np.pi / 5, 12)
    0.5
    """
    P = np.atleast_2d(np.asarray(map_power, dtype=np.float64))
    lp = P.shape[1] - 1
    w = np.asarray(weights, dtype=np.float64)
    L = w.size - 1
    g = np.asarray(factors, dtype=np.float64)[:lp + 1]
    b = g * np.sqrt((2 * np.arange(lp + 1) + 1) / (4 * np.pi))
    tail = float(spectral_truncation_curve(P, b, min(L, lp))[min(L, lp)]) ** 2
    band = float(np.sum((1.0 - w[:lp + 1]) ** 2 * b[:L + 1] ** 2 * P.mean(axis=0)[:L + 1]))
    return math.sqrt(tail + band)


def negative_fraction(alm, factors, nlat: int | None = None) -> float:
    """Predicted solid-angle share where any channel of the signal of degree len(factors) − 1
    (``factors`` = w_l g_l) is negative, on :func:`gl_synthesis`'s grid."""
    g = np.asarray(factors, dtype=np.float64)
    L = g.size - 1
    vals, om = gl_synthesis(alm, g, L, nlat)
    neg = (vals < -negative_tolerance(alm, g)).any(axis=0)              # (nlat, nphi)
    return float((neg * om[:, None]).sum() / (4 * np.pi))


def dense_negative_fractions(exports, height: int = DENSE_HEIGHT, *,
                             block_bytes: int = DENSE_BLOCK_BYTES,
                             quiet: bool = True) -> list[float | None]:
    """Solid-angle share where any channel of each
    :class:`~envfit.sh._sh_export.SHCoefficients` in ``exports`` is negative, by the
    direct sum at every pixel centre of a ``height``-row lat-long grid of their world frame
    (:func:`sh_eval`), weighted by the exact pixel solid angles; None above
    :data:`DIRECT_LMAX`.

    The grid is visited in blocks of rows of at most ``block_bytes`` (directions and values
    of every export), so the memory does not grow with ``height`` (issue 22: a 100000-row
    grid asked for terabytes at once); the time does, and is planned beforehand
    (:func:`envfit.sh._plan.check_sh_plan`)."""
    todo = [e for e in exports if e.lmax <= DIRECT_LMAX]
    if not todo:
        return [None] * len(exports)
    height = check_int(height, "--check-height", 1)
    top = max(e.lmax for e in todo)
    n = (top + 1) ** 2
    cols, spans = [], []
    for e in todo:
        c = np.zeros((n, e.coefficients.shape[1]))
        c[:e.coefficients.shape[0]] = e.coefficients
        tol = 1e-9 * float(np.abs(e.coefficients[0]).max()) / math.sqrt(4 * np.pi)
        spans.append((len(cols), e.coefficients.shape[1], max(tol, 1e-300)))
        cols.extend(c.T)
    coef = np.stack(cols, axis=1)                                         # (n, K)
    theta, phi = pixel_angles(height)
    om = row_solid_angles(height)                                         # one pixel per row
    m = local_to_world(todo[0].up)
    rows = max(1, int(block_bytes) // (8 * phi.size * (coef.shape[1] + 4)))
    area = np.zeros(len(todo))
    for i in progress(range(0, height, rows), desc="sh: dense check", unit="block",
                      quiet=quiet):
        st, ct = np.sin(theta[i:i + rows, None]), np.cos(theta[i:i + rows, None])
        local = np.stack(np.broadcast_arrays(st * np.cos(phi), st * np.sin(phi), ct), axis=-1)
        vals = sh_eval(coef, local @ m.T)                                 # (rows, W, K)
        for j, (start, k, tol) in enumerate(spans):
            neg = (vals[..., start:start + k] < -tol).any(axis=-1)        # (rows, W)
            area[j] += float(neg.sum(axis=1) @ om[i:i + rows])
    found = iter(area / (4 * np.pi))
    return [float(next(found)) if e.lmax <= DIRECT_LMAX else None for e in exports]


def measured_rmse(envmap: EnvMap, exports, axes: int = CHECK_AXES, alm=None) -> list[float]:
    """Measured RMSE of each export against the ground truth (module docstring), absolute.

    Irradiance: the exported coefficients evaluated (:meth:`SHCoefficients.evaluate`) at
    ``axes`` spherical Fibonacci directions (above :data:`DIRECT_LMAX`: synthesised from the
    local ``alm``) against π × the ground-truth integrator (computed once). Radiance: the truncated, windowed signal (:func:`pixel_synthesis` of the local
    ``alm``) against the map's bilinear lookup at the pixel centres of a lat-long grid of
    2H rows, weighted by their solid angles (a few thousand directions would miss a sun's
    disc; the map's own pixel centres would weigh a one-pixel peak of the interpolant as
    its whole pixel).
    """
    axes = check_int(axes, "axes", 1)
    A = spherical_fibonacci_sphere(axes) if any(e.irradiance for e in exports) else None
    irr = None if A is None else np.pi * shading_integral(envmap, A, "diffuse")
    h2 = 2 * envmap.height
    if alm is None:
        alm = bilinear_sh_coefficients(envmap, max(e.lmax for e in exports))
    if not all(e.irradiance for e in exports):
        rad = envmap.lookup(pixel_directions(h2, up=envmap.up))
    om = pixel_solid_angles(h2)[..., None]
    out = []
    for e in exports:
        g = np.asarray(e.window_weights) * shading_factors(e.lmax, e.irradiance)
        if e.irradiance:
            est = e.evaluate(A) if e.lmax <= DIRECT_LMAX else synthesize_convolution(
                truncate_alm(alm, e.lmax), e.lmax, g, axes_to_local(A, envmap.up))
            out.append(float(np.sqrt(np.mean((est - irr) ** 2))))
            continue
        err = pixel_synthesis(envmap, alm, g, e.lmax, h2) - rad
        out.append(float(np.sqrt(np.sum(om * err ** 2) / (4 * np.pi * err.shape[-1]))))
    return out


def ringing_rows(alm, power, irradiance: bool, Ls, windows=tuple(WINDOWS),
                 nlat: int | None = None, *, quiet: bool = True) -> list[RingingRow]:
    """Predicted relative error and negative fraction of every (L, window), L in ``Ls``
    (``alm``: local complex coefficients of degree ≥ max(Ls); ``power``: the map's power
    per degree, :func:`envfit.shading._spectra.map_degree_power`, to 2H − 1)."""
    lp = power.shape[1] - 1
    g_all = shading_factors(lp, irradiance)
    mean = signal_mean(alm, g_all)
    alm = truncate_alm(alm, max(Ls))
    rows = []
    for L in progress(Ls, desc="sh: ringing table", unit="degree", quiet=quiet):
        for name in windows:
            lam = sloan_lambda(alm, g_all[:L + 1], L, nlat) if name == "sloan" else None
            w = window_weights(name, L, lam)
            rows.append(RingingRow(
                L=int(L), window=name, window_lambda=lam,
                predicted_relative_rmse=truncation_rmse(power, g_all, w) / mean,
                negative_fraction=negative_fraction(alm, w * g_all[:L + 1], nlat)))
    return rows


def choose(rows, target: float) -> tuple[RingingRow | None, str]:
    """The row to use for a relative ``target`` and the sentence that says why (module
    docstring), conditioned on the rows' numbers."""
    ok = [r for r in rows if r.predicted_relative_rmse <= target]
    clean_all = [r for r in rows if r.negative_fraction == 0.0]
    if not ok:
        best = min(rows, key=lambda r: r.predicted_relative_rmse)
        pos = min(clean_all, key=lambda r: (r.predicted_relative_rmse, r.L), default=None)
        alt = "" if pos is None or pos is best else (
            f"; the smallest error with no negative direction is {_pct(pos)} at {pos.label}")
        return best, (f"no degree up to {max(r.L for r in rows)} meets the {target:.3g} "
                      f"target; the smallest predicted error is {_pct(best)} at {best.label} "
                      f"(negative on {best.negative_fraction:.2%} of directions){alt}")
    clean = [r for r in ok if r.negative_fraction == 0.0]
    if clean:
        r = min(clean, key=lambda r: (r.L, r.predicted_relative_rmse))
        same = [o for o in ok if o.L == r.L and o.negative_fraction > 0]
        alt = (f"; at the same L, {', '.join(o.window for o in same)} would go negative on "
               f"up to {max(o.negative_fraction for o in same):.2%}" if same else "")
        return r, (f"{r.label}: the smallest degree whose predicted error ({_pct(r)} of the "
                   f"mean) meets the {target:.3g} target with no negative direction{alt}")
    r = min(ok, key=lambda r: (r.negative_fraction, r.L, r.predicted_relative_rmse))
    return r, (f"every (L, window) meeting the {target:.3g} target goes negative somewhere; "
               f"the least: {r.label}, {_pct(r)} predicted error, negative on "
               f"{r.negative_fraction:.2%} of directions")


def _pct(r: RingingRow) -> str:
    return f"{r.predicted_relative_rmse:.3%}"
