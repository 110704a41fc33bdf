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

from envfit.base import os_reason
from envfit.base import EnvfitError, OutputError, ParameterError
from envfit.data_gen import synth_kind_names
from envfit.defaults import UPS
from envfit.maps import EnvMap
from envfit.cli._common import CONVENTION_HELP, add_common_arguments, map_convention, map_up, out_dir
from envfit.cli._output import CommandOutput
from envfit.cli._ranges import Ranged

#: the kinds, as :data:`envfit.data_gen.SYNTH_KINDS` names them
KINDS = synth_kind_names()

_PI = 3.141592653589793
#: the ranges of the options (``--help`` and the errors say these words): --height by the SH
#: sampler's largest degree H-1 = 8191 (envfit.data_gen._gp.SHT_MAX_LMAX), the angles by the
#: generators' (data_gen._analytic, _marker), values and colours by a fixed cap
HEIGHT = Ranged(2, 8192, "H")
EXACT_HEIGHT = 48          # --method exact: 2 H^2 <= envfit.data_gen.EXACT_MAX_POINTS = 4608
MARKER_RADIUS = Ranged(0, _PI / 4, "RAD", integer=False, lo_open=True)
S0 = Ranged(1, 2, "s", integer=False, lo_open=True, hi_open=True)
CHANNELS = Ranged(1, 4, "C")
OFFSET = Ranged(-1e9, 1e9, "offset", integer=False, literals=("auto",))
AMPLITUDE = Ranged(0, 1e9, "sigma", integer=False, lo_open=True)
COLOUR = Ranged(0, 1e9, "v", integer=False, many=True, repeats=True)
THETA = Ranged(0, _PI, "theta", integer=False)
THETA_EDGE = Ranged(0, _PI, "theta", integer=False, lo_open=True, hi_open=True)
PHI = Ranged(-2 * _PI, 2 * _PI, "phi", integer=False)
SUN_RADIUS = Ranged(0, _PI / 2, "r", integer=False, lo_open=True)


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
    p.add_argument("--height", type=HEIGHT, default=256, metavar="H",
                   help=f"rows (width = 2 x height), {HEIGHT} (the SH sampler's largest degree "
                        f"H-1 is 8191; --method exact: H <= {EXACT_HEIGHT}); default 256")
    p.add_argument("--up", choices=UPS, default=None,
                   help="world up axis stored with the map, on envfit's grid (default: y); "
                        "not with --convention")
    p.add_argument("--convention", metavar="NAME", default=None, help=CONVENTION_HELP.replace(
        "whose lat-long layout the MAP file has", "whose lat-long layout to write").replace(
        "The map is converted to envfit's grid (exactly where only pixels move, else "
        "bilinear). Not with --up; one map at a time", "Not with --up"))
    g = p.add_argument_group("marker")
    g.add_argument("--marker-radius", type=MARKER_RADIUS, default=None, metavar="RAD",
                   help=f"angular radius of each marker in radians, {MARKER_RADIUS} (pi/4) "
                        "(default: 3 rows, 3 pi/H)")
    p.add_argument("--half", action="store_true", help="write half floats instead of float32")
    g = p.add_argument_group("gp")
    g.add_argument("--s0", type=S0, default=None,
                   help=f"Sobolev smoothness of the process, {S0}")
    g.add_argument("--channels", type=CHANNELS, default=None, metavar="C",
                   help=f"channels, {CHANNELS} (default: 3)")
    g.add_argument("--method", choices=("sht", "exact"), default=None,
                   help="band-limited SH synthesis (fast) or exact Cholesky at pixel centres "
                        f"(small maps: --height H <= {EXACT_HEIGHT})")
    g.add_argument("--offset", type=OFFSET, default=None,
                   help=f"constant added to the zero-mean sample, {OFFSET}; 'auto' makes every "
                        "pixel positive (sun-gp: 4 x amplitude, raised if a pixel would be "
                        "negative)")
    g.add_argument("--amplitude", type=AMPLITUDE, default=None,
                   help=f"scale sigma of the process, {AMPLITUDE}")
    _add_analytic_arguments(p)
    # the kinds' options default to None: the kind's own default applies (SYNTH_KINDS)
    add_common_arguments(p)
    p.set_defaults(func=run, output_metavar="")  # "cannot write m.exr: …"


def _add_analytic_arguments(p: argparse.ArgumentParser) -> None:
    """The options of the analytic kinds (constant, sky, sun, step)."""
    g = p.add_argument_group("analytic maps (colours are comma-separated: one value or R,G,B, "
                             f"each {COLOUR})")
    g.add_argument("--value", type=COLOUR, default=None, help=f"constant: the value, each {COLOUR}")
    g.add_argument("--horizon", type=COLOUR, default=None, help=f"sky: horizon colour, each {COLOUR}")
    g.add_argument("--zenith", type=COLOUR, default=None, help=f"sky: zenith colour, each {COLOUR}")
    g.add_argument("--sun-theta", type=THETA, default=None,
                   help=f"sun: polar angle from up (radians), {THETA} (pi)")
    g.add_argument("--sun-phi", type=PHI, default=None, help=f"sun: azimuth (radians), {PHI} (2 pi)")
    g.add_argument("--sun-radius", type=SUN_RADIUS, default=None,
                   help=f"sun: angular radius (radians), {SUN_RADIUS} (pi/2)")
    g.add_argument("--sun-radiance", type=COLOUR, default=None,
                   help=f"sun, sun-gp: disk radiance (added to the background for sun-gp), each "
                        f"{COLOUR}")
    g.add_argument("--sky", type=COLOUR, default=None, help=f"sun: sky colour, each {COLOUR}")
    g.add_argument("--theta-edge", type=THETA_EDGE, default=None,
                   help=f"step: edge polar angle (radians), {THETA_EDGE} (pi)")
    g.add_argument("--low", type=COLOUR, default=None, help=f"step: value below the edge, each {COLOUR}")
    g.add_argument("--high", type=COLOUR, default=None, help=f"step: value above the edge, each {COLOUR}")


def _kind_params(args: argparse.Namespace) -> dict:
    """The options ``--kind`` takes (:data:`envfit.data_gen.SYNTH_KINDS`), by their API
    names; an option left at None keeps the kind's default."""
    from envfit.data_gen import SYNTH_KINDS
    names = SYNTH_KINDS[args.kind].params
    return {name: getattr(args, name) for name in names
            if getattr(args, name, None) is not None}


def run(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.maps import save_envmap
    from envfit.maps import synthesize_envmap
    if args.height < 2:
        raise ParameterError(f"--height {args.height} is outside {HEIGHT}")
    if args.method == "exact" and args.height > EXACT_HEIGHT:
        raise ParameterError(f"--height {args.height} with --method exact is outside "
                             f"H <= {EXACT_HEIGHT}: the exact sampler factorises 2H^2 pixel "
                             "centres (at most 4608); use --method sht")
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
