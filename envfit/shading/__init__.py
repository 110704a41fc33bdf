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

from envfit.base._lazy import lazy_exports

_LAZY = {
    "hsh_truncation_estimates": "_estimators", "quadrature_estimates": "_estimators",
    "sh_truncation_estimates": "_estimators", "twisted_frames": "_estimators",
    "sh_truncation_curve": "_estimators", "hsh_truncation_curve": "_estimators",
    "rmse_over_axes": "_estimators", "RMSE": "_estimators",
    "shading_integral": "_ground_truth", "weight_function": "_ground_truth",
    "funk_hecke_factors": "_ground_truth", "default_sh_lmax": "_ground_truth",
}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
