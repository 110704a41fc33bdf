"""``envfit info MAP``: size, channels, value statistics and loading notes of an environment map.

Statistics: per-channel minimum, maximum and solid-angle weighted mean; the dynamic range
``max Y / min positive Y`` of the luminance (also in stops, log2); the brightest pixel (by
luminance) with its row, column, world direction and local angles (θ from the up axis, φ).

With ``--convention C`` the file is read in renderer C's lat-long layout
(:mod:`envfit.maps._conventions`) and the brightest direction is also given in C's terms:
its polar angle θ from C's up axis, C's own azimuth (e.g. the blender layout's ``atan2(y, x)``, OpenEXR's
longitude ``atan2(x, z)``) and the continuous pixel ``(col, row)`` at which C looks that
direction up in the file (C's own formula; integers are pixel centres; sizes W×H).

Bright sources (the sun, lamps: connected regions above a robust threshold holding at least
5 % of the map's luminous power, :func:`envfit.maps._bright_sources.find_bright_sources`) are
listed with their direction, angles and pixel in the layout, equivalent solid angle and share
of the power (:func:`envfit.maps._preview.list_sources`).

With ``--out DIR``: ``DIR/<map>_preview.png``, the map tone-mapped (display scale) in the
file's layout with its axes in the layout's angles and the sources marked
(:func:`envfit.plots._preview.plot_map_preview`), and ``DIR/<map>_info.json``, the JSON of
``--json``.

Example::

    envfit info sky.exr --up y --max-height 512 --json info.json
    envfit info sky.exr --convention mitsuba3 --out preview/
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from envfit.maps import EnvMap
from envfit.maps import describe_envmap, list_sources
from envfit.cli._common import (add_common_arguments, add_map_arguments, load_map_from_args,
                                map_convention, out_dir)
from envfit.cli._output import CommandOutput


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "info", help="describe an environment map (size, channels, range, brightest direction)",
        description="Load a lat-long environment map (any format OpenImageIO reads) and print "
                    "its size, channels, per-channel min/max/solid-angle mean, dynamic range, "
                    "brightest direction, bright sources (direction, solid angle, share of the "
                    "power) and what loading changed. --out DIR: a preview PNG of the map in "
                    "its layout with the sources marked, and the JSON.")
    add_map_arguments(p, optional=False)
    add_common_arguments(p, seed=False)
    p.set_defaults(func=run)


def _fmt(v) -> str:
    return "[" + ", ".join(f"{x:.6g}" for x in np.asarray(v).ravel()) + "]"


def _convention_lines(c: dict | None, width: int, height: int) -> list[str]:
    if c is None:
        return []
    return [f"  in {c['name']} ({c['renderer']}, +{c['up']} up): theta {c['theta_deg']:.2f} deg "
            f"from +{c['up']}, {c['phi_is']} = {c['phi_deg']:.2f} deg; pixel (col, row) = "
            f"({c['col']:.2f}, {c['row']:.2f}) of the {width}x{height} file"]


def _source_lines(sources) -> list[str]:
    if not sources:
        return ["  bright sources (>= 5 % of the power): none"]
    return ["  bright sources (>= 5 % of the power), theta/phi/pixel in the layout above:",
            *(f"    {e.label()}; direction {_fmt(e.direction)}, pixel (col, row) = "
              f"({e.position['col']:.2f}, {e.position['row']:.2f})" for e in sources)]


def write_preview(output: CommandOutput, env: EnvMap, conv, out: Path, stem: str,
                  sources=None) -> Path | None:
    """``out/<stem>_preview.png`` of ``env`` in ``conv``'s layout (None: envfit's grid), the
    sources marked; a failed write is recorded (:meth:`CommandOutput.guarded_write`) and
    gives None."""
    from envfit.plots import plot_map_preview
    from envfit.maps import map_preview
    path = out / f"{stem}_preview.png"
    png = output.guarded_write(path, plot_map_preview, map_preview(env, conv, sources=sources), path)
    if png is not None:
        output.say(f"wrote {png}")
    return png


def run(args: argparse.Namespace, output: CommandOutput) -> int:
    from envfit.base import atomic_write_json
    m = load_map_from_args(args)
    conv = map_convention(args)
    out = out_dir(args)
    sources = list_sources(m, conv)
    info = describe_envmap(m, conv, sources)
    info["path"] = str(args.map)
    b = info["brightest"]
    dr = info["dynamic_range"]
    output.say(
               f"{args.map}: {info['width']}x{info['height']} lat-long, {info['channels']} channel(s), "
               f"up={info['up']}",
               f"  min   {_fmt(info['min'])}",
               f"  max   {_fmt(info['max'])}",
               f"  mean  {_fmt(info['mean'])}  (solid-angle weighted)",
               f"  luminance: mean {info['mean_luminance']:.6g}, max {info['max_luminance']:.6g}, "
               + (f"dynamic range {dr:.4g}:1 ({info['dynamic_range_stops']:.1f} stops)" if dr
           else "dynamic range undefined (no positive pixel)"),
               f"  brightest pixel: row {b['row']}, col {b['col']}, direction {_fmt(b['direction'])} "
               f"(theta {b['theta_deg']:.2f} deg from up, phi {b['phi_deg']:.2f} deg)",
               *_convention_lines(b["convention"], info["width"], info["height"]),
               *_source_lines(sources),
               *(f"  note: {n}" for n in info["notes"]))
    if out is not None:
        stem = Path(args.map).stem if args.map else "builtin"
        png = write_preview(output, m, conv, out, stem, sources)
        info["files"] = {"preview": None if png is None else str(png),
                         "json": str(out / f"{stem}_info.json")}
        if output.guarded_write(out / f"{stem}_info.json", atomic_write_json,
                                out / f"{stem}_info.json", info) is not None:
            output.say(f"wrote {out / f'{stem}_info.json'}")
    output.emit_json(info)
    return 0
