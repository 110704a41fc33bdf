"""``envfit table2``: the paper's Table 2 (Sec. 9.1) on a map, or on a library of maps."""
from __future__ import annotations

import argparse

import numpy as np

from envfit.defaults import SOLVERS
from envfit.cli._common import (add_common_arguments, add_executor_arguments, add_map_arguments,
                                executor_kwargs, library_maps, library_mode,
                                load_map_from_args, load_options_from_args, out_dir)
from envfit.cli._output import CommandOutput
from envfit.cli._ranges import PIXELS, Ranged, check_library_pixels, check_pixels

#: the ranges of the options (``--help`` and the errors say these words)
S_VALUES = Ranged(1, 2, "s", integer=False, lo_open=True, hi_open=True, many=True)
N_VALUES = Ranged(2, None, "N", many=True, hi_text=PIXELS)


def register(sub) -> None:
    p = sub.add_parser(
        "table2", help="reconstruct a map from N samples for a grid of s (the paper's Table 2)",
        description="For each (s, N): sample the map at N directions, interpolate with the "
                    "Sobolev kernel K_gd^(s) (Eq. 14), evaluate at every pixel and report the "
                    "RMSE on the chosen scale. Resumable: finished cells in --out are skipped. "
                    "Several maps (files, folders, glob patterns): each (s, N) matrix is "
                    "factorised once and solved for all maps; per-map results and a summary "
                    "across maps go to --out.")
    add_map_arguments(p, many=True)
    p.add_argument("--s", type=S_VALUES, default=None, metavar="S1,S2,…",
                   help=f"smoothness values, each {S_VALUES} (default: 1.1,1.5,1.9)")
    p.add_argument("--n", type=N_VALUES, default=None, metavar="N1,N2,…",
                   help=f"sample counts, each {N_VALUES}; and within the memory budget (default: "
                        "100,500,1000,2500,5000,10000,20000; --quick: 100,250,500,1000,2000)")
    p.add_argument("--pointset", choices=("sf", "random"), default="sf",
                   help="sample directions: spherical Fibonacci (default) or random")
    p.add_argument("--scale", choices=("display", "linear", "log"), default="display",
                   help="value scale of the comparison (default: display, as the paper)")
    p.add_argument("--quick", action="store_true",
                   help="a small grid on a map of at most 128 rows (seconds)")
    p.add_argument("--paper", action="store_true", help="print the paper's Table 2 beside")
    p.add_argument("--solver", choices=SOLVERS, default="auto",
                   help="linear solver of each cell: dense Cholesky, preconditioned CG with "
                        "O(N log N) products (RMSE equal to Cholesky's to 1e-6 relative), or "
                        "auto (default: one map by the measured crossover N; a library by "
                        "one dense factor for all maps where it fits; iterative where the "
                        "dense matrix does not fit)")
    p.add_argument("--reconstructions", action="store_true",
                   help="several maps: also write each map's reconstructions at the largest N "
                        "(one map: always written)")
    add_executor_arguments(p)
    add_common_arguments(p)
    p.set_defaults(func=run)


#: ``--quick`` without ``--max-height``: the map downscaled to at most this many rows
QUICK_HEIGHT = 128


def run(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.fit import PAPER_N, PAPER_S, QUICK_N
    s_values = args.s or list(PAPER_S)
    n_values = args.n or list(QUICK_N if args.quick else PAPER_N)
    if library_mode(args):
        return _run_library(args, output, s_values, n_values)
    return _run_single(args, output, s_values, n_values)


def _run_single(args, output: CommandOutput, s_values, n_values) -> int:
    from envfit.fit import format_table2, run_table2
    env = load_map_from_args(args, quick_height=QUICK_HEIGHT)
    check_pixels(N_VALUES, "--n", n_values, env)        # before the memory guard's N
    out = out_dir(args)
    for note in getattr(env, "notes", []):
        output.say(f"note: {note}")
    output.say(f"map {env.name}: {env.width}x{env.height}, {env.channels} channel(s); "
               f"{len(s_values)} s x {len(n_values)} N cells" + (f"; results in {out}" if out else ""))

    def on_cell(cell, resumed):
        if resumed:
            output.say(f"  s={cell.s:g} N={cell.n}: resumed from {out}")

    res = run_table2(env, s_values, n_values, pointset=args.pointset, scale=args.scale,
                     seed=args.seed, out=out, quiet=args.quiet, on_cell=on_cell,
                     solver=args.solver)
    output.record_unwritten(res.unwritten)
    output.say("", format_table2(res, paper=args.paper), "",
               format_table2(res, key="rmse_solid_angle"), "",
               f"s with the lowest RMSE at N = {res.n_values[-1]}: {res.s_best:g}")
    known = _known_s(env, res, quiet=args.quiet) if not args.quiet or args.json else None
    if known is not None:
        output.say(known["sentence"])
    if out is not None:
        from envfit.base import atomic_write_csv
        from envfit.plots import plot_table2
        rows = [(c.s, c.n, c.rmse, c.rmse_solid_angle, c.seconds, c.solver, c.iterations,
                 c.residual, c.rmse_change_bound) for c in res.cells]
        written = []
        for name, write, wargs in (
                ("table2_rmse.png", plot_table2, (res, out / "table2_rmse.png")),
                ("table2.csv", atomic_write_csv,
                 (out / "table2.csv", ("s", "n", "rmse", "rmse_solid_angle", "seconds", "solver",
                                       "iterations", "residual", "rmse_change_bound"), rows))):
            path = output.guarded_write(out / name, write, *wargs)
            if path is not None:
                res.files[name] = str(path)
                written.append(str(path))
        if written:
            output.say("wrote " + " and ".join(written))
    d = res.to_dict()
    if known is not None:
        d["known_s"] = known
    output.emit_json(d)
    return 0


#: the largest N at which the built-in map's closed-form expected RMSE is computed (an N x N
#: Cholesky per s plus O(N^2) table gathers: about half a minute at 4000 on 2 cores)
KNOWN_S_MAX_N = 4000


def _known_s(env, res, quiet: bool = False) -> dict | None:
    """On the built-in map (a GP of known s0): the closed-form expected RMSE against s for
    its synthesis, resize and lookup (:mod:`envfit.fit._kriging`) at the largest N of the
    table up to :data:`KNOWN_S_MAX_N`, and one sentence comparing its optimum with the
    measured one. ``None`` for any other map or a single s."""
    from envfit.fit import builtin_synthesis, expected_interpolation_mse, known_s_sentence
    model = builtin_synthesis(env)
    if model is None or len(res.s_values) < 2:          # one s: no optimum to compare
        return None
    ns = [n for n in res.n_values if n <= KNOWN_S_MAX_N]
    if not ns:
        return {"sentence": f"Known s: this map is a GP sample of s0 = {model.s0:g}; the "
                            f"closed-form expected optimum is computed for N <= "
                            f"{KNOWN_S_MAX_N} only (bench/known_s.py)."}
    n = ns[-1]
    curve = expected_interpolation_mse(model, res.s_values, n, pointset=res.pointset,
                                       seed=res.seed, max_pixels=2048, quiet=quiet)
    measured = res.s_best_by_n()[n]
    return {"sentence": known_s_sentence(curve, measured, res.scale), "n": n,
            "model": model.describe(), "s_values": list(res.s_values),
            "expected_rmse_pixel": [float(v) for v in np.sqrt(curve.mse_pixel)],
            "expected_rmse_solid_angle": [float(v) for v in np.sqrt(curve.mse_solid_angle)],
            "expected_s_best": curve.s_best, "measured_s_best": measured}



def _tail(label: str, width: int = 28) -> str:
    """``label`` within ``width`` characters, its end kept (where maps differ)."""
    return label if len(label) <= width else "…" + label[-(width - 1):]


def format_library_table2(lib) -> str:
    """One line per map: best s at the largest N and the RMSE there for every s."""
    n_max = lib.n_values[-1]
    head = f"  {'map':<28} {'H':>5} {'best s':>7} | " + " ".join(f"{'s=' + format(s, 'g'):>9}" for s in lib.s_values)
    lines = [f"RMSE per pixel at N = {n_max} ({lib.scale} scale), {len(lib.maps)} maps", head,
             "  " + "-" * (len(head) - 2)]
    for r in lib.maps:
        col = r.rmse_table()[:, -1]
        lines.append(f"  {_tail(r.map):<28} {r.height:>5} {r.s_best:>7g} | "
                     + " ".join(f"{v:9.4f}" for v in col))
    counts = {s: int(sum(abs(r.s_best - s) < 1e-9 for r in lib.maps)) for s in lib.s_values}
    lines.append("  best s across maps: " + ", ".join(f"s={s:g}: {c}" for s, c in counts.items()))
    return "\n".join(lines)


def _run_library(args, output: CommandOutput, s_values, n_values) -> int:
    from envfit.batch import LibraryOptions, run_table2_library
    out = out_dir(args)
    maps = library_maps(args, quick_height=QUICK_HEIGHT)
    if args.paper:
        output.say("note: --paper prints beside a single map's table only")

    def on_cell(label, cell, resumed):
        if resumed:
            output.say(f"  {label}: s={cell.s:g} N={cell.n}: resumed from {out}")

    options = LibraryOptions(load_options=load_options_from_args(args, quick_height=QUICK_HEIGHT),
                             quiet=args.quiet,
                             **executor_kwargs(args))
    check_library_pixels(N_VALUES, "--n", n_values, maps, options.load_options)
    lib = run_table2_library(maps, s_values, n_values, pointset=args.pointset, scale=args.scale,
                             seed=args.seed, out=out, save_reconstructions=args.reconstructions,
                             on_cell=on_cell, solver=args.solver, options=options)
    output.record_unwritten(lib.unwritten)
    output.say(*[f"note: {n}" for n in lib.notes],
               f"{len(lib.maps)} maps, {len(s_values)} s x {len(n_values)} N; {lib.cells_computed} cells "
               f"computed with {lib.factorizations} factorisation(s), {lib.cells_resumed} resumed; "
               f"{lib.seconds:.1f} s" + (f" on {lib.executor}" if lib.executor else ""),
               "", format_library_table2(lib))
    if out is not None:
        output.say(f"wrote per-map results to {out}/<map>/ and the summary "
                   + ", ".join(sorted(k for k in lib.files)))
    output.emit_json(lib.to_dict())
    return 0
