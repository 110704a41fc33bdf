"""``envfit sh MAP --lmax L``: real SH coefficients of a map for engines, with the predicted
truncation error, the ringing table (windows x degrees: predicted error and the share of
directions where the truncated signal goes negative) and the degree/window to use for a
target (:mod:`envfit.sh._report`).

Without ``--out`` the ``--format`` document (json, csv or glsl) goes to stdout and the
summary to stderr; with ``--out DIR`` the folder gets ``sh.png`` (look here first),
``sh.json``, ``sh.csv``, ``sh.glsl`` and ``ringing.csv`` and the summary goes to stdout.

Every option is checked before the work (:func:`envfit.sh._report.plan`): ``--lmax``
and ``--table-lmax`` within the map's band limit H − 1, and the planned time and memory
(:mod:`envfit.sh._plan`) within the machine's memory budget and ``ENVFIT_TIME_LIMIT``
(seconds, default 900); a value beyond is refused in one line naming the largest that fits.
A run estimated over 10 s is announced on stderr with its largest stage.

Example::

    envfit sh forest.exr --lmax 2 --irradiance --format json > forest_sh.json
    envfit sh sky.exr --lmax 3 --irradiance --convention mitsuba3 --window sloan --out sh/
"""
from __future__ import annotations

import argparse
import sys

from envfit.cli._common import (add_common_arguments, add_map_arguments, load_map_from_args,
                                map_convention, out_dir)
from envfit.cli._output import CommandOutput
from envfit.cli._ranges import Ranged
from envfit.sh import MAX_CHECK_AXES, MAX_CHECK_HEIGHT
from envfit.sh import BAND_LIMIT

#: the ranges of the options (``--help`` and the errors say these words)
LMAX = Ranged(0, None, "L", hi_text=BAND_LIMIT)
TABLE_LMAX_RANGE = Ranged(1, None, "L", hi_text=BAND_LIMIT)
TARGET = Ranged(0, 1, "F", integer=False, lo_open=True)
AXES = Ranged(1, MAX_CHECK_AXES, "N")
HEIGHT = Ranged(1, MAX_CHECK_HEIGHT, "H")


def register(sub) -> None:
    from envfit.sh import FORMATS
    from envfit.sh import CHECK_AXES, DENSE_HEIGHT, TABLE_LMAX
    from envfit.sh import WINDOWS
    p = sub.add_parser(
        "sh", help="real SH coefficients for engines (irradiance, windows, ringing predictor)",
        description="Real spherical-harmonic coefficients of the map to degree L in the "
                    "convention's world axes: orthonormal, no Condon-Shortley phase "
                    "(Ramamoorthi & Hanrahan 2001), index l(l+1)+m; --irradiance: the "
                    "clamped-cosine convolution A_l L_lm. Prints the predicted RMSE of the "
                    "truncated signal (the map's own power per degree; measured against the "
                    "ground truth unless --no-check), and for L = 1..8 and L, each window "
                    "(none, hanning, lanczos, sloan) the predicted error and the share of "
                    "directions where the truncated signal is negative (Gauss-Legendre grid; "
                    "checked by a dense per-pixel sum), then the smallest L and window meeting "
                    "--target-relative without negative directions. Every option is "
                    "checked before the work: degrees within the map's band limit H-1, and "
                    "the planned time and memory within the machine's memory and the time "
                    "limit (ENVFIT_TIME_LIMIT seconds, default 900); a value beyond is "
                    "refused in one line naming the largest that fits.")
    add_map_arguments(p)
    p.add_argument("--lmax", type=LMAX, required=True, metavar="L",
                   help=f"SH degree of the exported coefficients, {LMAX}")
    p.add_argument("--irradiance", action="store_true",
                   help="export the irradiance coefficients A_l L_lm (clamped cosine)")
    p.add_argument("--scale", choices=("linear", "display"), default="linear",
                   help="values the coefficients are of (default: linear radiance)")
    p.add_argument("--format", choices=FORMATS, default="json",
                   help="stdout document without --out (default: json)")
    p.add_argument("--window", choices=tuple(WINDOWS), default="none",
                   help="window of the exported coefficients (default: none)")
    p.add_argument("--condon-shortley", action="store_true",
                   help="json/csv coefficients for the basis with the Condon-Shortley phase "
                        "(Sloan's Stupid SH Tricks, D3DX: odd m negated); glsl keeps its own")
    p.add_argument("--target-relative", type=TARGET, default=0.01, metavar="F",
                   help=f"relative RMSE the choice must meet, {TARGET} (default: 0.01)")
    p.add_argument("--table-lmax", type=TABLE_LMAX_RANGE, default=None, metavar="L",
                   help=f"ringing table for L = 1..this and --lmax, {TABLE_LMAX_RANGE} "
                        f"(default: min({TABLE_LMAX}, H-1))")
    p.add_argument("--no-check", action="store_true",
                   help="skip the measured error and the dense negative-fraction check")
    p.add_argument("--check-axes", type=AXES, default=None, metavar="N",
                   help=f"spherical Fibonacci directions of the measured irradiance error "
                        f"(--irradiance), {AXES} (default: {CHECK_AXES}); radiance is measured "
                        f"on the pixel centres of a 2H-row grid instead, and this is unused")
    p.add_argument("--check-height", type=HEIGHT, default=DENSE_HEIGHT, metavar="H",
                   help=f"rows of the dense check's lat-long grid, {HEIGHT} (default: "
                        f"{DENSE_HEIGHT})")
    add_common_arguments(p, seed=False)
    p.set_defaults(func=run)


#: a plan longer than this (estimated seconds) is announced on stderr before the work
NOTE_SECONDS = 10.0


def _plan_note(args: argparse.Namespace, stages) -> None:
    """One line on stderr before a long run: the estimated time and its largest stage."""
    total = sum(s.seconds for s in stages)
    if args.quiet or total < NOTE_SECONDS:
        return
    top = max(stages, key=lambda s: s.seconds)
    print(f"envfit sh: note: about {total:.0f} s of work on this machine (estimated; "
          f"{top.name}: {top.seconds:.0f} s, sized by {top.option})", file=sys.stderr)


def run(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.sh import SHReportOptions, document, measured_where, plan, sh_outputs, sh_report
    from envfit.sh import CHECK_AXES
    env = load_map_from_args(args)
    conv = map_convention(args)
    opts = SHReportOptions(irradiance=args.irradiance, window=args.window,
                           target_relative=args.target_relative, scale=args.scale,
                           table_lmax=args.table_lmax, check=not args.no_check,
                           check_axes=CHECK_AXES if args.check_axes is None else args.check_axes,
                           dense_height=args.check_height,
                           convention=None if conv is None else f"{conv.name} ({conv.renderer})",
                           condon_shortley=args.condon_shortley)
    _plan_note(args, plan(env, args.lmax, opts))        # refused here, before the work
    if args.check_axes is not None and not (args.irradiance or args.no_check or args.quiet):
        print(f"envfit sh: note: --check-axes {args.check_axes} is unused: it counts the "
              f"directions of the measured irradiance error (--irradiance); the radiance "
              f"error is measured on {measured_where(env.height, False, 0)}", file=sys.stderr)
    r = sh_report(env, args.lmax, opts, quiet=args.quiet)
    out = out_dir(args)
    json_on_stdout = str(args.json) == "-"
    if out is None and not json_on_stdout:
        sys.stdout.write(document(r, args.format))
        sys.stdout.flush()
    lines = r.summary_lines()
    if out is not None:
        files = {name: output.guarded_write(out / name, write, out / name)
                 for name, write in sh_outputs(r).items()}
        lines.append("wrote " + ", ".join(str(p) for p in files.values() if p is not None))
    if not args.quiet:
        stream = sys.stdout if out is not None and not json_on_stdout else sys.stderr
        print("\n".join(lines), file=stream)
    output.emit_json(r.to_dict())
    return 0
