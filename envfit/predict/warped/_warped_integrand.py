r"""The warped integrand itself: :math:`h_i(u)` of each part of a technique at given square
points, for one axis and twist 0 — the function whose spectrum
:func:`._warped_spectrum.warped_spectrum` takes.

Part i of a technique (:mod:`._techniques`) maps a square point u to a direction
:math:`\omega = T_i(u)` — the map sampler's inverse CDF
(:meth:`envfit.sampling.MapSampler.sample`) or the lobe's warp (the Lambert lift morphed
for the lobe, :func:`envfit.theory.lambert_to_hemisphere`, in the axis's untwisted frame
:func:`envfit.shading.twisted_frames`) — and

.. math:: h_i(u) = w_i(\omega)\,f(\omega)\,\rho_a(\omega)/p_i(\omega),

so that the estimator with the points :math:`u_{ij}` (no shift, no twist) is
:math:`F = \sum_i \frac1{n_i}\sum_j h_i(u_{ij})` (:mod:`envfit.sampling._importance`;
``tests/test_warped_spectrum.py`` checks it against the estimators). BRDF sampling's
:math:`h = f` is taken as 0 where :math:`\rho_a = 0` (the spectrum's convention; the
estimator takes the ratio as 1 there, a set of measure zero: z = 0 of the diffuse lobe).
"""
from __future__ import annotations

import numpy as np

from envfit.base import ParameterError
from envfit.base import as_unit_vectors
from envfit.defaults import DEFAULT_SHININESS
from envfit.maps import EnvMap
from envfit.maps import rows_dot, rows_times
from envfit.sampling import MapSampler
from envfit.sampling import brdf_pdf
from envfit.sampling import square_samples
from envfit.shading import twisted_frames, weight_function
from envfit.theory import lambert_to_hemisphere
from envfit.predict.warped._techniques import Technique, check_options

__all__ = ["warped_integrand"]


def _map_values(envmap: EnvMap, sampler: MapSampler, tech: Technique, a, U) -> np.ndarray:
    """The map part's h (K, C) at the points U (K, 2) for axis a."""
    d, pm = sampler.sample(U)
    rho = brdf_pdf(tech.weight, rows_dot(d, a))
    return envmap.lookup(d) * tech.map_part(rho, pm).factor[:, None]


def _lobe_values(envmap: EnvMap, sampler: MapSampler, tech: Technique, R, U) -> np.ndarray:
    """The lobe part's h (K, C) at the points U (K, 2) in the frame R (third column a)."""
    local = lambert_to_hemisphere(U, morph=tech.weight.morph)
    d = rows_times(local, R.T)
    rho = brdf_pdf(tech.weight, local[:, 2])
    pm = sampler.pdf(d) if tech.name == "mis" else np.ones_like(rho)
    return envmap.lookup(d) * tech.lobe_part(rho, pm).factor[:, None]


def warped_integrand(envmap: EnvMap, technique: str, axis, u, *, brdf="diffuse",
                     shininess: float = DEFAULT_SHININESS, sampler: MapSampler | None = None,
                     heuristic: str = "balance", fraction: float = 0.5) -> np.ndarray:
    r"""The warped integrand :math:`h_i(u)` of every part of ``technique`` at the square
    points u, for ``axis`` and twist 0 (module docstring): (parts, K, C), the map part first
    for MIS.

    Parameters
    ----------
    envmap : the map (f = ``envmap.lookup``).
    technique : "brdf", "map" or "mis" (:data:`._techniques.TECHNIQUES`).
    axis : (3,) the axis a (normalised internally).
    u : (K, 2) square points in [0, 1)²; every part is evaluated at all of them.
    brdf, shininess : the lobe (:func:`envfit.shading.weight_function`).
    sampler : the map's :class:`~envfit.sampling.MapSampler` (its defaults when None).
    heuristic, fraction : MIS heuristic and the map's share ν₁ of the samples (multi-sample
        MIS with :math:`n_1 = \nu_1 N` map samples).

    Raises
    ------
    envfit.base.ParameterError
        Bad arguments (as :func:`._warped_spectrum.warped_spectrum`), an axis that is not one
        vector, points outside the square.

    >>> m = EnvMap(np.full((8, 16, 1), 2.0))
    >>> h = warped_integrand(m, "brdf", [0, 0, 1.0], [[0.3, 0.6], [0.8, 0.1]])
    >>> h.shape, h.ravel().round(12).tolist()                     # h = f: the lobe is exact
    ((1, 2, 1), [2.0, 2.0])
    """
    check_options(envmap, technique, None, heuristic, fraction)
    a = as_unit_vectors(axis, name="axis")
    if a.shape[0] != 1:
        raise ParameterError(f"axis must be one vector (3,), got {a.shape[0]}")
    tech = Technique.of(technique, weight_function(brdf, shininess), heuristic, fraction)
    sampler = MapSampler(envmap) if sampler is None else sampler
    U = square_samples(u)
    out = []
    if tech.samples_map:
        out.append(_map_values(envmap, sampler, tech, a[0], U))
    if tech.samples_lobe:
        out.append(_lobe_values(envmap, sampler, tech, twisted_frames(a, None)[0], U))
    return np.stack(out)
