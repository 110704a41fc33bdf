r"""Rules: what a shading estimate integrates with — one concept, two kinds.

A *rule* is N points and how they are used to estimate the shading integral
:math:`\int f(u)\,p(u\cdot a)\,du`. Two kinds exist in envfit, and they share nothing but N
and the role (the thing a predictor of :mod:`envfit.predict` predicts the error of), so they
are two small classes under one base, :class:`Rule`, rather than one type whose fields
half apply:

* :class:`QuadratureRule` — the paper's rule (Marques et al., Sec. 5): points on the sphere
  with weights :math:`w_j`, :math:`\tilde I = \sum_j w_j f(u_j)` for a lobe, at fixed points;
  what its predictors read is its worst-case error :math:`E(s)` (Eq. 41), its error power per
  degree :math:`e_l` and :math:`\sum_j w_j` — computed once by
  :meth:`QuadratureRule.from_points` (or read from a stored cell);
* :class:`RendererRule` — the renderer's choice: a strategy of :data:`STRATEGIES`, a point
  set of :func:`envfit.theory._pointsets.square_points` and N; its points live on the unit
  square and are warped by the strategy's technique, twisted and shifted per axis, so it has
  no weights and no :math:`e_l`: its predictor reads the warped integrand's spectrum.

The registry of predictors (:data:`envfit.predict.PREDICTORS`) dispatches on this base: every
predictor is ``f(ctx, rule: Rule) -> Prediction`` and says which kind it reads
(:func:`envfit.predict.predict` refuses the other kind with one line).

The renderer strategies:

* ``brdf`` — BRDF (lobe) sampling;
* ``map`` — environment-map importance sampling (pdf ∝ luminance × solid angle);
* ``mis`` — multi-sample MIS of the two, balance heuristic, N/2 samples each;
* ``split`` — the bright sources (:func:`envfit.maps._bright_sources.find_bright_sources`)
  integrated exactly and the rest of the map by ``mis``;

with a point set of :func:`envfit.theory._pointsets.square_points` (random, jitter, sobol, lp,
bnot, sf — the square lattice of spherical Fibonacci) and N. Every estimate is randomised as a
renderer does it: each axis gets an independent uniform twist of its frame and an independent
Cranley–Patterson shift of the points (Cycles' per-pixel rotation of its Sobol pattern), so
every rule is unbiased and its RMSE over uniform axes is the number a renderer sees across
normals. MIS uses two point sets of the same kind, N − ⌊N/2⌋ for the map and ⌊N/2⌋ for the
lobe (a set's first half is poorly stratified for SF and LP). ``random`` is measured with
every point shifted independently (``shift="points"``): i.i.d. uniform points, a fresh set
for every estimate, so its measured RMSE is the mean over random sets.

The measurement of a renderer rule's RMSE (:func:`envfit.measure._rules.measure_rule`,
:class:`envfit.measure._rules.RendererSetup`) is in :mod:`envfit.measure._rules`.

Example
-------
>>> r = RendererRule("mis", "sobol", 16)
>>> [p.shape for p in rule_points(r)]
[(8, 2), (8, 2)]
>>> isinstance(r, Rule), isinstance(QuadratureRule(n=16, wce=0.5), Rule)
(True, True)
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from envfit.base import check_int
from envfit.base import ParameterError
from envfit.shading import rule_error_power
from envfit.theory import POINTSETS, square_points
from envfit.theory import worst_case_error

__all__ = ["STRATEGIES", "Rule", "QuadratureRule", "RendererRule", "rule_points"]

#: strategy → (technique of envfit.sampling._importance, on the rest map after the split?)
STRATEGIES: dict[str, tuple[str, bool]] = {
    "brdf": ("brdf", False),
    "map": ("map", False),
    "mis": ("mis", False),
    "split": ("mis", True),
}


@dataclass(frozen=True)
class Rule:
    """The base of every rule: N points (for a truncation, the cut-off degree L).

    Not used on its own: a predictor reads a :class:`QuadratureRule` or a
    :class:`RendererRule` (see the module docstring for why two kinds).
    """

    n: int


@dataclass(frozen=True)
class QuadratureRule(Rule):
    r"""The paper's quadrature rule (or a truncation) as its predictors read it.

    Attributes
    ----------
    n : the number of points N (for a truncation: the cut-off degree L).
    wce : its worst-case error :math:`E(\hat s)` (Eq. 41) at the context's s; None: unknown.
    error_power : :math:`e_l`, l = 0…H − 1 (or more), the squared error of the rule on the
        degree-l harmonics (:func:`envfit.shading._spectra.rule_error_power`); None: unknown.
    weight_sum : :math:`\sum_j w_j`; None for a rule without weights (a truncation keeps
        :math:`b_0` exactly: no error from the map's mean).
    wce_bandlimited : :math:`E'(\hat s')` given directly, used by (b′) when there is no
        ``error_power`` (a truncation's closed form,
        :func:`envfit.shading._spectra.sh_truncation_curve_transfer`).
    weight_dev2 : the mean of :math:`(\sum_j w_j - 1)^2` over the realisations of a
        stochastic point set whose terms are averaged (the advisor's curves); None:
        :math:`(\text{weight\_sum} - 1)^2`.
    points, weights, brdf : the rule itself, when at hand (informative only).
    """

    wce: float | None = None
    error_power: Sequence[float] | np.ndarray | None = None
    weight_sum: float | None = None
    wce_bandlimited: float | None = None
    weight_dev2: float | None = None
    points: np.ndarray | None = None
    weights: np.ndarray | None = None
    brdf: object | None = None

    @classmethod
    def from_points(cls, points, weights, brdf, s: float, band_lmax: int, *,
                    workers: int = 1) -> "QuadratureRule":
        r"""The rule of ``points`` and ``weights`` for ``brdf``: E(s)
        (:func:`envfit.theory._quadrature.worst_case_error`), :math:`e_l` to
        ``band_lmax`` (:func:`envfit.shading._spectra.rule_error_power`), :math:`\sum_j w_j`.

        >>> from envfit.theory._brdf import Diffuse
        >>> r = QuadratureRule.from_points(np.array([[0.0, 0.0, 1.0]]), [1.0], Diffuse(), 1.5, 4)
        >>> r.n, r.weight_sum, r.error_power.shape
        (1, 1.0, (5,))
        """
        pts = np.asarray(points, dtype=np.float64)
        w = np.asarray(weights, dtype=np.float64)
        return cls(n=int(pts.shape[0]),
                   wce=worst_case_error(pts, w, brdf, s, workers=workers),
                   error_power=rule_error_power(pts, w, brdf, band_lmax),
                   weight_sum=float(np.sum(w)), points=pts, weights=w, brdf=brdf)


@dataclass(frozen=True)
class RendererRule(Rule):
    """A strategy of :data:`STRATEGIES`, a point set of :data:`POINTSETS` and N ≥ 2.

    >>> RendererRule("map", "sobol", 64).label
    'map/sobol'
    """

    strategy: str = ""
    pointset: str = ""

    def __init__(self, strategy: str, pointset: str, n: int):
        object.__setattr__(self, "strategy", strategy)
        object.__setattr__(self, "pointset", pointset)
        object.__setattr__(self, "n", n)
        self.__post_init__()

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
