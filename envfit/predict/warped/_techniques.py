r"""The renderer estimators as sums of warped integrands: each technique's parts, and per part
the factor and the density of its warped integrand.

Every estimator of :mod:`envfit.sampling._importance` is a mean over square points,
:math:`F = \sum_i \frac{1}{n_i}\sum_j h_i(u_{ij})`, with one part i per sample stream and the
*warped integrand* :math:`h_i(u) = w_i(\omega)\,f(\omega)\rho_a(\omega)/p_i(\omega)` at
:math:`\omega = T_i(u)` — here written :math:`h_i = f\cdot\mathrm{factor}_i`, sampled with
density :math:`p_i` (:class:`PartTerms`):

* ``map`` — one part, :math:`\mathrm{factor} = \rho_a/p_\mathrm{map}`, density
  :math:`p_\mathrm{map}` (the :class:`~envfit.sampling.MapSampler` pdf);
* ``brdf`` — one part, factor 1 (0 where :math:`\rho_a = 0`), density :math:`\rho_a` (the lobe
  is sampled exactly: :func:`envfit.sampling._importance.brdf_pdf`);
* ``mis`` — multi-sample MIS (Veach 1997, §9.2.2), the map part then the lobe part, with
  :math:`q = (\nu_1 p_\mathrm{map}, \nu_2\rho_a)` and the heuristic's :math:`w_i/q_i`:
  :math:`\mathrm{factor}_i = \nu_i\rho_a\,w_i/q_i = w_i\rho_a/p_i`.

:class:`Technique` bundles what the spectrum needs of an estimator (its name, lobe, MIS
shares ν and heuristic), so that the functions that evaluate the parts take one argument.

Reference: E. Veach, PhD thesis (Stanford 1997), ch. 9 (MIS).

>>> import numpy as np
>>> from envfit.shading import weight_function
>>> t = Technique.of("mis", weight_function("diffuse", 30.0), "balance", 0.5)
>>> [float(p.factor[0]) for p in t.terms(np.array([0.2]), np.array([0.6]))]   # w_i ρ / p_i
[0.25, 0.25]
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envfit.base import ParameterError
from envfit.base import check_int
from envfit.maps import EnvMap
from envfit.sampling import HEURISTICS

__all__ = ["TECHNIQUES", "PartTerms", "Technique", "check_options"]

#: the techniques and their number of parts (sample streams)
TECHNIQUES = {"brdf": 1, "map": 1, "mis": 2}


@dataclass(frozen=True)
class PartTerms:
    """One part's warped integrand :math:`h_i = f\\cdot` ``factor`` and its density ``pdf``."""

    factor: np.ndarray
    pdf: np.ndarray


@dataclass(frozen=True, eq=False)
class Technique:
    """An estimator as the spectrum sees it: ``name`` (:data:`TECHNIQUES`), the lobe
    ``weight`` (:func:`envfit.shading.weight_function`), the shares ``nu`` (2,) =
    (ν₁, 1 − ν₁) and the MIS ``heuristic`` (:data:`envfit.sampling.HEURISTICS`)."""

    name: str
    weight: object
    nu: np.ndarray
    heuristic: object

    @classmethod
    def of(cls, name: str, weight, heuristic: str = "balance",
           fraction: float = 0.5) -> "Technique":
        """The technique of checked arguments (:func:`check_options`)."""
        nu1 = float(fraction)
        return cls(name, weight, np.array([nu1, 1.0 - nu1]), HEURISTICS[heuristic])

    @property
    def parts(self) -> int:
        """The number of parts (sample streams)."""
        return TECHNIQUES[self.name]

    @property
    def samples_map(self) -> bool:
        """Whether a part draws from the map sampler (map, MIS)."""
        return self.name != "brdf"

    @property
    def samples_lobe(self) -> bool:
        """Whether a part draws from the lobe (BRDF, MIS)."""
        return self.name != "map"

    def is_lobe_part(self, i: int) -> bool:
        """Whether part i is the lobe's (BRDF's only part, MIS's second)."""
        return self.name == "brdf" or (self.name == "mis" and i == 1)

    def terms(self, rho: np.ndarray, pm: np.ndarray) -> list[PartTerms]:
        r"""Per part the factor and density at directions where the lobe is ``rho`` =
        :math:`\rho_a` and the map pdf ``pm`` (module docstring)."""
        if self.name == "map":
            return [PartTerms(np.divide(rho, pm, out=np.zeros_like(rho), where=pm > 0), pm)]
        if self.name == "brdf":
            return [PartTerms(np.where(rho > 0, 1.0, 0.0), rho)]
        nu, heur = self.nu, self.heuristic
        q = np.stack([nu[0] * pm, nu[1] * rho])
        return [PartTerms(nu[0] * rho * heur.over_q(q, 0), pm),
                PartTerms(nu[1] * rho * heur.over_q(q, 1), rho)]

    def map_part(self, rho: np.ndarray, pm: np.ndarray) -> PartTerms:
        """The terms of the part sampled from the map (map, MIS)."""
        return self.terms(rho, pm)[0]

    def lobe_part(self, rho: np.ndarray, pm: np.ndarray) -> PartTerms:
        """The terms of the part sampled from the lobe (BRDF, MIS)."""
        return self.terms(rho, pm)[-1]


def check_options(envmap, technique, grid, heuristic, fraction) -> int | None:
    """Raise :class:`~envfit.base.ParameterError` for a non-map, an unknown technique, a grid
    G that is not a multiple of 4 (≥ 8), an unknown heuristic or an MIS share outside (0, 1),
    in that order; G (None when ``grid`` is None: not checked)."""
    if not isinstance(envmap, EnvMap):
        raise ParameterError(f"envmap must be an EnvMap, got {type(envmap).__name__}")
    if technique not in TECHNIQUES:
        raise ParameterError(f"technique must be one of {', '.join(TECHNIQUES)}; "
                             f"got {technique!r}")
    g = None
    if grid is not None:
        g = check_int(grid, "grid", 8)
        if g % 4:
            raise ParameterError(f"grid must be a multiple of 4, got {grid}")
    if heuristic not in HEURISTICS:
        raise ParameterError(f"heuristic must be one of {', '.join(HEURISTICS)}; "
                             f"got {heuristic!r}")
    try:
        nu1 = float(fraction)
    except (TypeError, ValueError):
        nu1 = float("nan")
    if not 0.0 < nu1 < 1.0:
        raise ParameterError(f"fraction must be in (0, 1), got {fraction!r}")
    return g
