"""theory — worst-case errors of quadrature rules and SH/HSH truncation for shading integrals.

Pure numerical code (numpy/scipy/ducc0), no I/O, never imports ``envfit``. Each module
holds one concept of Marques, Bouville & Bouatouch, "Spectral Analysis of Quadrature Rules
and Fourier Truncation-based Methods Applied to Shading Integrals" (IEEE TVCG 2019):

- :mod:`envfit.theory._sobolev` — a_l^(s) (Eqs. 15–16), the generalized distance kernel (Eq. 14);
- :mod:`envfit.theory._weight_function` — the generic zonal weight function: b_l, b̃_l by
  quadrature, its inverse CDF, HSH→SH (Eqs. 18–20, 31–33);
- :mod:`envfit.theory._brdf` — the diffuse, glossy and Phong lobes in closed form (Eqs. 20–30);
- :mod:`envfit.theory._sh` — Legendre/SH sums of point sets (Eqs. 44–45, 54);
- :mod:`envfit.theory._pointsets`, :mod:`envfit.theory._bnot` (on :mod:`envfit.theory._power_cells`),
  :mod:`envfit.theory._sphere_points` — point sets;
- :mod:`envfit.theory._weights` — equal and optimal sample weights;
- :mod:`envfit.theory._cholesky` — the dense Cholesky every factorisation uses (blocked, safe from
  OpenBLAS's threaded-``dsyrk`` crash on AVX-512 at N >= 16 000);
- :mod:`envfit.theory._quadrature` — worst-case error Eq. 41 and its spectrum Eq. 42;
- :mod:`envfit.theory._truncation` — SH/HSH truncation error Eqs. 51–52, N-versus-L equivalence;
- :mod:`envfit.theory._table1` — the paper's Table 1; :mod:`envfit.theory._figures` — the data of
  Figs. 1–5 and a BNOT check; :mod:`envfit.theory._claims` — the paper's claims about them,
  checked; :mod:`envfit.theory._wce_curves` — E(N) curve tools (slopes, log grids, inversion).
"""
import importlib

#: public name -> submodule (the private module ``_<submodule>``); loaded on first use (PEP 562), so ``import envfit.theory._errors`` or a
#: command line that needs one module does not pay for scipy.stats, the BNOT solver, …
_EXPORTS = {
    "errors": ("TheoryParameterError", "check_smoothness"),
    "sobolev": ("generalized_distance_kernel", "kernel_constant", "kernel_from_distance2",
                "kernel_series", "sobolev_coefficients"),
    "brdf": ("Diffuse", "Glossy", "Phong"),
    "weight_function": ("WeightFunction", "ZonalWeight", "hsh_to_sh_matrix"),
    "sh": ("anisotropic_power_spectrum", "legendre_p", "legendre_series", "point_set_power_spectrum",
           "point_set_sh_coefficients", "zonal_sums"),
    "pointsets": ("DETERMINISTIC_POINTSETS", "POINTSETS", "frame_from_axis", "generate",
                  "hemisphere_points", "lambert_to_hemisphere", "larcher_pillichshammer",
                  "morph_diffuse", "morph_glossy", "random_square", "rotate_to_axes", "sobol02",
                  "spherical_fibonacci", "square_points", "stratified_jitter"),
    "bnot": ("bnot_diagnostics", "bnot_square", "capacity_weights", "min_toroidal_distance",
             "radial_power_spectrum"),
    "power_cells": ("PowerDiagram", "power_diagram"),
    "sphere_points": ("random_sphere", "sphere_points", "spherical_fibonacci_sphere"),
    "quadrature": ("ErrorSpectrum", "error_spectrum", "initial_error", "kernel_mean_embedding",
                   "worst_case_error", "worst_case_error_squared"),
    "weights": ("equal_weights", "kernel_matrix", "optimal_weights"),
    "truncation": ("equivalent_qmc_points", "smallest_degree", "spatial_truncation_error",
                   "truncation_error", "truncation_error_curve"),
}
_LAZY = {name: mod for mod, names in _EXPORTS.items() for name in names}
#: submodules reached as attributes (Table 1, the data of Figs. 1–5, their claims, E(N) curves);
#: none may share a name with a lazy export above, or importing it would shadow that function
_SUBMODULES = ("claims", "figures", "table1", "wce_curves")

#: names other envfit packages import from theory's modules: importable from the
#: package (lazily) but not its public API (not in ``__all__``, not documented)
_SHARED = {
    "BRDFS": "brdf",
    "GLOSSY_MAX_SHININESS": "brdf",
    "PAPER_S": "table1",
    "PAPER_SHININESS": "brdf",
    "WEIGHTINGS": "weights",
    "cho_factor": "cholesky",
    "cho_solve": "cholesky",
    "cholesky": "cholesky",
    "cholesky_inplace": "cholesky",
    "gauss_legendre_01": "brdf",
    "inverse_diagonal": "cholesky",
    "make_weight": "figures",
    "paper_table1_values": "table1",
    "quadrature_rule": "figures",
    "split_lmax": "figures",
    "table1_report": "table1",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str):
    if name in _LAZY or name in _SHARED:
        mod = _LAZY.get(name) or _SHARED[name]
        value = getattr(importlib.import_module(f"._{mod}", __name__), name)
        globals()[name] = value
        return value
    if name in _SUBMODULES:
        return importlib.import_module(f"._{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY) | set(_SUBMODULES))
