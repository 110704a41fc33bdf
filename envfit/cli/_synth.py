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

import numpy as np

from envfit.base._atomic import os_reason
from envfit.base._errors import EnvfitError, OutputError, ParameterError
from envfit.defaults import UPS
from envfit.cli._common import (CONVENTION_HELP, add_common_arguments, colour_list, emit_json,
                                finite_float, map_convention, map_up, out_dir, positive_float,
                                positive_int, say)

KINDS = ("gp", "sun-gp", "constant", "sky", "sun", "step", "marker")


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
    g.add_argument("--s0", type=finite_float, default=1.5, help="Sobolev smoothness of the process, in (1, 2)")
    g.add_argument("--channels", type=positive_int, default=3)
    g.add_argument("--method", choices=("sht", "exact"), default="sht",
                   help="band-limited SH synthesis (fast) or exact Cholesky at pixel centres (small maps)")
    g.add_argument("--offset", type=_auto_or_number, default="auto",
                   help="constant added to the zero-mean sample; 'auto' makes every pixel "
                        "positive (sun-gp: 4 x amplitude, raised if a pixel would be negative)")
    g.add_argument("--amplitude", type=positive_float, default=1.0, help="scale sigma of the process")
    g = p.add_argument_group("analytic maps (colours are comma-separated: one value or R,G,B)")
    g.add_argument("--value", type=colour_list, default=[1.0], help="constant: the value")
    g.add_argument("--horizon", type=colour_list, default=[0.6, 0.7, 0.8], help="sky: horizon colour")
    g.add_argument("--zenith", type=colour_list, default=[0.2, 0.35, 0.9], help="sky: zenith colour")
    g.add_argument("--sun-theta", type=finite_float, default=0.6, help="sun: polar angle from up (radians)")
    g.add_argument("--sun-phi", type=finite_float, default=1.0, help="sun: azimuth (radians)")
    g.add_argument("--sun-radius", type=positive_float, default=0.05, help="sun: angular radius (radians)")
    g.add_argument("--sun-radiance", type=colour_list, default=[200.0],
                   help="sun, sun-gp: disk radiance (added to the background for sun-gp)")
    g.add_argument("--sky", type=colour_list, default=[0.5, 0.6, 0.9], help="sun: sky colour")
    g.add_argument("--theta-edge", type=finite_float, default=np.pi / 2, help="step: edge polar angle")
    g.add_argument("--low", type=colour_list, default=[0.1], help="step: value below the edge")
    g.add_argument("--high", type=colour_list, default=[1.0], help="step: value above the edge")
    add_common_arguments(p)
    p.set_defaults(func=run, output_metavar="")  # "cannot write m.exr: …"


def _auto_or_number(text: str):
    """``--offset``: 'auto' or a finite number (argparse ``type=``)."""
    return "auto" if str(text).strip().lower() == "auto" else finite_float(text)


def _colour(v):
    return v[0] if len(v) == 1 else tuple(v)


def synthesize(args: argparse.Namespace) -> tuple[np.ndarray, dict]:
    """The map array (H×2H×C, local frame) and a description of how it was made."""
    import envfit.data_gen as data_gen
    if args.height < 2:
        raise ParameterError(f"--height must be at least 2, got {args.height}")
    info = {"kind": args.kind, "height": args.height}
    try:
        if args.kind == "gp":
            f = data_gen.gaussian_process_map(args.s0, args.height, seed=args.seed,
                                              channels=args.channels, scale=args.amplitude,
                                              method=args.method)
            if args.offset == "auto":
                offset = float(-f.min() + 0.1 * (f.max() - f.min()))
            else:
                offset = float(args.offset)
            f = f + offset
            info.update(s0=args.s0, seed=args.seed, channels=args.channels, offset=offset,
                        amplitude=args.amplitude, method=args.method)
            return f, info
        if args.kind == "sun-gp":
            offset = 4.0 * args.amplitude if args.offset == "auto" else float(args.offset)
            from envfit.data_gen._sun_gp import sun_gp_map
            f, sun = sun_gp_map(args.height, seed=args.seed, s0=args.s0,
                                sun_theta=args.sun_theta, sun_phi=args.sun_phi,
                                sun_radius=args.sun_radius,
                                sun_radiance=_colour(args.sun_radiance),
                                channels=args.channels, offset=offset,
                                scale=args.amplitude, method=args.method)
            if args.offset == "auto" and f.min() < 0:       # lift the background above 0
                lift = float(-f.min() + 0.1 * offset)
                f, offset = f + lift, offset + lift
            info.update(s0=args.s0, seed=args.seed, channels=args.channels, offset=offset,
                        amplitude=args.amplitude, method=args.method,
                        sun_frame="local (z up; the written map's world frame by its up axis)",
                        sun={k: np.asarray(getattr(sun, k)).tolist() for k in
                             ("direction", "theta", "phi", "radius", "radiance",
                              "solid_angle", "rendered_solid_angle")})
            return f, info
        if args.kind == "constant":
            m = data_gen.ConstantMap(_colour(args.value))
        elif args.kind == "sky":
            m = data_gen.SkyGradientMap(_colour(args.horizon), _colour(args.zenith))
        elif args.kind == "sun":
            m = data_gen.SunSkyMap(sun_theta=args.sun_theta, sun_phi=args.sun_phi,
                                   sun_radius=args.sun_radius,
                                   sun_radiance=_colour(args.sun_radiance), sky=_colour(args.sky))
        else:
            m = data_gen.StepMap(_colour(args.low), _colour(args.high), args.theta_edge)
    except ValueError as exc:  # data_gen reports bad parameters as ValueError subclasses
        raise ParameterError(str(exc)) from None
    info["map"] = repr(m)
    return m.render(args.height), info


def _marker(args: argparse.Namespace, conv) -> tuple[np.ndarray, dict]:
    """The marker map's pixels (H×2H×3) laid out in ``conv`` (None: envfit's grid, --up)."""
    from envfit.data_gen._marker import MARKERS, marker_map
    from envfit.maps._latlong import pixel_directions
    if args.height < 2:
        raise ParameterError(f"--height must be at least 2, got {args.height}")
    radius = args.marker_radius if args.marker_radius is not None else 3.0 * np.pi / args.height
    dirs = (conv.pixel_directions(args.height) if conv is not None
            else pixel_directions(args.height, up=map_up(args)))
    try:
        f = marker_map(dirs, radius)
    except ValueError as exc:
        raise ParameterError(str(exc)) from None
    return f, {"kind": "marker", "height": args.height, "marker_radius": radius,
               "markers": {label: {"axis": list(axis), "colour": list(colour),
                                   "amplitude": amp} for label, axis, colour, amp in MARKERS}}


def run(args: argparse.Namespace) -> int:
    from envfit.maps._envmap import EnvMap
    from envfit.maps._io import save_envmap
    conv = map_convention(args)
    if args.kind == "marker":
        f, info = _marker(args, conv)
    else:
        f, info = synthesize(args)
        if conv is not None:      # synthesized on envfit's grid with conv's up, laid out as conv's
            f = conv.from_internal(EnvMap(np.asarray(f, dtype=np.float64), up=conv.up))
    name = f"synth:{args.kind}"
    # envfit:up names the world axis of the top row (the convention's, with --convention)
    env = EnvMap(np.asarray(f, dtype=np.float32), up=map_up(args), name=name)
    try:
        path = save_envmap(args.output, env, half=args.half)
    except EnvfitError:     # EnvMapFileError "…: write failed: …" says it all
        raise
    except OSError as exc:  # disk full, folder gone meanwhile (checked writable before)
        raise OutputError(f"could not write {args.output}: {os_reason(exc)}") from None
    info.update(path=str(path), width=env.width, channels=env.channels,
                convention=conv.name if conv is not None else None, up=map_up(args),
                min=float(f.min()), max=float(f.max()), mean=[float(x) for x in env.mean()])
    say(args, f"wrote {path}: {args.kind} map {env.width}x{env.height}, {env.channels} "
              f"channel(s)"
              + (f", s0 = {args.s0}" if args.kind == "gp" else "")
              + (f", {conv.name} layout (+{conv.up} up)" if conv is not None else ""))
    out = out_dir(args)
    if out is not None:           # the preview of what was written, in the file's layout
        from envfit.cli._info import write_preview
        internal = env if conv is None else conv.to_internal(env)
        png = write_preview(args, EnvMap(internal.data, up=internal.up, name=path.name), conv,
                            out, Path(path).stem)
        info["files"] = {"preview": None if png is None else str(png)}
    emit_json(args, info)
    return 0
