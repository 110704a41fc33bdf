r"""The smoothness s of a map: the fit criteria and search, σ̂, and the paper's Table 2.

Modules:

* :mod:`~envfit.fit._criterion` — The fit criterion at one s, for one map or for many maps
  sharing one factorisation.
* :mod:`~envfit.fit._kriging` — Closed-form expected interpolation error of a Gaussian-
  process map (the kriging error).
* :mod:`~envfit.fit._search` — The search for ŝ and its 95 % interval, implemented once: a
  coarse grid, a shared refinement lattice and a cubic spline.
* :mod:`~envfit.fit._sigma` — σ̂, the scale of the GP model :math:`f \sim GP(0, \sigma^2
  K_{gd}^{(s)})` of a map at a given s: the paper's kernel (:func:`profiled_sigma`) and the
  band-limited one (:func:`bandlimited_profiled_sigma`), channels combined
  (:func:`combine_sigma`), and the ``"auto" | value`` choice of s (:func:`parse_s`). Used by
  validation and by the advisor.
* :mod:`~envfit.fit._smoothness` — Estimate the Sobolev smoothness s of a map on the
  continuous range (1, 2), with an uncertainty, by one of three explicit criteria (beyond
  the paper's Table 2 grid search):
* :mod:`~envfit.fit._table2` — The paper's Table 2 experiment (Sec. 9.1): reconstruct a map
  from N samples with the Sobolev kernel K_gd^(s) for a grid of (s, N), and report the
  reconstruction RMSE.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "fit_smoothness": "_smoothness", "FitResult": "_smoothness",
    "fit_smoothness_samples": "_smoothness", "SampleFit": "_smoothness",
    "SynthesisModel": "_kriging", "KrigingCurve": "_kriging",
    "expected_interpolation_mse": "_kriging", "expected_profiled_likelihood": "_kriging",
    "format_table2": "_table2", "run_table2": "_table2", "sample_directions": "_table2",
    "Table2Result": "_table2",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "TABLE2_FIELDS": "_table2",
    "Table2Cell": "_table2",
    "check_grid": "_table2",
    "table2_cell_key": "_table2",
    "table2_recon_stem": "_table2",
    "DEFAULT_METHOD": "_smoothness",
    "DEFAULT_N": "_smoothness",
    "DEFAULT_REFINE": "_search",
    "KERNELS": "_smoothness",
    "METHODS": "_smoothness",
    "N_BOOTSTRAP": "_criterion",
    "PAPER_N": "_table2",
    "PAPER_S": "_table2",
    "QUICK_N": "_table2",
    "SCORE_NAMES": "_smoothness",
    "S_GRID": "_smoothness",
    "SmoothnessSearch": "_search",
    "bandlimited_profiled_sigma": "_sigma",
    "builtin_synthesis": "_kriging",
    "cell_checks": "_table2",
    "combine_sigma": "_sigma",
    "evaluate_criterion": "_criterion",
    "fit_notes": "_smoothness",
    "holdout_pixels": "_smoothness",
    "known_s_sentence": "_kriging",
    "lattice": "_search",
    "parse_s": "_sigma",
    "plan_fit_memory": "_smoothness",
    "profiled_sigma": "_sigma",
    "run_searches": "_search",
    "search_lattice": "_search",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})
