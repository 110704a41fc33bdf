"""theory — worst-case errors of quadrature rules and SH/HSH truncation for shading integrals.

Pure numerical code (numpy/scipy/ducc0), no I/O, never imports ``envfit``. Each module
holds one concept of Marques, Bouville & Bouatouch, "Spectral Analysis of Quadrature Rules
and Fourier Truncation-based Methods Applied to Shading Integrals" (IEEE TVCG 2019).
"""
from .errors import TheoryParameterError, check_smoothness
from .sobolev import (generalized_distance_kernel, kernel_constant, kernel_from_distance2,
                      kernel_series, sobolev_coefficients)

__all__ = ["TheoryParameterError", "check_smoothness", "generalized_distance_kernel",
           "kernel_constant", "kernel_from_distance2", "kernel_series", "sobolev_coefficients"]
