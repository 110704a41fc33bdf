"""``envfit synth``: write a synthetic map (Gaussian process of known s, an analytic map, or
the axis-marker self-check map), on envfit's pixel grid or in a renderer's ``--convention``.

With ``--out DIR``, ``DIR/<OUT>_preview.png`` shows the written map in its layout with its
bright sources marked (as ``envfit info --out``).

Example::

    envfit synth marker.exr --kind marker --convention mitsuba3 --height 64 --out preview/
    envfit info marker.exr --convention mitsuba3      # brightest direction: +x
"""
from __future__ import annotations

import argparse
from pathlib import Path

from envfit.base._atomic import os_reason
from envfit.base._errors import EnvfitError, OutputError, ParameterError
from envfit.data_gen import synth_kind_names
from envfit.defaults import UPS
from envfit.maps._envmap import EnvMap
from envfit.cli._common import (CONVENTION_HELP, add_common_arguments, colour_list,
                                finite_float, map_convention, map_up, out_dir, positive_float,
                                positive_int)
from envfit.cli._output import CommandOutput

#: the kinds, as :data:`envfit.data_gen.SYNTH_KINDS` names them
KINDS = synth_kind_names()


def register(sub) -> None:
    p = sub.add_parser(
        "synth", help="write a synthetic lat-long map (gp, sun-gp, constant, sky, sun, step, marker)",
        description="Synthesize a lat-long map of known smoothness (a Gaussian-process sample "
                    "with covariance K_gd^(s0), Eq. 8), a sun of known radiance and radius on such a "
                    "background ('sun-gp': linear HDR with a sun, for the renderer estimators), "
                    "or an analytic map with known shading "
                    "integrals, or the self-check map 'marker' (small markers of distinct colours at "
                    "the world axes +x red (the brightest), -x cyan, +y green, -y magenta, +z "
                    "blue, -z yellow), and write it as EXR, in envfit's layout or in a "
                    "renderer's --convention.")
    p.add_argument("output", metavar="OUT.exr", type=Path)
    p.add_argument("--kind", choices=KINDS, default="gp")
    p.add_argument("--height", type=positive_int, default=256, help="rows (width = 2 x height)")
    p.add_argument("--up", choices=UPS, default=None,
                   help="world up axis stored with the map, on envfit's grid (default: y); "
                        "not with --convention")
    p.add_argument("--convention", metavar="NAME", default=None, help=CONVENTION_HELP.replace(
        "whose lat-long layout the MAP file has", "whose lat-long layout to write").replace(
        "The map is converted to envfit's grid (exactly where only pixels move, else "
        "bilinear). Not with --up; one map at a time", "Not with --up"))
    g = p.add_argument_group("marker")
    g.add_argument("--marker-radius", type=positive_float, default=None, metavar="RAD",
                   help="angular radius of each marker in radians (default: 3 rows, 3 pi/H)")
    p.add_argument("--half", action="store_true", help="write half floats instead of float32")
    g = p.add_argument_group("gp")
    g.add_argument("--s0", type=finite_float, default=None, help="Sobolev smoothness of the process, in (1, 2)")
    g.add_argument("--channels", type=positive_int, default=None, help="channels (default: 3)")
    g.add_argument("--method", choices=("sht", "exact"), default=None,
                   help="band-limited SH synthesis (fast) or exact Cholesky at pixel centres (small maps)")
    g.add_argument("--offset", type=_auto_or_number, default=None,
                   help="constant added to the zero-mean sample; 'auto' makes every pixel "
                        "positive (sun-gp: 4 x amplitude, raised if a pixel would be negative)")
    g.add_argument("--amplitude", type=positive_float, default=None, help="scale sigma of the process")
    g = p.add_argument_group("analytic maps (colours are comma-separated: one value or R,G,B)")
    g.add_argument("--value", type=colour_list, default=None, help="constant: the value")
    g.add_argument("--horizon", type=colour_list, default=None, help="sky: horizon colour")
    g.add_argument("--zenith", type=colour_list, default=None, help="sky: zenith colour")
    g.add_argument("--sun-theta", type=finite_float, default=None, help="sun: polar angle from up (radians)")
    g.add_argument("--sun-phi", type=finite_float, default=None, help="sun: azimuth (radians)")
    g.add_argument("--sun-radius", type=positive_float, default=None, help="sun: angular radius (radians)")
    g.add_argument("--sun-radiance", type=colour_list, default=None,
                   help="sun, sun-gp: disk radiance (added to the background for sun-gp)")
    g.add_argument("--sky", type=colour_list, default=None, help="sun: sky colour")
    g.add_argument("--theta-edge", type=finite_float, default=None, help="step: edge polar angle")
    g.add_argument("--low", type=colour_list, default=None, help="step: value below the edge")
    g.add_argument("--high", type=colour_list, default=None, help="step: value above the edge")
    # the kinds' options default to None: the kind's own default applies (SYNTH_KINDS)
    add_common_arguments(p)
    p.set_defaults(func=run, output_metavar="")  # "cannot write m.exr: …"


def _auto_or_number(text: str):
    """``--offset``: 'auto' or a finite number (argparse ``type=``)."""
    return "auto" if str(text).strip().lower() == "auto" else finite_float(text)


def _kind_params(args: argparse.Namespace) -> dict:
    """The options ``--kind`` takes (:data:`envfit.data_gen.SYNTH_KINDS`), by their API
    names; an option left at None keeps the kind's default."""
    from envfit.data_gen import SYNTH_KINDS
    names = SYNTH_KINDS[args.kind].params
    return {name: getattr(args, name) for name in names
            if getattr(args, name, None) is not None}


def run(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.maps._io import save_envmap
    from envfit.maps._synth import synthesize_envmap
    if args.height < 2:
        raise ParameterError(f"--height must be at least 2, got {args.height}")
    made = synthesize_envmap(args.kind, args.height, seed=args.seed,
                             up=None if map_convention(args) is not None else map_up(args),
                             convention=map_convention(args), **_kind_params(args))
    env, conv, f = made.envmap, made.convention, made.pixels
    try:
        path = save_envmap(args.output, env, half=args.half)
    except EnvfitError:     # EnvMapFileError "…: write failed: …" says it all
        raise
    except OSError as exc:  # disk full, folder gone meanwhile (checked writable before)
        raise OutputError(f"could not write {args.output}: {os_reason(exc)}") from None
    info = made.synth.to_dict()
    info.update(path=str(path), width=env.width, channels=env.channels,
                convention=conv.name if conv is not None else None, up=env.up,
                min=float(f.min()), max=float(f.max()), mean=[float(x) for x in env.mean()])
    output.say(f"wrote {path}: {args.kind} map {env.width}x{env.height}, {env.channels} "
               f"channel(s)"
               + (f", s0 = {info['s0']}" if args.kind == "gp" else "")
               + (f", {conv.name} layout (+{conv.up} up)" if conv is not None else ""))
    out = out_dir(args)
    if out is not None:           # the preview of what was written, in the file's layout
        from envfit.cli._info import write_preview
        internal = env if conv is None else conv.to_internal(env)
        png = write_preview(output, EnvMap(internal.data, up=internal.up, name=path.name),
                            conv, out, Path(path).stem)
        info["files"] = {"preview": None if png is None else str(png)}
    output.emit_json(info)
    return 0
