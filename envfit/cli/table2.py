"""``envfit table2``: the paper's Table 2 (Sec. 9.1) on a map."""
from __future__ import annotations

import argparse

from .common import (add_common_arguments, add_map_arguments, emit_json, float_list, int_list,
                     load_map_from_args, out_dir, say)


def register(sub) -> None:
    p = sub.add_parser(
        "table2", help="reconstruct a map from N samples for a grid of s (the paper's Table 2)",
        description="For each (s, N): sample the map at N directions, interpolate with the "
                    "Sobolev kernel K_gd^(s) (Eq. 14), evaluate at every pixel and report the "
                    "RMSE on the chosen scale. Resumable: finished cells in --out are skipped.")
    add_map_arguments(p)
    p.add_argument("--s", type=float_list, default=None, metavar="S1,S2,…",
                   help="smoothness values in (1, 2) (default: 1.1,1.5,1.9)")
    p.add_argument("--n", type=int_list, default=None, metavar="N1,N2,…",
                   help="sample counts (default: 100,500,1000,2500,5000,10000,20000; "
                        "--quick: 100,250,500,1000,2000)")
    p.add_argument("--pointset", choices=("sf", "random"), default="sf",
                   help="sample directions: spherical Fibonacci (default) or random")
    p.add_argument("--scale", choices=("display", "linear", "log"), default="display",
                   help="value scale of the comparison (default: display, as the paper)")
    p.add_argument("--quick", action="store_true",
                   help="a small grid on a map of at most 128 rows (seconds)")
    p.add_argument("--paper", action="store_true", help="print the paper's Table 2 beside")
    add_common_arguments(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..table2 import PAPER_N, PAPER_S, QUICK_N, format_table2, run_table2
    if args.quick and args.max_height is None:
        args.max_height = 128
    env = load_map_from_args(args)
    s_values = args.s or list(PAPER_S)
    n_values = args.n or list(QUICK_N if args.quick else PAPER_N)
    out = out_dir(args)
    for note in getattr(env, "notes", []):
        say(args, f"note: {note}")
    say(args, f"map {env.name}: {env.height}x{env.width}, {env.channels} channel(s); "
              f"{len(s_values)} s x {len(n_values)} N cells" + (f"; results in {out}" if out else ""))

    def on_cell(cell, resumed):
        if not args.quiet and resumed:
            print(f"  s={cell.s:g} N={cell.n}: resumed from {out}")

    res = run_table2(env, s_values, n_values, pointset=args.pointset, scale=args.scale,
                     seed=args.seed, out=out, quiet=args.quiet, on_cell=on_cell)
    say(args, "", format_table2(res, paper=args.paper), "",
        format_table2(res, key="rmse_solid_angle"), "",
        f"s with the lowest RMSE at N = {res.n_values[-1]}: {res.s_best:g}")
    if out is not None:
        from ..atomic import atomic_write_csv
        from ..plots.table2 import plot_table2
        png = plot_table2(res, out / "table2_rmse.png")
        res.files["table2_rmse.png"] = str(png)
        rows = [(c.s, c.n, c.rmse, c.rmse_solid_angle, c.seconds) for c in res.cells]
        csv = atomic_write_csv(out / "table2.csv", ("s", "n", "rmse", "rmse_solid_angle", "seconds"), rows)
        res.files["table2.csv"] = str(csv)
        say(args, f"wrote {png} and {csv}")
    emit_json(args, res.to_dict())
    return 0
