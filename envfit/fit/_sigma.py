r"""σ̂, the scale of the GP model :math:`f \sim GP(0, \sigma^2 K_{gd}^{(s)})` of a map at a given s:
the paper's kernel (:func:`profiled_sigma`) and the band-limited one
(:func:`bandlimited_profiled_sigma`), channels combined (:func:`combine_sigma`), and the
``"auto" | value`` choice of s (:func:`parse_s`). Used by validation and by the advisor.
"""
from __future__ import annotations

import math

import numpy as np

from envfit.theory import cho_factor, cho_solve
from envfit.theory import sphere_points
from envfit.theory import kernel_matrix

from envfit.sobolev import (bandlimited_log_likelihood, map_band_limit, max_samples,
                            pixel_centre_samples)
from envfit.sobolev import profiled_log_likelihood
from envfit.base import check_int
from envfit.maps import EnvMap
from envfit.base import ParameterError
from envfit.maps import local_to_world
from envfit.base import plan_memory
from envfit.shading import (bandlimited_worst_case_error, bandlimited_worst_case_errors,
                            low_degree_power_ratio, lookup_transfer, map_degree_power,
                            model_scatter, pixel_degree_power, rule_error_power,
                            sh_truncation_curve_transfer, spectral_rmse)


def parse_s(value) -> float | str:
    """``"auto"`` or a smoothness in (1, 2) (a string or number); else :class:`ParameterError`.

    >>> parse_s("auto"), parse_s("1.5"), parse_s(1.3)
    ('auto', 1.5, 1.3)
    """
    if isinstance(value, str):
        text = value.strip().lower()
        if text == "auto":
            return "auto"
        try:
            v = float(text)
        except ValueError:
            raise ParameterError(f"s (--s) must be 'auto' or a number in (1, 2), got {value!r}") \
                from None
    else:
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ParameterError(f"s (--s) must be 'auto' or a number in (1, 2), got {value!r}") \
                from None
    if not (math.isfinite(v) and 1.0 < v < 2.0):
        raise ParameterError(f"s (--s) must be 'auto' or a number in (1, 2) (the Sobolev range "
                             f"of the kernel, Eq. 14), got {value!r}")
    return v


def profiled_sigma(envmap: EnvMap, s: float, *, n: int = 1500, seed: int = 0) -> np.ndarray:
    r"""σ̂ per channel of the GP model f ~ GP(0, σ² K_gd^(s)) at a given s, (C,).

    The profiled maximum-likelihood scale (the same estimate as ``envfit fit --method
    likelihood`` at its fitted s): with the map sampled at n spherical Fibonacci directions
    (the fit's sampling, :func:`envfit.theory._sphere_points.sphere_points`), values centred per
    channel (the map's mean is its l = 0 term),

    .. math:: \hat\sigma_c^2 = \frac{1}{n} f_c^T K^{-1} f_c, \qquad K_{ij} = K^{(s)}_{gd}(u_i, u_j)
              \quad (14)

    by a float64 Cholesky factorisation
    (:func:`envfit.sobolev._likelihood.profiled_log_likelihood`). Does not need
    :mod:`envfit.sobolev._interpolation`.
    ``envmap`` must already be on the wanted value scale.

    >>> from envfit.maps._envmap import EnvMap
    >>> m = EnvMap(np.full((8, 16, 2), 3.0))          # a constant: zero after centring
    >>> profiled_sigma(m, 1.5, n=50).tolist()
    [0.0, 0.0]
    """
    s = float(parse_s(s))
    n = check_int(n, "n", 2)
    plan_memory(n, "the sigma fit", channels=envmap.channels, n_name="fit_n")
    local = sphere_points("sf", n, seed=seed)
    dirs = local @ local_to_world(envmap.up).T
    v = envmap.lookup(dirs).reshape(n, envmap.channels)
    v = v - v.mean(axis=0, keepdims=True)
    K = kernel_matrix(local, s)
    try:  # kernel_matrix is Fortran-ordered: factorised in place
        cf = cho_factor(K, overwrite_a=True)
    except np.linalg.LinAlgError:  # pragma: no cover - SF points are distinct
        raise ParameterError("kernel matrix of the sigma fit is not positive definite") from None
    log_det = 2.0 * float(np.sum(np.log(np.diagonal(cf[0]))))
    return np.atleast_1d(profiled_log_likelihood(v, cho_solve(cf, v), log_det).sigma)


def combine_sigma(sigmas) -> float:
    r"""Channels' σ̂ combined as RMS, :math:`(\frac1C\sum_c\sigma_c^2)^{1/2}` — the σ of the
    RMSE over axes *and* channels (:func:`envfit.shading._estimators.rmse_over_axes`).

    >>> combine_sigma([3.0, 4.0]) == (12.5) ** 0.5
    True
    """
    s = np.asarray(sigmas, dtype=np.float64).ravel()
    if s.size == 0:
        raise ParameterError("no sigma to combine")
    return float(np.sqrt(np.mean(s * s)))


def bandlimited_profiled_sigma(scaled: EnvMap, s: float, *, n: int = 1500,
                               seed: int = 0) -> tuple[np.ndarray, int]:
    r"""σ̂ per channel at a given s under the band-limited model (:mod:`envfit.sobolev._bandlimited`):
    ``n`` spherical Fibonacci directions (at most :func:`envfit.sobolev._bandlimited.max_samples`)
    moved to their pixel centres, values centred per
    channel, :math:`\hat\sigma_c^2 = f_c^T K_{H-1}^{-1} f_c / n`. ``scaled`` must already
    be on the wanted value scale. Returns ``(sigma (C,), samples used)``.

    >>> from envfit.maps._envmap import EnvMap
    >>> sig, used = bandlimited_profiled_sigma(EnvMap(np.full((8, 16, 2), 3.0)), 1.5, n=50)
    >>> sig.tolist(), used                      # n capped at 8²/2 = 32 on 8 rows
    ([0.0, 0.0], 32)
    """
    s = float(parse_s(s))
    n = min(check_int(n, "n", 10), max(10, max_samples(map_band_limit(scaled))))
    plan_memory(n, "the band-limited sigma fit", channels=scaled.channels, n_name="fit_n",
                smallest=10)
    local = sphere_points("sf", n, seed=seed)
    pts, v = pixel_centre_samples(scaled, local @ local_to_world(scaled.up).T)
    v = v - v.mean(axis=0, keepdims=True)
    ll, sig = bandlimited_log_likelihood(pts, v, s, map_band_limit(scaled))
    return np.atleast_1d(sig), int(len(pts))
