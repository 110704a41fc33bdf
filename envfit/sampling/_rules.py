r"""Renderer sampling rules — a strategy, a point set and N — the renderer's choice.

A *rule* is what a renderer engineer chooses: a strategy of :data:`STRATEGIES`

* ``brdf`` — BRDF (lobe) sampling;
* ``map`` — environment-map importance sampling (pdf ∝ luminance × solid angle);
* ``mis`` — multi-sample MIS of the two, balance heuristic, N/2 samples each;
* ``split`` — the bright sources (:func:`envfit.maps._sources.find_bright_sources`)
  integrated exactly and the rest of the map by ``mis``;

a point set of :func:`envfit.theory._pointsets.square_points` (random, jitter, sobol, lp, bnot,
sf — the square lattice of spherical Fibonacci) and N. Every estimate is randomised as a
renderer does it: each axis gets an independent uniform twist of its frame and an independent
Cranley–Patterson shift of the points (Cycles' per-pixel rotation of its Sobol pattern), so
every rule is unbiased and its RMSE over uniform axes is the number a renderer sees across
normals. MIS uses two point sets of the same kind, N − ⌊N/2⌋ for the map and ⌊N/2⌋ for the
lobe (a set's first half is poorly stratified for SF and LP). ``random`` is measured with
every point shifted independently (``shift="points"``): i.i.d. uniform points, a fresh set
for every estimate, so its measured RMSE is the mean over random sets.

The measurement of a rule's RMSE (:func:`envfit.measure._rules.measure_rule`,
:class:`envfit.measure._rules.RendererSetup`) is in :mod:`envfit.measure._rules`.

Example
-------
>>> r = RendererRule("mis", "sobol", 16)
>>> [p.shape for p in rule_points(r)]
[(8, 2), (8, 2)]
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envfit.base._checks import check_int
from envfit.base._errors import ParameterError
from envfit.theory._pointsets import POINTSETS, square_points

__all__ = ["STRATEGIES", "RendererRule", "rule_points"]

#: strategy → (technique of envfit.sampling._importance, on the rest map after the split?)
STRATEGIES: dict[str, tuple[str, bool]] = {
    "brdf": ("brdf", False),
    "map": ("map", False),
    "mis": ("mis", False),
    "split": ("mis", True),
}

@dataclass(frozen=True)
class RendererRule:
    """A strategy of :data:`STRATEGIES`, a point set of :data:`POINTSETS` and N ≥ 2.

    >>> RendererRule("map", "sobol", 64).label
    'map/sobol'
    """

    strategy: str
    pointset: str
    n: int

    def __post_init__(self):
        if self.strategy not in STRATEGIES:
            raise ParameterError(f"strategy must be one of {', '.join(STRATEGIES)}; "
                                 f"got {self.strategy!r}")
        if self.pointset not in POINTSETS:
            raise ParameterError(f"point set must be one of {', '.join(sorted(POINTSETS))}; "
                                 f"got {self.pointset!r}")
        object.__setattr__(self, "n", check_int(self.n, "N", 2))

    @property
    def label(self) -> str:
        return f"{self.strategy}/{self.pointset}"

    @property
    def technique(self) -> str:
        return STRATEGIES[self.strategy][0]

    @property
    def on_rest(self) -> bool:
        return STRATEGIES[self.strategy][1]


def rule_points(rule: RendererRule, seed: int = 0) -> list[np.ndarray]:
    """The rule's square points: one (N, 2) set, or for MIS the map's N − ⌊N/2⌋ and the
    lobe's ⌊N/2⌋ (seeds ``seed`` and ``seed + 1`` for the stochastic sets)."""
    if rule.technique != "mis":
        return [square_points(rule.pointset, rule.n, seed=seed)]
    n2 = rule.n // 2
    return [square_points(rule.pointset, rule.n - n2, seed=seed),
            square_points(rule.pointset, n2, seed=seed + 1)]
