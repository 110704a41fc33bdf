r"""What ``envfit validate`` runs: :class:`ValidateConfig`, the ``--quick`` preset
(:func:`quick_config`, :data:`QUICK_DESCRIPTION`) and the named sets it draws from."""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Sequence

from envfit.base import check_int, check_ints, check_names, check_positive
from envfit.base import ParameterError
from envfit.defaults import (ALL_POINTSETS, BRDFS, DEFAULT_POINTSETS, DEFAULT_SHININESS,
                             QUICK_N, VALIDATE_N, WEIGHTINGS)
from envfit.fit import parse_s
from envfit.theory import POINTSETS

__all__ = ["ValidateConfig", "quick_config", "ALL_POINTSETS", "WEIGHTINGS", "BRDFS", "DEFAULT_N",
           "QUICK_N", "QUICK_POINTSETS", "S_CANDIDATES", "QUICK_DESCRIPTION", "BRDF_INDEX"]

# ALL_POINTSETS (the paper's six point sets, Sec. 7.1, in the registry's order: also the
# seed index), WEIGHTINGS, BRDFS and QUICK_N (16 … 1024) are envfit.defaults', re-exported
DEFAULT_N = VALIDATE_N                                     # 16 … 4096
QUICK_POINTSETS = DEFAULT_POINTSETS                        # all but BNOT
#: smoothness values against which the fitted s is compared (shape residual)
S_CANDIDATES = (1.1, 1.3, 1.5, 1.7, 1.9)

QUICK_DESCRIPTION = (
    "--quick: the map downscaled to at most 256 rows, M = 500 axes, N = 16…1024, point sets "
    "sf, sobol, lp, random, jitter (BNOT left out: its optimal-transport construction alone "
    "costs ~10 s at N = 1024), s fitted from 600 samples, SH truncation L = 0…12, HSH on 64 "
    "rows with 100 axes up to L = 10, QMC-equivalent N searched up to 1024.")

#: seed index of a BRDF (the twists about the axes)
BRDF_INDEX = {"diffuse": 0, "glossy": 1}


@dataclass
class ValidateConfig:
    """What :func:`run_validation` runs (the defaults are the full run of the issue).

    Attributes
    ----------
    s : "auto" (fit s and σ with ``fit_method`` from ``fit_n`` samples) or a value in (1, 2)
        (σ then from the profiled likelihood at that s, :func:`profiled_sigma`).
    brdfs, shininess : "diffuse" and/or "glossy" (n = ``shininess``).
    pointsets, weights, n_values : the quadrature rules (weights ∈ {"equal", "osw"}).
    axes : M, the number of random axes.
    scale : value scale of the integrand ("display", "linear", "log").
    seed : one seed for axes, twists, stochastic point sets and the fit.
    truncation : run the SH/HSH truncation experiment (Fig. 8).
    sh_L, hsh_L : cut-off degrees; diffuse HSH uses ``diffuse_hsh_L`` (exact from L = 1).
    hsh_axes, hsh_max_height : the cheaper setting of the HSH measurement.
    equivalent_nmax : largest N searched for the QMC-equivalent of a truncation.
    s_candidates : s values compared by the shape residual (the used s is added).
    fit_method, fit_n : the smoothness fit.
    workers : threads for the bilinear lookups and the O(N²) error sums.
    quick : only recorded (what ``--quick`` changed is in :data:`QUICK_DESCRIPTION`).
    """

    s: float | str = "auto"
    brdfs: Sequence[str] = BRDFS
    shininess: float = DEFAULT_SHININESS
    pointsets: Sequence[str] = ALL_POINTSETS
    weights: Sequence[str] = WEIGHTINGS
    n_values: Sequence[int] = DEFAULT_N
    axes: int = 2000
    scale: str = "display"
    seed: int = 0
    truncation: bool = True
    sh_L: Sequence[int] = tuple(range(0, 21))
    hsh_L: Sequence[int] = tuple(range(0, 17))
    diffuse_hsh_L: Sequence[int] = (0, 1, 2)
    hsh_axes: int = 250
    hsh_max_height: int = 128
    equivalent_nmax: int = 4096
    s_candidates: Sequence[float] = S_CANDIDATES
    fit_method: str = "likelihood"
    fit_n: int = 1500
    workers: int = 2
    quick: bool = False

    def __post_init__(self) -> None:
        self.s = parse_s(self.s)
        self.brdfs = tuple(check_names(self.brdfs, BRDFS, "BRDF"))
        self.pointsets = tuple(check_names(self.pointsets, tuple(POINTSETS), "point set"))
        self.weights = tuple(check_names(self.weights, WEIGHTINGS, "weighting"))
        self.shininess = check_positive(self.shininess, "shininess")
        self.n_values = tuple(sorted(set(check_ints(self.n_values, "N", 2))))
        self.axes = check_int(self.axes, "the number of axes", 2)
        self.sh_L = tuple(sorted(set(check_ints(self.sh_L, "L", 0))))
        self.hsh_L = tuple(sorted(set(check_ints(self.hsh_L, "L", 0))))
        self.diffuse_hsh_L = tuple(sorted(set(check_ints(self.diffuse_hsh_L, "L", 0))))
        self.hsh_axes = check_int(self.hsh_axes, "hsh_axes", 2)
        self.hsh_max_height = check_int(self.hsh_max_height, "hsh_max_height", 2)
        self.equivalent_nmax = check_int(self.equivalent_nmax, "equivalent_nmax", 2)
        self.fit_n = check_int(self.fit_n, "fit_n", 10)
        self.workers = max(1, int(self.workers))
        cands = []
        for v in self.s_candidates:
            cands.append(parse_s(v))
        self.s_candidates = tuple(sorted(set(float(c) for c in cands)))
        if self.scale not in ("display", "linear", "log"):
            raise ParameterError(f"scale must be display, linear or log, got {self.scale!r}")
        if not self.brdfs or not self.pointsets or not self.weights or not self.n_values:
            raise ParameterError("validate needs at least one BRDF, point set, weighting and N")

    def to_dict(self) -> dict:
        """The configuration as JSON-ready values (tuples as lists)."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}


def quick_config(**overrides) -> ValidateConfig:
    """The ``--quick`` configuration (:data:`QUICK_DESCRIPTION`), with ``overrides``.

    The map itself is downscaled by the caller (the CLI: ``--max-height 256``).

    >>> quick_config().axes, quick_config().n_values[-1]
    (500, 1024)
    """
    base = dict(axes=500, n_values=QUICK_N, pointsets=QUICK_POINTSETS, fit_n=600,
                sh_L=tuple(range(0, 13)), hsh_L=tuple(range(0, 11)), hsh_axes=100,
                hsh_max_height=64, equivalent_nmax=1024, quick=True)
    base.update(overrides)
    return ValidateConfig(**base)
