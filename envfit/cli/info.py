"""``envfit info MAP``: size, channels, value statistics and loading notes of an environment map.

Statistics: per-channel minimum, maximum and solid-angle weighted mean; the dynamic range
``max Y / min positive Y`` of the luminance (also in stops, log2); the brightest pixel (by
luminance) with its row, column, world direction and local angles (θ from the up axis, φ).

With ``--convention C`` the file is read in renderer C's lat-long layout
(:mod:`envfit.maps.conventions`) and the brightest direction is also given in C's terms:
its polar angle θ from C's up axis, C's own azimuth (e.g. Cycles' ``atan2(y, x)``, OpenEXR's
longitude ``atan2(x, z)``) and the continuous pixel ``(col, row)`` at which C looks that
direction up in the file (C's own formula; integers are pixel centres; sizes W×H).

Example::

    envfit info sky.exr --up y --max-height 512 --json info.json
    envfit info sky.exr --convention mitsuba3
"""
from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from envfit.maps.conventions import LatLongConvention
from envfit.maps.envmap import EnvMap
from envfit.maps.latlong import pixel_angles, pixel_to_direction, row_solid_angles
from .common import (add_common_arguments, add_map_arguments, emit_json, load_map_from_args,
                     map_convention, say)


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "info", help="describe an environment map (size, channels, range, brightest direction)",
        description="Load a lat-long environment map (any format OpenImageIO reads) and print "
                    "its size, channels, per-channel min/max/solid-angle mean, dynamic range, "
                    "brightest direction and what loading changed.")
    add_map_arguments(p, optional=False)
    add_common_arguments(p, seed=False)
    p.set_defaults(func=run)


def in_convention(conv: LatLongConvention, direction, width: int, height: int) -> dict[str, Any]:
    """A world direction in a renderer's terms: θ from its up axis, its own azimuth, and the
    continuous pixel (col, row) of a ``width x height`` file in its layout (JSON-ready).

    >>> from envfit.maps.conventions import convention
    >>> v = in_convention(convention("pbrt3"), [0.0, 0.0, 1.0], 8, 4)
    >>> v["theta_deg"], v["col"], v["row"]
    (0.0, -0.5, -0.5)
    """
    theta, phi = conv.angles(direction)
    row, col = conv.direction_to_pixel(direction, height, width)
    return {"name": conv.name, "renderer": conv.renderer, "up": conv.up,
            "theta_deg": float(np.degrees(theta)), "phi_deg": float(np.degrees(phi)),
            "phi_is": conv.azimuth_label, "col": float(col), "row": float(row),
            "source": conv.source}


def describe_envmap(m: EnvMap, conv: LatLongConvention | None = None) -> dict[str, Any]:
    """The statistics ``envfit info`` reports, as a JSON-ready dict (with ``conv``: the
    brightest direction also in that renderer's terms, :func:`in_convention`)."""
    data = m.data
    y = m.luminance()
    flat = int(np.argmax(y))
    row, col = divmod(flat, m.width)
    theta, phi = pixel_angles(m.height, m.width)
    direction = pixel_to_direction(row, col, m.height, m.width, up=m.up)
    om = row_solid_angles(m.height, m.width)
    pos = y[y > 0]
    ymax = float(y.max())
    dr = float(ymax / pos.min()) if pos.size else None
    return {
        "name": m.name,
        "width": m.width,
        "height": m.height,
        "channels": m.channels,
        "dtype": str(data.dtype),
        "up": m.up,
        "min": data.min(axis=(0, 1)).astype(np.float64),
        "max": data.max(axis=(0, 1)).astype(np.float64),
        "mean": m.mean(),
        "mean_luminance": float(om @ y.sum(axis=1) / (om.sum() * m.width)),
        "max_luminance": ymax,
        "dynamic_range": dr,
        "dynamic_range_stops": float(np.log2(dr)) if dr else None,
        "brightest": {
            "row": int(row), "col": int(col),
            "direction": direction,
            "theta_deg": float(np.degrees(theta[row])),
            "phi_deg": float(np.degrees(phi[col])),
            "value": data[row, col].astype(np.float64),
            "convention": (in_convention(conv, direction, m.width, m.height)
                           if conv is not None else None),
        },
        "notes": list(m.notes),
    }


def _fmt(v) -> str:
    return "[" + ", ".join(f"{x:.6g}" for x in np.asarray(v).ravel()) + "]"


def _convention_lines(c: dict | None, width: int, height: int) -> list[str]:
    if c is None:
        return []
    return [f"  in {c['name']} ({c['renderer']}, +{c['up']} up): theta {c['theta_deg']:.2f} deg "
            f"from +{c['up']}, {c['phi_is']} = {c['phi_deg']:.2f} deg; pixel (col, row) = "
            f"({c['col']:.2f}, {c['row']:.2f}) of the {width}x{height} file"]


def run(args: argparse.Namespace) -> int:
    m = load_map_from_args(args)
    conv = map_convention(args)
    info = describe_envmap(m, conv)
    info["path"] = str(args.map)
    b = info["brightest"]
    dr = info["dynamic_range"]
    say(args,
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
        *(f"  note: {n}" for n in info["notes"]))
    emit_json(args, info)
    return 0
