"""data_gen — synthetic environment maps with known smoothness or known shading integrals.

Pure arrays in a map's *local* frame (z = up; see envfit/maps/_latlong.py for the convention);
``data_gen`` uses ``theory`` (Sobolev coefficients) and never imports ``envfit``.

The kinds ``envfit synth`` writes are a registry, :data:`SYNTH_KINDS` (name → parameters,
offset policy, factory), with one dispatcher, :func:`synthesize` (:mod:`._synth`).
"""
from envfit.data_gen import _sht as sht
from envfit.data_gen._analytic import (AnalyticMap, ConstantMap, SkyGradientMap, StepMap,
                                       SunSkyMap, diffuse_cap_integral, glossy_cap_integral,
                                       glossy_mean_cosine, glossy_normalisation)
from envfit.data_gen._errors import SyntheticMapError
from envfit.data_gen._gp import (EXACT_MAX_POINTS, expected_power_spectrum, expected_variance,
                                 gaussian_process_map, gaussian_process_values)
from envfit.data_gen._marker import MARKERS, marker_for_colour, marker_map
from envfit.data_gen._sun_gp import SunGPOptions, SunRecord, sun_gp_map
from envfit.data_gen._synth import (SYNTH_KINDS, OffsetPolicy, SynthesizedMap, SynthKind,
                                    synth_kind_names, synthesize)

__all__ = ["sht", "SyntheticMapError", "EXACT_MAX_POINTS", "expected_power_spectrum",
           "expected_variance", "gaussian_process_map", "gaussian_process_values",
           "AnalyticMap", "ConstantMap", "SkyGradientMap", "StepMap", "SunSkyMap",
           "diffuse_cap_integral", "glossy_cap_integral", "glossy_mean_cosine",
           "glossy_normalisation", "MARKERS", "marker_map", "marker_for_colour",
           "SunGPOptions", "SunRecord", "sun_gp_map",
           "SYNTH_KINDS", "OffsetPolicy", "SynthKind", "SynthesizedMap", "synth_kind_names",
           "synthesize"]
