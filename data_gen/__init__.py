"""data_gen — synthetic environment maps with known smoothness or known shading integrals.

Pure arrays in a map's *local* frame (z = up; see envfit/maps/_latlong.py for the convention);
``data_gen`` uses ``theory`` (Sobolev coefficients) and never imports ``envfit``.
"""
from envfit.data_gen import _sht as sht
from envfit.data_gen._analytic import (AnalyticMap, ConstantMap, SkyGradientMap, StepMap,
                                       SunSkyMap, diffuse_cap_integral, glossy_cap_integral,
                                       glossy_mean_cosine, glossy_normalisation)
from envfit.data_gen._errors import SyntheticMapError
from envfit.data_gen._gp import (EXACT_MAX_POINTS, expected_power_spectrum, expected_variance,
                                 gaussian_process_map, gaussian_process_values)

__all__ = ["sht", "SyntheticMapError", "EXACT_MAX_POINTS", "expected_power_spectrum",
           "expected_variance", "gaussian_process_map", "gaussian_process_values",
           "AnalyticMap", "ConstantMap", "SkyGradientMap", "StepMap", "SunSkyMap",
           "diffuse_cap_integral", "glossy_cap_integral", "glossy_mean_cosine",
           "glossy_normalisation"]
