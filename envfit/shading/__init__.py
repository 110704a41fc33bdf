r"""Shading integrals on a map: the ground truth (exact integrals at any frame), the paper's
estimators (quadrature, SH/HSH truncation) and the spectra (per-degree map and rule power,
lookup transfer).

Modules:

* :mod:`~envfit.shading._bilinear_sh` — Exact SH coefficients of a map's bilinear interpolant
  and the zonal convolution at axes.
* :mod:`~envfit.shading._estimators` — Estimators of the normalised shading integral (Eq. 17)
  on a lat-long map, and their RMSE.
* :mod:`~envfit.shading._ground_truth` — Ground truth of the normalised shading integral (Eq.
  17) on a lat-long map, two ways.
* :mod:`~envfit.shading._hemisphere` — Direct quadrature of hemisphere integrals of a map's
  bilinear interpolant (the reference).
* :mod:`~envfit.shading._patches` — Bilinear patches of a lat-long map: the geometry both
  ground-truth methods share.
* :mod:`~envfit.shading._quadrature` — Quadrature estimates of shading integrals (Eq. 34) for
  many axes and weightings at once.
* :mod:`~envfit.shading._spectra` — Spectra behind predictions (b') and (c) of ``envfit
  validate``: per-degree error power of a rule, a map's realised power per degree, and the
  bilinear lookup's transfer.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "hsh_truncation_estimates": "_estimators", "quadrature_estimates": "_estimators",
    "sh_truncation_estimates": "_estimators", "twisted_frames": "_estimators",
    "sh_truncation_curve": "_estimators", "hsh_truncation_curve": "_estimators",
    "rmse_over_axes": "_estimators", "RMSE": "_estimators",
    "shading_integral": "_ground_truth", "weight_function": "_ground_truth",
    "funk_hecke_factors": "_ground_truth", "default_sh_lmax": "_ground_truth",
}

__all__ = sorted(_LAZY)

#: names other envfit packages import from this one's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "power_by_degree": "_spectra",
    "LOOKUP_BLOCK": "_estimators",
    "alm_l_index": "_bilinear_sh",
    "axes_to_local": "_patches",
    "band_e2": "_spectra",
    "bandlimited_worst_case_error": "_spectra",
    "bandlimited_worst_case_errors": "_spectra",
    "bilinear_sh_coefficients": "_bilinear_sh",
    "degree_weights": "_spectra",
    "lookup_transfer": "_spectra",
    "low_degree_power_ratio": "_spectra",
    "map_degree_power": "_spectra",
    "model_scatter": "_spectra",
    "pixel_degree_power": "_spectra",
    "quadrature_estimates_multi": "_quadrature",
    "random_axes": "_quadrature",
    "rule_error_power": "_spectra",
    "rule_power_cost": "_spectra",
    "sh_analysis_cost": "_spectra",
    "sh_truncation_curve_transfer": "_spectra",
    "spectral_rmse": "_spectra",
    "synthesize_convolution": "_bilinear_sh",
}

__getattr__, __dir__ = lazy_exports(__name__, {**_LAZY, **_SHARED})
