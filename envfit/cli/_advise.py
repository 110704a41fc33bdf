"""``envfit advise``: how many samples, or which SH/HSH degree, for this map, BRDF and target error.

This module parses the command line and picks the run by what is asked; each run builds its
checked options, calls :func:`envfit.advisor.advise_with` (or the library's driver) and prints:
:mod:`~envfit.cli._advise_rules` (envfit's own rules), :mod:`~envfit.cli._advise_renderer`
(``--renderer``: a renderer's own terms) and :mod:`~envfit.cli._advise_library` (several maps).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from envfit.defaults import (ADVISE_RENDERER_POINTSETS, ALL_POINTSETS, BRDFS,
                             DEFAULT_POINTSETS, DEFAULT_SHININESS, MICROFACET_BSDF_WORDS,
                             MICROFACET_BSDFS, PREDICTOR_CHOICES, WEIGHTINGS)
from envfit.cli._common import (add_common_arguments, add_executor_arguments, add_map_arguments,
                                library_mode)
from envfit.cli._advise_library import check_library, run_library
from envfit.cli._advise_renderer import (add_renderer_arguments, reject_without_renderer,
                                         renderer_options_from_args, run_renderer)
from envfit.cli._advise_rules import run_rules
from envfit.cli._output import CommandOutput
from envfit.cli._ranges import Ranged, distinct_names, state_common_ranges

SHININESS = Ranged(0, None, "n", integer=False, lo_open=True)
TARGET_RMSE = Ranged(0, None, "E", integer=False, lo_open=True)
TARGET_RELATIVE = Ranged(0, 1, "F", integer=False, lo_open=True, hi_open=True)
S_VALUE = Ranged(1, 2, "s", integer=False, lo_open=True, hi_open=True, literals=("auto",))
AT_LEAST_1 = Ranged(1, None, "N")


def register(sub) -> None:
    p = sub.add_parser(
        "advise",
        help="smallest N per point set / weighting and smallest SH/HSH degree for a target error",
        description="Predict the RMS shading error of each rule two ways and find the "
                    "smallest N (bisection) or L whose prediction is at most the target "
                    "(default: 1% of the map's mean shading value, on the linear scale). "
                    "(b'): fit the map's smoothness s' and scale sigma' under the model of an "
                    "H-row map (kernel band-limited at degree H-1, samples at pixel centres; "
                    "cached); sigma' times the rule's worst-case error summed to degree H-1 "
                    "with degree l weighted by the bilinear lookup's transfer tau_l (Eq. 42; "
                    "Eqs. 51-52 for SH/HSH truncation), plus the error on the map's mean when "
                    "the weights do not sum to 1. (c): the map's own power per degree (of its "
                    "bilinear interpolant, to degree 2H-1) times the rule's error power, the "
                    "exact mean over random rotations (SH truncation too; HSH: (b') only). "
                    "--predictor auto (default) sizes by (c) on the linear scale and wherever "
                    "(b') and (c) disagree by more than 1.25x (with a warning line), else by "
                    "(b'). Prints a table sorted by cost (N samples, or (L+1)^2 coefficients) "
                    "and a recommendation; --check measures the actual RMSE at the chosen N/L "
                    "on the map.")
    add_map_arguments(p, many=True)
    _add_target_arguments(p)
    _add_search_arguments(p)
    _add_check_and_cache_arguments(p)
    add_renderer_arguments(p)
    add_executor_arguments(p)
    add_common_arguments(p)
    state_common_ranges(p)
    p.set_defaults(func=run)


def _add_target_arguments(p) -> None:
    """The lobe, the target, the scale and the predictor."""
    from envfit.maps import SCALES
    micro = ", ".join(f"{b} ({MICROFACET_BSDF_WORDS[b]})" for b in MICROFACET_BSDFS)
    p.add_argument("--brdf", choices=BRDFS + MICROFACET_BSDFS, default="diffuse",
                   help=f"weight function: {', '.join(BRDFS)} (default: diffuse); with "
                        f"--renderer: diffuse or a microfacet BSDF with --roughness: {micro}")
    p.add_argument("--shininess", type=SHININESS, default=DEFAULT_SHININESS,
                   help=f"glossy exponent {SHININESS} (default: {DEFAULT_SHININESS:g})")
    tg = p.add_mutually_exclusive_group()
    tg.add_argument("--target-rmse", type=TARGET_RMSE, metavar="E",
                    help=f"target RMS shading error, on the --scale values; {TARGET_RMSE}")
    tg.add_argument("--target-relative", type=TARGET_RELATIVE, metavar="F",
                    help=f"target as a fraction of the map's mean shading value, "
                         f"{TARGET_RELATIVE} (default, when neither is given: 0.01)")
    p.add_argument("--scale", choices=SCALES, default="linear",
                   help="value scale of the integrand and the fit (default: linear, the raw "
                        "radiance a renderer integrates)")
    p.add_argument("--predictor", choices=PREDICTOR_CHOICES, default="auto",
                   help="prediction that sizes N/L: auto (default: (c) on the linear scale and "
                        "where (b') and (c) disagree by > 1.25x, else (b')), bandlimited (b'), "
                        "spectral (c)")


def _add_search_arguments(p) -> None:
    """The rules searched and the search's numbers."""
    from envfit.advisor import BASES, MAX_SEEDS
    sets = ", ".join(ALL_POINTSETS)
    p.add_argument("--pointsets", type=distinct_names, default=None, metavar="sf,sobol,…",
                   help=f"point sets among {sets} (default: {','.join(DEFAULT_POINTSETS)}; "
                        f"bnot costs ~15 s per realisation at N = 4096)")
    p.add_argument("--weights", type=distinct_names, default=None, metavar="equal,osw",
                   help=f"weightings among {', '.join(WEIGHTINGS)} (default: all)")
    p.add_argument("--bases", type=distinct_names, default=None, metavar="sh,hsh",
                   help=f"truncations to size among {', '.join(BASES)} (default: all; 'none' "
                        f"for none)")
    p.add_argument("--s", type=S_VALUE, default="auto", metavar="auto|VALUE",
                   help=f"smoothness: 'auto' (band-limited likelihood fit, default) or a value "
                        f"{S_VALUE} (sigma then by the band-limited likelihood at that s)")
    ranges = {"--fit-n": (Ranged(10, None, "N"), "samples of the fit (default: 3000)"),
              "--nmin": (AT_LEAST_1, "smallest N searched (default: 4)"),
              "--nmax": (AT_LEAST_1, "largest N searched, at least --nmin (default: 65536); "
                                      "with --renderer the largest spp, at most 2147483647 "
                                      "(a renderer's spp is a 32-bit int; default 65536, or "
                                      "2147483647 for an independent sampler, whose RMSE is "
                                      "exactly sigma/sqrt(spp))"),
              "--osw-nmax": (AT_LEAST_1, "largest N searched with optimal weights (an NxN "
                                          "solve; default: 4096)"),
              "--realisations": (Ranged(1, MAX_SEEDS, "K"), "realisations averaged per N for "
                                                             "random/jitter/bnot (default: 4)")}
    for flag, (rng, text) in ranges.items():
        p.add_argument(flag, type=rng, default=None, help=f"{text}; {rng}", metavar=rng.name)


def _add_check_and_cache_arguments(p) -> None:
    """--check and its axes, the renderer rows' options, the cache's options."""
    from envfit.advisor import MAX_AXES
    p.add_argument("--check", action="store_true",
                   help="measure the RMSE at the chosen N/L on the map, beside the prediction")
    axes = Ranged(2, MAX_AXES, "M")
    p.add_argument("--axes", type=axes, default=1000, metavar="M",
                   help=f"random axes of --check, {axes} (default: 1000, seeded by --seed)")
    _add_renderer_arguments(p)
    p.add_argument("--no-cache", action="store_true",
                   help="neither read nor write the cache of fits and wce curves")
    p.add_argument("--cache-dir", type=Path, default=None, metavar="DIR",
                   help="cache folder (default: $ENVFIT_CACHE_DIR or ~/.cache/envfit)")


def _add_renderer_arguments(p) -> None:
    """The renderer rows' options (strategies, point sets, spectra, check axes)."""
    from envfit.advisor import MAX_AXES, MAX_SPECTRUM_AXES
    from envfit.sampling import STRATEGIES
    from envfit.renderers import STRATEGY_NAMES
    rg = p.add_argument_group("renderer rows")
    rg.add_argument("--strategies", type=distinct_names, default=None, metavar="brdf,map,mis,split",
                    help=f"renderer strategies to size, among {', '.join(STRATEGIES)}: brdf "
                         f"(BRDF sampling), map (map importance sampling), mis (multi-sample "
                         f"MIS, N/2 each), split (bright sources integrated exactly + MIS on "
                         f"the rest) (default: all); with --renderer among "
                         f"{', '.join(STRATEGY_NAMES)} (default: every one it can render)")
    rg.add_argument("--renderer-pointsets", type=distinct_names, default=None,
                    metavar="sobol,sf,random",
                    help=f"point sets of the renderer rules among {', '.join(ALL_POINTSETS)} "
                         f"(default: {','.join(ADVISE_RENDERER_POINTSETS)})")
    rg.add_argument("--no-renderer", action="store_true",
                    help="no renderer rows: the quadrature and SH/HSH table only")
    numbers = {
        "--renderer-grid": (Ranged(8, None, "G", multiple=4), "G", "grid of the warped spectra (QMC "
                            "predictions exact to N ~ (G/8)^2; default: 512)"),
        "--renderer-spectrum-axes": (Ranged(1, MAX_SPECTRUM_AXES, "K"), "K", "axes of the warped "
                                     "spectra's sample over the sphere (default: 32)"),
        "--renderer-axes-start": (Ranged(2, MAX_AXES, "M"), "M", "--check of the renderer rows: "
                                  "axes of the first round of the adaptive measurement "
                                  "(default: 250)"),
        "--renderer-max-axes": (Ranged(2, MAX_AXES, "M"), "M", "--check of the renderer rows: at "
                                "most this many axes, at least --renderer-axes-start (the "
                                "measurement doubles them until its 95%% interval is within "
                                "+-10%%; default: 4000)")}
    for flag, (rng, meta, text) in numbers.items():
        rg.add_argument(flag, type=rng, default=None, metavar=meta, help=f"{text}; {rng}")


def _prepare_maps(args: argparse.Namespace) -> None:
    """``args.library``: several maps, a folder, a pattern or an executor option (a library,
    which needs ``--renderer``: else one line, :func:`envfit.cli._advise_library.check_library`);
    otherwise ``args.map`` becomes the one path (or None: the built-in map)."""
    args.library = library_mode(args)
    if args.library:
        check_library(args)
    else:
        args.map = args.map[0] if args.map else None


def run(args: argparse.Namespace, output: CommandOutput) -> int:
    """``envfit advise``: what is asked picks the run — a library of maps (in a renderer's
    terms), one map in a renderer's terms (``--renderer``), or envfit's own rules — each
    options → :func:`envfit.advisor.advise_with` (or the library's driver) → print."""
    _prepare_maps(args)
    if args.renderer is not None:
        t0 = time.perf_counter()
        ropts, rules = renderer_options_from_args(args)   # one line, before the map
        if args.library:
            return run_library(args, output, ropts)
        return run_renderer(args, output, ropts, rules, t0)
    reject_without_renderer(args)
    return run_rules(args, output)
