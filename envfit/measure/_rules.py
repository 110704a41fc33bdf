r"""The measured error of a renderer rule (:class:`envfit.sampling.RendererRule`) on a map.

:func:`measure_rule` measures a rule's RMSE over uniform axes — on axes importance-sampled
from the map's :class:`envfit.measure._axis_proposal.AxisProposal` and weighted, by default —
with a bootstrap 95 % interval and as many axes as the interval needs to be within ±10 %
(:func:`envfit.measure._adaptive_rmse.adaptive_rmse`); the ground truth of each axis is computed
once per :class:`RendererSetup` and brdf and reused by every rule that draws it.

Example
-------
>>> import numpy as np
>>> from envfit.maps._envmap import EnvMap
>>> from envfit.sampling import RendererRule
>>> setup = RendererSetup.of(EnvMap(np.full((8, 16, 1), 2.0)), sources=[])
>>> out = measure_rule(setup, RendererRule("brdf", "sobol", 16), "diffuse", axes_start=20,
...                    max_axes=20, resamples=200)
>>> round(out.interval.rmse, 9)          # a constant map, lobe sampled exactly: no error
0.0
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from envfit.defaults import DEFAULT_SHININESS
from envfit.base import ParameterError
from envfit.maps import EnvMap
from envfit.maps import BrightSource, find_bright_sources
from envfit.measure._adaptive_rmse import AdaptiveRMSE, adaptive_rmse
from envfit.measure._axis_proposal import AxisProposal
from envfit.sampling import ESTIMATORS, MapSampler, RendererRule, rule_points, split_map
from envfit.shading import shading_integral, weight_function

__all__ = ["RendererSetup", "rule_estimates", "measure_rule", "replicates", "SAMPLES_PER_AXIS",
           "AXIS_SAMPLING"]

#: samples per axis of a measurement: N × replicates ≥ this
SAMPLES_PER_AXIS = 4096
#: how :func:`measure_rule` draws its axes: name → adaptive_rmse's proposal on a setup
AXIS_SAMPLING = {
    "importance": lambda setup, rule, brdf, shininess: setup.proposal(
        brdf, shininess, part="rest" if rule.on_rest else "whole"),
    "uniform": lambda setup, rule, brdf, shininess: None,
}



@dataclass
class RendererSetup:
    """A map prepared for the rules: its sampler, bright sources, the source and rest maps and
    the rest map's sampler, and a cache of ground truths per (brdf, shininess, axes)."""

    envmap: EnvMap
    sampler: MapSampler
    sources: tuple[BrightSource, ...]
    source_map: EnvMap
    rest_map: EnvMap
    rest_sampler: MapSampler
    _truth: dict = field(default_factory=dict, repr=False)
    _proposals: dict = field(default_factory=dict, repr=False)

    @classmethod
    def of(cls, envmap: EnvMap, sources=None) -> "RendererSetup":
        """Build it: sources detected with the defaults when None (``[]``: none split off)."""
        if not isinstance(envmap, EnvMap):
            raise ParameterError(f"envmap must be an EnvMap, got {type(envmap).__name__}")
        srcs = tuple(find_bright_sources(envmap) if sources is None else sources)
        smap, rmap = split_map(envmap, list(srcs))
        return cls(envmap, MapSampler(envmap), srcs, smap, rmap, MapSampler(rmap))

    def proposal(self, brdf: str, shininess: float, *, part: str = "whole") -> AxisProposal:
        """The axis proposal (:class:`envfit.measure._axis_proposal.AxisProposal`) of the whole
        map, or (``part="rest"``) of the rest map, for the lobe; built once."""
        key = (part, brdf, float(shininess))
        if key not in self._proposals:
            m, sampler = ((self.rest_map, self.rest_sampler) if part == "rest"
                          else (self.envmap, self.sampler))
            self._proposals[key] = AxisProposal.of(m, sampler, weight_function(brdf, shininess))
        return self._proposals[key]

    def truth(self, axes: np.ndarray, brdf: str, shininess: float, *, part: str = "whole"):
        """Shading integrals (M, C) of the whole map, or (``part="source"``) of the source
        map, at the axes; cached by the axes' bytes."""
        key = (part, brdf, float(shininess), axes.tobytes())
        if key not in self._truth:
            m = self.envmap if part == "whole" else self.source_map
            self._truth[key] = (np.zeros((axes.shape[0], m.channels)) if part == "source"
                                and not self.sources else
                                shading_integral(m, axes, brdf, shininess))
        return self._truth[key]


def rule_estimates(setup: RendererSetup, rule: RendererRule, axes, brdf="diffuse",
                   shininess: float = DEFAULT_SHININESS, *, seed: int = 0, point_seed: int = 0,
                   shift: bool | str = True) -> np.ndarray:
    """The rule's estimates (M, C) at the axes, twisted and shifted with ``seed`` (``shift``
    as :mod:`envfit.sampling._importance`: ``"points"`` makes any set i.i.d. uniform); the
    source part of ``split`` is computed once per distinct axis."""
    A = np.asarray(axes, dtype=np.float64)
    pts = rule_points(rule, point_seed)
    u = pts[0] if len(pts) == 1 else tuple(pts)
    m, sampler = ((setup.rest_map, setup.rest_sampler) if rule.on_rest
                  else (setup.envmap, setup.sampler))
    est = ESTIMATORS[rule.technique](m, A, u, sampler, brdf, shininess, seed=seed, shift=shift)
    if rule.on_rest:
        uniq, inv = np.unique(A, axis=0, return_inverse=True)
        est = est + setup.truth(uniq, brdf, shininess, part="source")[inv.ravel()]
    return est


def replicates(n: int) -> int:
    """Estimates per axis of :func:`measure_rule`: ⌈:data:`SAMPLES_PER_AXIS`/N⌉, so that a
    rare event (a few samples of N = 16 hitting a sun of 1e-4 sr) is seen at small N too."""
    return max(1, -(-SAMPLES_PER_AXIS // int(n)))


def measure_rule(setup: RendererSetup, rule: RendererRule, brdf="diffuse",
                 shininess: float = DEFAULT_SHININESS, *, seed: int = 0,
                 target_relative: float = 0.10,
                 axes_start: int = 500, max_axes: int = 16000,
                 resamples: int = 2000, sampling: str = "importance") -> AdaptiveRMSE:
    """The rule's RMSE over uniform random axes with its bootstrap 95 % interval, adaptive
    (:func:`envfit.measure._adaptive_rmse.adaptive_rmse`: doubling the axes from ``axes_start``
    until the interval is within ±``target_relative`` or ``max_axes`` are measured).

    ``sampling`` (:data:`AXIS_SAMPLING`): ``"importance"`` draws the axes from the map's
    :class:`envfit.measure._axis_proposal.AxisProposal` for the lobe (the rest map's for
    ``split``) and weights each axis's squared error by u/q — unbiased for the mean over
    uniform axes, and on a map with a sun far less skewed than ``"uniform"`` axes, whose
    sample usually holds too few of the axes that catch the sun and so measures low.

    Each axis gets :func:`replicates` independent estimates (twist and shift each; for
    ``random`` every point shifted on its own: a fresh i.i.d. set) and contributes their mean squared error, the bootstrap
    resampling axes. The axes are drawn from ``seed`` (the same for every rule on the same
    proposal — every ``split`` rule, or every other rule, of a lobe — so their truths are
    shared); twists, shifts and random sets from a stream of their own."""
    if sampling not in AXIS_SAMPLING:
        raise ParameterError(f"sampling must be one of {', '.join(AXIS_SAMPLING)}; "
                             f"got {sampling!r}")
    stream = np.random.default_rng([int(seed), 7])
    reps = replicates(rule.n)

    def measure(A: np.ndarray) -> np.ndarray:
        truth = np.repeat(setup.truth(A, brdf, shininess), reps, axis=0)
        AA = np.repeat(A, reps, axis=0)
        s = int(stream.integers(2 ** 62))
        shift = "points" if rule.pointset == "random" else True
        est = rule_estimates(setup, rule, AA, brdf, shininess, seed=s, shift=shift)
        d = ((est - truth) ** 2).mean(axis=1)
        return d.reshape(A.shape[0], reps).mean(axis=1)

    return adaptive_rmse(measure, axes_start=axes_start, max_axes=max_axes,
                         target_relative=target_relative, seed=seed, resamples=resamples,
                         proposal=AXIS_SAMPLING[sampling](setup, rule, brdf, shininess))
