"""theory — worst-case errors of quadrature rules and SH/HSH truncation for shading integrals.

Pure numerical code (numpy/scipy/ducc0), no I/O, never imports ``envfit``. Each module
holds one concept of Marques, Bouville & Bouatouch, "Spectral Analysis of Quadrature Rules
and Fourier Truncation-based Methods Applied to Shading Integrals" (IEEE TVCG 2019):

- :mod:`theory.sobolev` — a_l^(s) (Eqs. 15–16), the generalized distance kernel (Eq. 14);
- :mod:`theory.brdf` — zonal weight functions, b_l, b̃_l, HSH→SH (Eqs. 20–33);
- :mod:`theory.sh` — Legendre/SH sums of point sets (Eqs. 44–45, 54);
- :mod:`theory.pointsets`, :mod:`theory.bnot`, :mod:`theory.sphere_points` — point sets;
- :mod:`theory.weights` — equal and optimal sample weights;
- :mod:`theory.quadrature` — worst-case error Eq. 41 and its spectrum Eq. 42;
- :mod:`theory.truncation` — SH/HSH truncation error Eqs. 51–52, N-versus-L equivalence.
"""
from .errors import TheoryParameterError, check_smoothness
from .sobolev import (generalized_distance_kernel, kernel_constant, kernel_from_distance2,
                      kernel_series, sobolev_coefficients)
from .brdf import Diffuse, Glossy, Phong, WeightFunction, ZonalWeight, hsh_to_sh_matrix
from .sh import (anisotropic_power_spectrum, legendre_p, legendre_series, point_set_power_spectrum,
                 point_set_sh_coefficients, zonal_sums)
from .pointsets import (DETERMINISTIC_POINTSETS, POINTSETS, frame_from_axis, generate,
                        hemisphere_points, lambert_to_hemisphere, larcher_pillichshammer,
                        morph_diffuse, morph_glossy, random_square, rotate_to_axes, sobol02,
                        spherical_fibonacci, square_points, stratified_jitter)
from .bnot import (bnot_diagnostics, bnot_square, capacity_weights, min_toroidal_distance,
                   power_diagram, radial_power_spectrum)
from .sphere_points import random_sphere, sphere_points, spherical_fibonacci_sphere
from .quadrature import (ErrorSpectrum, error_spectrum, initial_error, kernel_mean_embedding,
                         worst_case_error, worst_case_error_squared)
from .weights import equal_weights, kernel_matrix, optimal_weights
from .truncation import (equivalent_qmc_points, smallest_degree, spatial_truncation_error,
                         truncation_error, truncation_error_curve)

__all__ = [name for name in dir() if not name.startswith("_")]

from . import figures, table1  # noqa: E402  (the paper's Table 1 and the data of Figs. 1–5)
