r"""Cycles' adaptive sampling as its source runs it (blender/cycles @ v5.0.0; the same code in
Blender 5.0.1 and on its main branch of 2026-07) — everything the adaptive model
(:mod:`envfit.predict.renderer._adaptive`) needs of Cycles but its patterns' points
(:mod:`._patterns`).

**The settings** (``src/scene/integrator.cpp``: ``Integrator::get_adaptive_sampling``).
Blender's *Noise Threshold* τ (default 0.01; 0 = automatic: max(0.001, 1/samples)) and *Min
Samples* (default 0 = automatic: max(4, ⌈16/τ^0.3⌉) — "threshold 0.1 → 32, 0.01 → 64,
0.001 → 128"); the threshold the kernel compares is 5τ ("arbitrary factor"); the step is 16.

**When a pixel is tested** (``src/integrator/adaptive_sampling.cpp``: ``need_filter``,
``align_samples``): after the 0-based sample s with s > min_samples and s & 15 = 15, i.e. at the
sample counts n = 16k > min_samples + 1; the render's work is cut so that every pixel stops
exactly there. A final render (``background``) compares the full threshold from the first
test on (``src/integrator/render_scheduler.cpp``: the progressive noise floor is for
viewport renders only).

**The test** (``src/kernel/film/adaptive_sampling.h``:
``film_adaptive_sampling_convergence_check``). The pixel holds the sum I of its samples and,
in the auxiliary pass, A = 2 × the sum of its *class A* samples (``src/kernel/film/
light_passes.h``: ``film_write_adaptive_buffer``; ``src/kernel/sample/pattern.h``:
``sample_is_class_A``: popcount(s & 0xaaaaaaaa) odd, which splits every 16 consecutive samples
8 : 8). With n its samples,

.. math::  e = \frac{\sum_c |I_c - A_c| / n}{10^{-4} + g(\sum_c I_c / n)},\qquad
           g(x) = \sqrt{x}\ (x < 1),\ x\ (x \ge 1),

and the pixel has converged when e < 5τ.

**Its neighbours** (``film_adaptive_sampling_filter_x``, ``_y``): after each test a pixel whose
3 × 3 neighbourhood holds an unconverged pixel is marked unconverged, so a pixel stops at the
first test where it and its eight neighbours pass (each of them sampled as long as it was).

**The points** of each pixel's film, light and BSDF requests under its pattern — Tabulated
Sobol (a random table and order per pixel and request) or blue noise (the pixel's run of one
fixed sequence, the run as long as Max Samples: ``blue_noise_sequence_length`` is the render's
samples) — are :mod:`envfit.renderers.cycles._patterns`'.

Example
-------
>>> from envfit.renderers.cycles._adaptive import CYCLES_ADAPTIVE
>>> s = CYCLES_ADAPTIVE.settings(0.01, samples=4096)
>>> s.min_samples, s.scaled_threshold, int(s.checks[0]), int(s.checks[-1])
(64, 0.05, 80, 4096)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from envfit.base import ParameterError
from envfit.renderers.cycles._patterns import class_a, pattern_points

__all__ = ["AdaptiveSettings", "CyclesAdaptive", "CYCLES_ADAPTIVE"]

_SRC = "blender/cycles @ v5.0.0 "


@dataclass(frozen=True)
class AdaptiveSettings:
    """Cycles' adaptive sampling for one render (module docstring).

    Attributes
    ----------
    threshold : τ as the user sets it (Blender's *Noise Threshold*; the automatic one
        resolved).
    samples : the most samples a pixel takes (Blender's *Max Samples*).
    min_samples : the automatic rule's or the user's (at least 4).
    scaled_threshold : 5τ, what the test compares.
    checks : the sample counts at which a pixel is tested (ascending; the last one is
        ``samples``, where every pixel stops).
    """

    threshold: float
    samples: int
    min_samples: int
    scaled_threshold: float
    checks: np.ndarray


class CyclesAdaptive:
    """Cycles' adaptive sampling (module docstring): its settings, its test and the points of
    the patterns it is modelled for."""

    name = "adaptive sampling"
    words = "Noise Threshold"
    source = _SRC + "src/kernel/film/adaptive_sampling.h, src/scene/integrator.cpp"
    step = 16
    scale = 5.0
    epsilon = 1e-4
    #: a pixel stops only with its (2r + 1)² neighbourhood
    neighbourhood = 1
    #: the sampling patterns whose points :meth:`points` draws
    samplers = ("tabulated_sobol", "blue_noise")
    default_threshold, default_samples = 0.01, 4096

    def settings(self, threshold: float, samples: int = 4096,
                 min_samples: int = 0) -> AdaptiveSettings:
        """The render's settings from Blender's ``adaptive_threshold``, ``samples`` and
        ``adaptive_min_samples`` (0: automatic)."""
        if not isinstance(samples, (int, np.integer)) or not 1 <= samples <= 1 << 24:
            raise ParameterError(f"samples must be an integer from 1 to {1 << 24}, got "
                                 f"{samples!r}")
        if not isinstance(min_samples, (int, np.integer)) or min_samples < 0:
            raise ParameterError(f"min samples must be an integer >= 0, got {min_samples!r}")
        t = float(threshold)
        if not math.isfinite(t) or t < 0:
            raise ParameterError(f"the noise threshold must be >= 0, got {threshold!r}")
        if t == 0.0:
            t = max(0.001, 1.0 / samples)
        if min_samples == 0:
            lo = max(4, math.ceil(np.float32(16.0) / np.float32(t) ** np.float32(0.3)))
        else:
            lo = max(4, int(min_samples))
        first = ((lo + 1) | (self.step - 1)) + 1           # align_samples' first filter
        checks = np.arange(first, samples + 1, self.step, dtype=np.int64)
        if len(checks) == 0 or checks[-1] != samples:
            checks = np.append(checks, samples)
        return AdaptiveSettings(t, int(samples), int(lo), self.scale * t, checks)

    @staticmethod
    def class_a(n: int) -> np.ndarray:
        """Which of the samples 0 … n − 1 are class A (:func:`class_a`)."""
        return class_a(n)

    def error(self, total: np.ndarray, half: np.ndarray, n) -> np.ndarray:
        """e of the test (module docstring) from the sums I (…, C) and A (…, C, twice the
        class-A sum) of n samples."""
        n = np.asarray(n, dtype=np.float64)
        diff = np.sum(np.abs(total - half), axis=-1) / n
        x = np.sum(total, axis=-1) / n
        norm = np.where(x < 1.0, np.sqrt(np.maximum(x, 0.0)), x)
        return diff / (self.epsilon + norm)

    def points(self, sampler: str, samples: int, realizations: int,
               rng: np.random.Generator, *, film: bool = False) -> tuple:
        """The light's and the BSDF's (x, y) of the samples 0 … samples − 1 of
        ``realizations`` pixels of a render of ``samples`` (Max Samples) under the pattern
        ``sampler``: two arrays (R, samples, 2), float64; with ``film``, the film position in
        the pixel too (:func:`._patterns.pattern_points`)."""
        if sampler not in self.samplers:
            raise ParameterError(f"Cycles' adaptive sampling is modelled for the "
                                 f"{', '.join(self.samplers)} patterns only, not {sampler!r}")
        return pattern_points(sampler, samples, realizations, rng, film=film)


#: the record's adaptive sampling (:attr:`envfit.renderers.Renderer.adaptive`)
CYCLES_ADAPTIVE = CyclesAdaptive()
