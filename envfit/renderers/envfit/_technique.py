r"""envfit's own estimator as a renderer record, so that the registry is complete: the
:class:`envfit.sampling.MapSampler` (piecewise constant per pixel, pdf ∝ luminance × solid
angle, the bilinear-smoothed luminance, a 1 % floor), BRDF sampling by the lobe's own morph
(diffuse :math:`z = \sqrt{u_0}`, :math:`\phi = 2\pi u_1`), the **balance** heuristic with
N − ⌊N/2⌋ map and ⌊N/2⌋ lobe samples (:mod:`envfit.sampling._rules`), and envfit's point
sets, randomised by one Cranley–Patterson shift and one frame twist per axis
(:mod:`envfit.sampling._importance`).
"""
from __future__ import annotations

import numpy as np

from envfit.sampling import MapSampler
from envfit.renderers._base import (DirectionSample, EnvmapTechnique, Renderer,
                                           SamplerSpec, StrategySetting, square_points)
from envfit.shading import twisted_frames

__all__ = ["EnvfitMapTechnique", "envfit_cosine", "envfit_frame", "ENVFIT"]


class EnvfitMapTechnique(EnvmapTechnique):
    """envfit's map technique: radiance = :meth:`envfit.maps.EnvMap.lookup` (envfit's
    bilinear interpolant, RGB), sampling and pdf = :class:`envfit.sampling.MapSampler`
    (``u[:, 0]`` → rows, ``u[:, 1]`` → columns); directions in envfit's world frame.

    >>> from envfit.maps import EnvMap
    >>> t = EnvfitMapTechnique(EnvMap(np.ones((4, 8, 3))))
    >>> d, p = t.sample([[0.25, 0.5]])
    >>> bool(np.isclose(p[0], 1 / (4 * np.pi))), bool(np.allclose(t.pdf(d), p))
    (True, True)
    """

    name = "envfit"
    renderer = "envfit MapSampler"
    source = "envfit.sampling._map_sampler.MapSampler; envfit.maps._latlong.bilinear_lookup"

    def __init__(self, envmap, **options):
        self.envmap = envmap
        self.sampler = MapSampler(envmap, **options)
        self.native_to_world = np.eye(3)

    def _eval_native(self, d):
        f = np.asarray(self.envmap.lookup(d), dtype=np.float64).reshape(len(d), -1)
        return np.repeat(f, 3, axis=1) if f.shape[1] == 1 else f[:, :3]

    def _sample_native(self, u):
        return self.sampler.sample(np.minimum(u, np.nextafter(1.0, 0.0)))

    def _pdf_native(self, d):
        return self.sampler.pdf(d)


def envfit_cosine(u) -> DirectionSample:
    r"""envfit's diffuse lobe sampling: the Lambert lift with the cosine morph,
    :math:`z = \sqrt{u_0}`, :math:`\phi = 2\pi u_1` (:func:`envfit.theory.lambert_to_hemisphere`
    with ``morph`` of the diffuse weight), pdf :math:`z/\pi`.

    >>> d, p = envfit_cosine([[1.0, 0.0]])
    >>> d.tolist(), bool(np.isclose(p[0], 1 / np.pi))
    ([[0.0, 0.0, 1.0]], True)
    """
    U = square_points(u)
    z = np.sqrt(U[:, 0])
    phi = 2.0 * np.pi * U[:, 1]
    r = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    return DirectionSample(np.column_stack([r * np.cos(phi), r * np.sin(phi), z]), z / np.pi)


def envfit_frame(normals) -> np.ndarray:
    """envfit's untwisted frame about each axis (K, 3, 3), rows (t, b, n):
    :func:`envfit.shading.twisted_frames` without a seed (the estimators add a uniform twist
    per axis)."""
    return np.transpose(twisted_frames(np.asarray(normals, dtype=np.float64).reshape(-1, 3)),
                        (0, 2, 1))



def _row_strata(n: int) -> tuple:
    """The jitter rule's strata by rows (:func:`envfit.theory.jitter_strata`)."""
    return (("layout", "rows"),)

_R = "envfit.theory._pointsets.square_points; one CP shift per axis (envfit.sampling._importance)"
SAMPLERS = {
    "random": SamplerSpec("random", "independent", "independent", int,
                          "i.i.d. uniform points, a fresh set per estimate. " + _R),
    "jitter": SamplerSpec("jitter", "jittered", "shared_shift", int,
                          "stratified jitter. " + _R, options=_row_strata),
    "sobol": SamplerSpec("sobol", "cp_shift", "shared_shift", int,
                         "Sobol' (0,2) points, Cranley-Patterson shifted. " + _R, default=True),
    "lp": SamplerSpec("lp", "cp_shift", "shared_shift", int,
                      "Larcher-Pillichshammer points, shifted. " + _R),
    "sf": SamplerSpec("sf", "cp_shift", "shared_shift", int,
                      "the square lattice of spherical Fibonacci, shifted. " + _R),
    "bnot": SamplerSpec("bnot", "cp_shift", "shared_shift", int,
                        "blue-noise optimal transport points, shifted. " + _R),
}

STRATEGIES = {
    "map": StrategySetting("map", True, "envfit", {"strategy": "map"}, 1, 0, "plain",
                           "N map samples"),
    "brdf": StrategySetting("brdf", True, "envfit", {"strategy": "brdf"}, 0, 1, "plain",
                            "N lobe samples"),
    "mis": StrategySetting("mis", True, "envfit", {"strategy": "mis"}, 1, 1, "plain",
                           "balance heuristic, N - N//2 map and N//2 lobe samples"),
}


def _snippet(s: StrategySetting, spec: SamplerSpec, spp: int, *,
             filename: str = "envmap.exr") -> str:
    """The envfit call that measures this rule (a renderer rule of envfit's own)."""
    return (f"from envfit.maps import load_envmap\n"
            f"from envfit.sampling import RendererRule, rule_points\n"
            f"envmap = load_envmap({filename!r})\n"
            f"rule = RendererRule({s.settings['strategy']!r}, {spec.name!r}, {spp})\n"
            f"points = rule_points(rule)\n")


ENVFIT = Renderer(
    name="envfit",
    renderer="envfit's own estimators (MapSampler, lobe sampling, balance MIS)",
    technique=EnvfitMapTechnique,
    cosine=envfit_cosine,
    tangent_frame=envfit_frame,
    heuristic="balance",
    strategies=STRATEGIES,
    samplers=SAMPLERS,
    snippet_fn=_snippet,
    source="envfit.sampling._map_sampler, _importance, _rules",
    display="envfit",
    negative_radiance=("envfit's MapSampler samples by luminance with a 1 % floor, and no "
                       "measurement checks the model of a signed map"),
)
