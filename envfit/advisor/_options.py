r"""What the advisor is asked: :class:`AdviseOptions`, its parameters grouped by role and checked
in one place, and their defaults.

Roles: the *target* (BRDF lobe, target error, value scale), the *rules* sized (point sets,
weightings, SH/HSH bases), the *fit* of s' and σ' (``s``, ``fit_n``, ``seed``), the *search*
range (``nmin``, ``nmax``, ``osw_nmax``, ``seeds`` realisations per N), the *check* (``axes``
and the HSH check's size) and the *cache*; ``workers`` and ``quiet`` only say how to run.
Every check raises :class:`envfit.base._errors.ParameterError` with a one-line message (the
CLI's exit code 2), with the checks of :mod:`envfit.base._checks`.

Example
-------
>>> o = AdviseOptions(brdf="Glossy", target_rmse=0.01, pointsets=["SF", "sf"], bases=())
>>> o.brdf, o.shininess, o.pointsets, o.weights, o.nmax
('glossy', 30.0, ('sf',), ('equal', 'osw'), 65536)
>>> AdviseOptions(target_rmse=0.01).shininess is None           # diffuse: no lobe exponent
True
>>> o = AdviseOptions(); o.scale, o.target_relative, o.target_rmse, o.predictor   # the defaults
('linear', 0.01, None, 'auto')
>>> AdviseOptions(target_rmse=0.01, nmin=100, nmax=10)
Traceback (most recent call last):
...
envfit.base._errors.ParameterError: nmax must be an integer >= 100, got 10
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields

from envfit.advisor._rule_rows import DEFAULT_RENDERER_POINTSETS, DEFAULT_STRATEGIES
from envfit.base import check_int, check_names, check_positive
from envfit.base import ParameterError
from envfit.defaults import (ADVISE_SPECTRUM_AXES as RENDERER_SPECTRUM_AXES, ALL_POINTSETS,
                             BRDFS, DEFAULT_POINTSETS, DEFAULT_SHININESS, PREDICTOR_CHOICES,
                             RENDERER_AXES_START, RENDERER_GRID, RENDERER_MAX_AXES, WEIGHTINGS)
from envfit.fit import parse_s
from envfit.maps import SCALES
from envfit.shading import weight_function
from envfit.sampling import STRATEGIES
from envfit.theory import POINTSETS as SQUARE_POINTSETS

__all__ = ["AdviseOptions", "ALL_POINTSETS", "DEFAULT_POINTSETS", "WEIGHTINGS", "BASES", "BRDFS",
           "DEFAULT_FIT_N", "DEFAULT_NMIN", "DEFAULT_NMAX", "DEFAULT_OSW_NMAX", "DEFAULT_SEEDS",
           "DEFAULT_AXES", "DEFAULT_SHININESS", "DEFAULT_SCALE", "DEFAULT_TARGET_RELATIVE",
           "PREDICTOR_CHOICES", "RENDERER_AXES_START", "RENDERER_MAX_AXES", "MAX_AXES",
           "MAX_SPECTRUM_AXES", "MAX_SEEDS"]

# ALL_POINTSETS (every point set of envfit.theory._pointsets), DEFAULT_POINTSETS (BNOT only
# when asked for: ≈15 s per realisation at N = 4096), WEIGHTINGS, BRDFS and DEFAULT_SHININESS
# are envfit.defaults', re-exported
BASES = ("sh", "hsh")
DEFAULT_FIT_N = 3000
DEFAULT_NMIN = 4
DEFAULT_NMAX = 65536
#: OSW needs an N×N float64 Cholesky per evaluated N (134 MB, ≈1–3 s at 4096)
DEFAULT_OSW_NMAX = 4096
#: realisations averaged per N for the stochastic point sets
DEFAULT_SEEDS = 4
#: random axes of the check
DEFAULT_AXES = 1000
#: the value scale by default: raw radiance, what a renderer integrates
DEFAULT_SCALE = "linear"
#: the target when none is given: 1 % of the map's mean shading value
DEFAULT_TARGET_RELATIVE = 0.01
# PREDICTOR_CHOICES (which prediction sizes N/L: "auto" or one forced) and the renderer
# check's adaptive measurement (RENDERER_AXES_START, RENDERER_MAX_AXES) are envfit.defaults'
#: the most axes of a check (``axes``, ``check_hsh_axes``, ``renderer_max_axes``): the RMSE
#: over M axes has a Monte-Carlo error ≈ 1/√(2M), 0.2 % here; more buys no information and
#: costs M shading integrals and rule evaluations (1e9 axes was killed for memory)
MAX_AXES = 100_000
#: the most axes of the renderer's warped spectra (≈ 1 s each per strategy on 2 cores: the
#: default 32 costs ≈ 32 s; 1e8 held 11 GB and ran on)
MAX_SPECTRUM_AXES = 1024
#: the most realisations per N of a stochastic point set (each one multiplies the search's
#: cost; the mean's scatter is 1/16 of one realisation's at 256)
MAX_SEEDS = 256


def _check_at_most(value: int, top: int, what: str, why: str) -> int:
    """``value`` if ≤ ``top``, else a one-line ParameterError saying why the bound."""
    if value > top:
        raise ParameterError(f"{what} must be <= {top} ({why}), got {value}")
    return value


def _check_axes(value, what: str) -> int:
    """An axis count in [2, :data:`MAX_AXES`].

    >>> _check_axes(10 ** 9, "axes (--axes)")
    Traceback (most recent call last):
    ...
    envfit.base._errors.ParameterError: axes (--axes) must be <= 100000 (the RMSE over M axes is known to ≈ 1/√(2M): 0.2 % at 100000), got 1000000000
    """
    return _check_at_most(check_int(value, what, 2), MAX_AXES, what,
                          f"the RMSE over M axes is known to ≈ 1/√(2M): 0.2 % at {MAX_AXES}")


@dataclass(frozen=True)
class AdviseOptions:
    """The advisor's parameters, checked and normalised on construction.

    Parameters
    ----------
    brdf : str
        Target: "diffuse" or "glossy" (case-insensitive; stored lower-case).
    target_rmse : float or None
        Target: the RMS shading error, on the ``scale`` values.
    target_relative : float or None
        Target: a fraction (0 < t < 1) of the map's mean shading value. At most one of
        ``target_rmse`` and ``target_relative``; neither: ``target_relative`` =
        :data:`DEFAULT_TARGET_RELATIVE` (0.01, 1 % of the mean shading value).
    shininess : float or None
        Target: the glossy lobe exponent n; stored as None for the diffuse lobe.
    scale : str
        Target: the value scale of the integrand and the fit, "linear" (default, raw
        radiance: what a renderer integrates), "display" or "log".
    predictor : str
        Which prediction sizes N (and the SH degree): "auto" (default; the spectral
        prediction (c) on the linear scale and wherever (b′) and (c) disagree by more than
        :data:`envfit.advisor._choice.DISAGREEMENT` at the chosen N, else (b′); see
        :mod:`envfit.advisor._choice`), "bandlimited" (always (b′)) or "spectral" (always (c)).
    pointsets, weights, bases : sequence of str
        Rules: point sets (:data:`ALL_POINTSETS`), weightings ("equal", "osw") and truncation
        bases ("sh", "hsh"; empty: none), stored as de-duplicated lower-case tuples.
    s : "auto" or float
        Fit: "auto" (s' and σ' by the band-limited likelihood) or a value in (1, 2).
    fit_n : int
        Fit: samples of the fit (≥ 10).
    seed : int
        Fit, search and check: seed of the fit, of the stochastic realisations and of the
        check's axes (≥ 0).
    nmin, nmax, osw_nmax : int
        Search: the N range (``nmin`` ≥ 1, ``nmax`` ≥ ``nmin``); OSW up to
        ``min(nmax, osw_nmax)``.
    seeds : int
        Search: realisations averaged per N for random, jitter and BNOT (1 … :data:`MAX_SEEDS`).
    check : bool
        Check: measure the RMSE at the chosen N/L.
    axes : int
        Check: random axes of the measurement (2 … :data:`MAX_AXES`).
    check_hsh_height, check_hsh_axes : int
        Check: rows of the map (≥ 4; at most the map's) and axes (2 … :data:`MAX_AXES`;
        at most ``axes``) of the (dear) HSH measurement.
    cache : bool
        Cache: read and write the on-disk cache (:mod:`envfit.advisor._cache`).
    cache_dir : path or None
        Cache: its folder (default ``$ENVFIT_CACHE_DIR`` or ``~/.cache/envfit``).
    renderer : bool
        Renderer rows: size the renderer rules (:mod:`envfit.advisor._rule_rows`); off by
        default in the API (their spectra cost ~10 s on 2 cores whatever the map's size),
        on in ``envfit advise`` unless ``--no-renderer``.
    strategies, renderer_pointsets : sequence of str
        Renderer rows: strategies (brdf, map, mis, split) and point sets (of
        :func:`envfit.theory._pointsets.square_points`; default sobol, sf, random).
    renderer_grid, renderer_spectrum_axes : int
        Renderer rows: the warped spectra's grid (a multiple of 4, ≥ 8; its memory checked by
        the advisor's budget) and axes (1 … :data:`MAX_SPECTRUM_AXES`)
        (:data:`envfit.advisor._rule_rows.RENDERER_GRID`, ``RENDERER_SPECTRUM_AXES``).
    renderer_axes_start, renderer_max_axes : int
        Renderer check: the adaptive measurement's first and largest number of axes
        (2 ≤ start ≤ max ≤ :data:`MAX_AXES`; :func:`envfit.measure._rules.measure_rule`).
    renderer_curves : bool
        Renderer rows: predict every grid N (for the plot), not only those the search needs.
    workers : int
        Threads of the wce and the check's lookups.
    quiet : bool
        No progress bars.

    Raises
    ------
    envfit.base._errors.ParameterError
        A value out of range or a name not known, in one line.
    """

    brdf: str = "diffuse"
    target_rmse: float | None = None
    target_relative: float | None = None
    shininess: float | None = DEFAULT_SHININESS
    scale: str = DEFAULT_SCALE
    predictor: str = "auto"
    pointsets: Sequence[str] = DEFAULT_POINTSETS
    weights: Sequence[str] = WEIGHTINGS
    bases: Sequence[str] = BASES
    s: float | str = "auto"
    fit_n: int = DEFAULT_FIT_N
    seed: int = 0
    nmin: int = DEFAULT_NMIN
    nmax: int = DEFAULT_NMAX
    osw_nmax: int = DEFAULT_OSW_NMAX
    seeds: int = DEFAULT_SEEDS
    check: bool = False
    axes: int = DEFAULT_AXES
    check_hsh_height: int = 128
    check_hsh_axes: int = 200
    cache: bool = True
    cache_dir: object = None
    renderer: bool = False
    strategies: Sequence[str] = DEFAULT_STRATEGIES
    renderer_pointsets: Sequence[str] = DEFAULT_RENDERER_POINTSETS
    renderer_grid: int = RENDERER_GRID
    renderer_spectrum_axes: int = RENDERER_SPECTRUM_AXES
    renderer_axes_start: int = RENDERER_AXES_START
    renderer_max_axes: int = RENDERER_MAX_AXES
    renderer_curves: bool = False
    workers: int = 2
    quiet: bool = True

    def __post_init__(self) -> None:
        for name, value in self._checked_target().items():
            object.__setattr__(self, name, value)
        for name, value in self._checked_rules().items():
            object.__setattr__(self, name, tuple(value))
        for name, value in self._checked_numbers().items():
            object.__setattr__(self, name, value)

    def _checked_target(self) -> dict:
        """BRDF, shininess, the one target (default: relative 0.01), the scale and the
        predictor, checked."""
        brdf = check_names([self.brdf], BRDFS, "BRDF")[0]
        shin = check_positive(self.shininess, "shininess") if brdf == "glossy" else None
        if self.target_rmse is not None and self.target_relative is not None:
            raise ParameterError("give at most one of target_rmse (--target-rmse) and "
                                 "target_relative (--target-relative)")
        rmse, rel = None, None
        if self.target_rmse is None:
            rel = check_positive(DEFAULT_TARGET_RELATIVE if self.target_relative is None
                                 else self.target_relative,
                                 "the relative target (--target-relative)")
            if rel >= 1.0:
                raise ParameterError(f"the relative target (--target-relative) is a fraction of "
                                     f"the mean shading value and must be < 1, got "
                                     f"{self.target_relative!r}")
        else:
            rmse = check_positive(self.target_rmse, "the target RMSE (--target-rmse)")
        if self.scale not in SCALES:
            raise ParameterError(f"scale must be one of {', '.join(SCALES)}, got {self.scale!r}")
        predictor = check_names([self.predictor], PREDICTOR_CHOICES, "predictor")[0]
        return {"brdf": brdf, "shininess": shin, "target_rmse": rmse, "target_relative": rel,
                "predictor": predictor}

    def _checked_rules(self) -> dict:
        """Point sets, weightings and bases, checked: something to advise on."""
        pointsets = check_names(self.pointsets, ALL_POINTSETS, "point set")
        weights = check_names(self.weights, WEIGHTINGS, "weighting")
        bases = check_names(self.bases, BASES, "basis")
        strategies = check_names(self.strategies, tuple(STRATEGIES), "strategy")
        rps = check_names(self.renderer_pointsets, tuple(sorted(SQUARE_POINTSETS)),
                          "renderer point set")
        if self.renderer and (not strategies or not rps):
            raise ParameterError("give at least one strategy and one renderer point set "
                                 "(or no renderer rows)")
        if not pointsets and not bases:
            raise ParameterError("nothing to advise on: no point set and no SH/HSH basis")
        if pointsets and not weights:
            raise ParameterError("give at least one weighting (equal, osw)")
        return {"pointsets": pointsets, "weights": weights, "bases": bases,
                "strategies": strategies, "renderer_pointsets": rps}

    def _checked_numbers(self) -> dict:
        """s, the fit's and the search's integers and the check's sizes, checked."""
        out = {"s": parse_s(self.s), "fit_n": check_int(self.fit_n, "fit_n", 10),
               "seed": check_int(self.seed, "seed", 0), "nmin": check_int(self.nmin, "nmin", 1)}
        out["nmax"] = check_int(self.nmax, "nmax", out["nmin"])
        return {**out, "osw_nmax": check_int(self.osw_nmax, "osw_nmax", 1),
                "seeds": _check_at_most(check_int(self.seeds, "seeds", 1), MAX_SEEDS,
                                        "seeds (--realisations)", "realisations per N"),
                "axes": _check_axes(self.axes, "axes (--axes)"),
                "check_hsh_height": check_int(self.check_hsh_height, "check_hsh_height", 4),
                "check_hsh_axes": _check_axes(self.check_hsh_axes, "check_hsh_axes"),
                **self._checked_renderer_numbers()}

    def _checked_renderer_numbers(self) -> dict:
        """The renderer rows' grid, spectrum axes and check axes, checked."""
        grid = check_int(self.renderer_grid, "the renderer spectra's grid", 8)
        if grid % 4:
            raise ParameterError(f"the renderer spectra's grid must be a multiple of 4, got "
                                 f"{grid}")
        start = _check_axes(self.renderer_axes_start, "renderer_axes_start")
        sp_axes = check_int(self.renderer_spectrum_axes, "the renderer spectra's axes", 1)
        return {"renderer_grid": grid, "renderer_axes_start": start,
                "renderer_spectrum_axes": _check_at_most(
                    sp_axes, MAX_SPECTRUM_AXES, "the renderer spectra's axes "
                    "(--renderer-spectrum-axes)", "≈ 1 s each per strategy"),
                "renderer_max_axes": _check_axes(check_int(self.renderer_max_axes,
                                                           "renderer_max_axes", start),
                                                 "renderer_max_axes"),
                "renderer": bool(self.renderer), "renderer_curves": bool(self.renderer_curves)}

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The field names, in order (the keywords :func:`envfit.advisor._advise.advise` takes).

        >>> AdviseOptions.names()[:3]
        ('brdf', 'target_rmse', 'target_relative')
        """
        return tuple(f.name for f in fields(cls))

    def lobe(self):
        """The weight function of the target's BRDF (n = 30 for the diffuse one, unused).

        >>> AdviseOptions(brdf="glossy", shininess=10, target_rmse=0.1).lobe() is not None
        True
        """
        return weight_function(self.brdf, self.shininess if self.shininess is not None
                               else DEFAULT_SHININESS)

    @property
    def osw_upper(self) -> int:
        """Largest N searched with optimal weights, ``max(nmin, min(nmax, osw_nmax))``."""
        return max(self.nmin, min(self.nmax, self.osw_nmax))

    def settings(self, s_rounded: float) -> dict:
        """The search settings an :class:`~envfit.advisor._result.Advice` reports."""
        return {"pointsets": list(self.pointsets), "weights": list(self.weights),
                "bases": list(self.bases), "s": self.s, "fit_n": self.fit_n, "seed": self.seed,
                "nmin": self.nmin, "nmax": self.nmax, "osw_nmax": self.osw_nmax,
                "seeds": self.seeds, "s_rounded": s_rounded, "predictor": self.predictor,
                "renderer": self.renderer, "strategies": list(self.strategies),
                "renderer_pointsets": list(self.renderer_pointsets),
                "renderer_grid": self.renderer_grid,
                "renderer_spectrum_axes": self.renderer_spectrum_axes,
                "renderer_axes_start": self.renderer_axes_start,
                "renderer_max_axes": self.renderer_max_axes}
