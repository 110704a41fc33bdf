"""``envfit info MAP``: size, channels, value statistics and loading notes of an environment map.

Statistics: per-channel minimum, maximum and solid-angle weighted mean; the dynamic range
``max Y / min positive Y`` of the luminance (also in stops, log2); the brightest pixel (by
luminance) with its row, column, world direction and local angles (θ from the up axis, φ).

Example::

    envfit info sky.exr --up y --max-height 512 --json info.json
"""
from __future__ import annotations

import argparse
from typing import Any

import numpy as np

from envfit.maps.envmap import EnvMap
from envfit.maps.latlong import pixel_angles, pixel_to_direction, row_solid_angles
from .common import (add_common_arguments, add_map_arguments, emit_json, load_map_from_args,
                     say)


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "info", help="describe an environment map (size, channels, range, brightest direction)",
        description="Load a lat-long environment map (any format OpenImageIO reads) and print "
                    "its size, channels, per-channel min/max/solid-angle mean, dynamic range, "
                    "brightest direction and what loading changed.")
    add_map_arguments(p, optional=False)
    add_common_arguments(p, seed=False)
    p.set_defaults(func=run)


def describe_envmap(m: EnvMap) -> dict[str, Any]:
    """The statistics ``envfit info`` reports, as a JSON-ready dict."""
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
        },
        "notes": list(m.notes),
    }


def _fmt(v) -> str:
    return "[" + ", ".join(f"{x:.6g}" for x in np.asarray(v).ravel()) + "]"


def run(args: argparse.Namespace) -> int:
    m = load_map_from_args(args)
    info = describe_envmap(m)
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
        *(f"  note: {n}" for n in info["notes"]))
    emit_json(args, info)
    return 0
