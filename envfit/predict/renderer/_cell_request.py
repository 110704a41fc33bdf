r"""A predicted cell as the renderer runs it: the spp its sampler runs, the randomisation of
:mod:`envfit.predict.renderer.randomisation` and its options, whether the two streams share
one point set, and the grid level of the renderer model (:mod:`._diffuse_model`).

Grid level per randomisation and N (:func:`grid_level`, measured on city.exr's integrands at
three normals): V alone for ``independent``; the strata as cells for ``jittered`` (M = r:
exact) and ``cmj`` (M = N: exact, finer grids give the same MSE to 4 digits); M = 8N (at least
4) for the Cranley–Patterson shift (its box is checked to N ≤ M/8, ``randomisation._cp_shift``);
M = 2N for the other digital nets — the digital shift's estimate of the power above the grid
needs N ≤ M/2 (``randomisation._digital_shift``): at M = N the 1/N fallback erred by up to 2×
per normal, at M = 2N the MSE agrees with M = 4N and 8N within 1–5 %; all capped at
``max_level``, never below log2 N for the Cranley–Patterson shift and CMJ (M ≥ N). Where the
grid of a digital shift or of Owen's scrambling is coarser than 2N, the power above it is
sampled, unbiased at any N (``randomisation._shift_samples``, ``._owen_samples``: ``shifts``
uniform shifts, resp. nested uniform scrambles, of the net, the integrand at those points, the
grid's cell means as a control variate). The cell means come from the integrand at the
midpoints of level ``max level + 1`` (2 × 2 per cell of the finest grid).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from envfit.base import ParameterError
from envfit.predict.renderer._sampled_nets import SAMPLE_TAG

__all__ = ["CellRequest", "cell_request", "grid_level", "samples_above"]

#: pairing → whether the two streams share one point set; the columns of a randomised
#: orthogonal array have independent permutations per dimension: their cross term is 0
#: (``randomisation._orthogonal``)
_SHARED = {"independent": False, "same_net_permuted": True, "joint_array": False}
#: the randomisations' options where the sampler names none: square strata, uniform
#: permutations
_PLAIN = {"jittered": (("layout", "square"),), "cmj": (("permutations", "uniform"),)}


def _widest_strata(n: int) -> int:
    """The strata a side of N's most nearly square factorisation x × y (y the largest divisor
    of N at most √N, x = N/y): with envfit's rows, the widest layout of jittered strata the
    grid resolves."""
    d = math.isqrt(n)
    while n % d:
        d -= 1
    return n // d


def grid_level(randomisation: str, n: int, max_level: int) -> int:
    """The grid level for ``randomisation`` of N points (module docstring), ≤ max_level."""
    if randomisation == "independent":
        want = 2
    elif randomisation == "jittered":
        r = max(_widest_strata(n), -(-n // max(1, round(math.sqrt(n)))))  # most strata a side
        square = r * r == n and r & (r - 1) == 0           # r x r, r = 2^k: on the grid
        want = (r - 1).bit_length() + (0 if square else 3)
    elif randomisation in ("cmj", "orthogonal"):
        want = (n - 1).bit_length() + (0 if n & (n - 1) == 0 else 1)
    elif randomisation == "cp_shift":
        want = (n - 1).bit_length() + 3                 # N <= M/8 (randomisation._cp_shift)
    else:
        want = (n - 1).bit_length() + 1
    # M >= N (the CP shift's box: M >= 4) unless the power above the grid is sampled (or the
    # point sets drawn above the grid's reach: randomisation._strata_samples)
    sampled = randomisation in ("independent", "jittered", "cmj", "orthogonal",
                                "shared_sequence") + tuple(SAMPLE_TAG)
    floor = max(0 if sampled else (n - 1).bit_length(), 2 * (randomisation == "cp_shift"))
    return max(1, floor, min(int(max_level), want))


def samples_above(randomisation: str, n: int, level: int) -> bool:
    """Whether the power above the grid of ``level`` is sampled (module docstring): a
    digital shift or an Owen-scrambled net of N > M/2 points."""
    return randomisation in SAMPLE_TAG and 2 * n > (1 << level)



@dataclass(frozen=True)
class CellRequest:
    """One predicted cell as the renderer runs it: ``n`` the spp it runs, ``name`` the
    randomisation's registry name and its ``options`` (``options_b``: the BSDF stream's),
    ``shared`` one point set for both streams, ``level`` the grid level, ``prefix`` any N
    the first N of the randomised sequence (``SamplerSpec.prefix``)."""

    strategy: str
    sampler: str
    spp: int = field(compare=False)         # cells asked at spp rounding to one n are one
    n: int
    name: str
    options: tuple
    shared: bool
    level: int
    options_b: tuple = ()                   # the BSDF stream's options where they differ
    prefix: bool = False                    # any N: the first N of the randomised sequence


def cell_request(renderer, options, strategy: str, sampler: str,
                   spp: int) -> CellRequest:
    """The cell of ``renderer`` as the renderer runs it: spp rounded, randomisation and its
    options, the grid level of ``options`` (no map needed: the model's checks)."""
    s = renderer.strategy(strategy)
    if not s.renderable:
        raise ParameterError(f"{renderer.name} cannot render strategy {strategy!r}")
    spec = renderer.sampler(sampler)
    n = spec.spp(spp)
    from envfit.predict.renderer.randomisation import RANDOMISATIONS
    if spec.randomisation not in RANDOMISATIONS:
        raise ParameterError(f"no exact model of {renderer.name}'s {sampler} "
                             f"({spec.randomisation}) yet")
    name = spec.randomisation
    two = s.emitter_samples > 0 and s.bsdf_samples > 0
    if two and spec.pairing not in _SHARED:
        raise ParameterError(f"no model of the pairing {spec.pairing!r} of {sampler}")
    if max(s.emitter_samples, s.bsdf_samples) > 1:
        raise ParameterError("the model takes at most one sample per technique and spp")
    opts = opts_b = ()
    if name in _PLAIN:
        opts = opts_b = spec.model_options(n) or _PLAIN[name]
    elif name == "shared_sequence":                 # the same runs, each request's own
        opts, opts_b = (spec.model_options(n) + (("stream", t),) for t in ("light", "bsdf"))
    elif name == "orthogonal":
        if s.dimensions is None:
            raise ParameterError(f"{renderer.name} does not say at which dimensions "
                                 f"strategy {strategy!r} draws its samples")
        opts, opts_b = ((("dimension", d),) for d in s.dimensions)
    level = grid_level(name, n, options.max_level)
    return CellRequest(strategy, sampler, int(spp), n, name, opts,
                    two and _SHARED[spec.pairing], level, opts_b, spec.prefix)
