"""``envfit fit``: estimate the Sobolev smoothness s of a map (or of a library of maps),
with an interval and σ̂."""
from __future__ import annotations

import argparse

from envfit.cli._common import (add_common_arguments, add_executor_arguments, add_map_arguments,
                                executor_kwargs, library_maps, library_mode, load_map_from_args,
                                load_options_from_args, out_dir)
from envfit.cli._output import CommandOutput
from envfit.cli._ranges import PIXELS, Ranged, check_library_pixels, check_pixels

#: the range of --n (``--help`` and the errors say these words)
N_RANGE = Ranged(10, None, "N", hi_text=PIXELS)


def register(sub) -> None:
    from envfit.fit import DEFAULT_METHOD, DEFAULT_N, KERNELS, METHODS
    p = sub.add_parser(
        "fit", help="estimate the Sobolev smoothness s of a map (with a 95%% interval and sigma)",
        description="Estimate s on the continuous range (1, 2) by the Gaussian-process "
                    "likelihood, closed-form leave-one-out, or held-out reconstruction error. "
                    "Several maps (files, folders, glob patterns): every s is factorised once "
                    "for all maps; a summary across maps goes to --out.")
    add_map_arguments(p, many=True)
    p.add_argument("--method", choices=METHODS, default=DEFAULT_METHOD,
                   help=f"criterion (default: {DEFAULT_METHOD}; see docs/guides/fit.md for why)")
    p.add_argument("--n", type=N_RANGE, default=DEFAULT_N, metavar="N",
                   help=f"number of samples, {N_RANGE}; and within the memory budget "
                        f"(default: {DEFAULT_N})")
    p.add_argument("--pointset", choices=("sf", "random"), default="sf")
    p.add_argument("--scale", choices=("display", "linear", "log"), default="display",
                   help="value scale the map is fitted on (default: display)")
    p.add_argument("--kernel", choices=KERNELS, default="full",
                   help="full: K_gd with bilinear samples (the paper's); bandlimited: K_gd "
                        "truncated at the map's Nyquist degree H-1 with samples at pixel "
                        "centres, the exact model of a band-limited map (likelihood only, "
                        "one map; default: full)")
    add_executor_arguments(p)
    add_common_arguments(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace, output: CommandOutput) -> int:
    if library_mode(args):
        if args.kernel != "full":
            from envfit.base import ParameterError
            raise ParameterError("--kernel bandlimited fits one map at a time (each map has its "
                                 "own band limit and pixel centres); give a single map")
        return _run_library(args, output)
    return _run_single(args, output)


def _run_single(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.fit import fit_smoothness
    env = load_map_from_args(args)
    check_pixels(N_RANGE, "--n", args.n, env)           # before the memory guard's N
    for note in getattr(env, "notes", []):
        output.say(f"note: {note}")
    res = fit_smoothness(env, method=args.method, n=args.n, scale=args.scale,
                         pointset=args.pointset, seed=args.seed, kernel=args.kernel,
                         quiet=args.quiet)
    sig = ", ".join(f"{x:.4g}" for x in res.sigma)
    output.say(f"map {env.name}: {env.width}x{env.height}",
               f"s = {res.s:.3f}  (95% interval {res.s_interval[0]:.3f} … {res.s_interval[1]:.3f}; "
               f"method {res.method}, N = {res.n}, {res.scale_description}"
               + (f", kernel band-limited at L = {res.band_lmax}" if res.kernel == "bandlimited" else "")
               + ")",
               f"sigma = {sig}  (per channel, on the {res.scale} scale)",
               *[f"note: {n}" for n in res.notes],
               f"({res.seconds:.1f} s)")
    out = out_dir(args)
    d = res.to_dict()
    d["map"] = env.name
    if out is not None:
        from envfit.plots import plot_fit_curve
        target = out / f"fit_{res.method}.png"
        png = output.guarded_write(target, plot_fit_curve, res, target)
        if png is not None:
            d["files"] = {"curve": str(png)}
            output.say(f"wrote {png}")
    output.emit_json(d)
    return 0



def _tail(label: str, width: int = 28) -> str:
    """``label`` within ``width`` characters, its end kept (where maps differ)."""
    return label if len(label) <= width else "…" + label[-(width - 1):]


def format_library_fit(lib) -> str:
    """One line per map: s, its 95 % interval, σ̂ per channel."""
    lines = [f"s per map ({lib.method}, N = {lib.n}, {lib.scale} scale), {len(lib.fits)} maps",
             f"  {'map':<28} {'s':>6}  {'95% interval':<15}  sigma"]
    for label, f in zip(lib.labels, lib.fits):
        lines.append(f"  {_tail(label):<28} {f.s:6.3f}  {f.s_interval[0]:.3f} … {f.s_interval[1]:.3f}  "
                     + ", ".join(f"{x:.4g}" for x in f.sigma))
    return "\n".join(lines)


def _run_library(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.batch import LibraryOptions, fit_smoothness_library
    out = out_dir(args)
    options = LibraryOptions(load_options=load_options_from_args(args), quiet=args.quiet,
                             **executor_kwargs(args))
    maps = library_maps(args)
    check_library_pixels(N_RANGE, "--n", args.n, maps, options.load_options)
    lib = fit_smoothness_library(maps, method=args.method, n=args.n,
                                 scale=args.scale, pointset=args.pointset, seed=args.seed,
                                 out=out, options=options)
    output.record_unwritten(lib.unwritten)
    output.say(*[f"note: {n}" for n in lib.notes],
               f"{len(lib.fits)} maps: {lib.factorizations} factorisation(s) in {lib.rounds} round(s), "
               f"{lib.evaluations_resumed} evaluations resumed; {lib.seconds:.1f} s"
               + (f" on {lib.executor}" if lib.executor else ""), "", format_library_fit(lib))
    if out is not None:
        output.say(f"wrote per-map cells to {out}/<map>/ and the summary "
                   + ", ".join(sorted(lib.files)))
    output.emit_json(lib.to_dict())
    return 0
