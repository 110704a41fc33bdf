"""``envfit fit``: estimate the Sobolev smoothness s of a map, with an interval and σ̂."""
from __future__ import annotations

import argparse

from .common import add_common_arguments, add_map_arguments, emit_json, load_map_from_args, out_dir, say


def register(sub) -> None:
    from ..fit import DEFAULT_METHOD, DEFAULT_N, METHODS
    p = sub.add_parser(
        "fit", help="estimate the Sobolev smoothness s of a map (with a 95%% interval and sigma)",
        description="Estimate s on the continuous range (1, 2) by the Gaussian-process "
                    "likelihood, closed-form leave-one-out, or held-out reconstruction error.")
    add_map_arguments(p)
    p.add_argument("--method", choices=METHODS, default=DEFAULT_METHOD,
                   help=f"criterion (default: {DEFAULT_METHOD}; see README for why)")
    p.add_argument("--n", type=int, default=DEFAULT_N, help=f"number of samples (default: {DEFAULT_N})")
    p.add_argument("--pointset", choices=("sf", "random"), default="sf")
    p.add_argument("--scale", choices=("display", "linear", "log"), default="display",
                   help="value scale the map is fitted on (default: display)")
    add_common_arguments(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..fit import fit_smoothness
    env = load_map_from_args(args)
    for note in getattr(env, "notes", []):
        say(args, f"note: {note}")
    res = fit_smoothness(env, method=args.method, n=args.n, scale=args.scale,
                         pointset=args.pointset, seed=args.seed, quiet=args.quiet)
    sig = ", ".join(f"{x:.4g}" for x in res.sigma)
    say(args, f"map {env.name}: {env.height}x{env.width}",
        f"s = {res.s:.3f}  (95% interval {res.s_interval[0]:.3f} … {res.s_interval[1]:.3f}; "
        f"method {res.method}, N = {res.n}, {res.scale_description})",
        f"sigma = {sig}  (per channel, on the {res.scale} scale)",
        *[f"note: {n}" for n in res.notes],
        f"({res.seconds:.1f} s)")
    out = out_dir(args)
    d = res.to_dict()
    d["map"] = env.name
    if out is not None:
        from ..plots.table2 import plot_fit_curve
        png = plot_fit_curve(res, out / f"fit_{res.method}.png")
        d["files"] = {"curve": str(png)}
        say(args, f"wrote {png}")
    emit_json(args, d)
    return 0
