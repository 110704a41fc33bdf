"""Options every subcommand shares (``--json``, ``--out``, ``--seed``, ``--quiet``) and output helpers."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from ..atomic import atomic_write_json, to_jsonable
from ..errors import ParameterError


def add_common_arguments(p: argparse.ArgumentParser, *, seed: bool = True) -> None:
    """Add ``--json FILE``, ``--out DIR``, ``--seed``, ``--quiet`` to a subcommand parser."""
    g = p.add_argument_group("output")
    g.add_argument("--json", metavar="FILE", type=Path, default=None,
                   help="write the machine-readable result to FILE ('-' for stdout)")
    g.add_argument("--out", metavar="DIR", type=Path, default=None,
                   help="folder for plots, CSV and images")
    if seed:
        g.add_argument("--seed", type=int, default=0, help="random seed (default: 0)")
    g.add_argument("--quiet", "-q", action="store_true", help="no progress bars or tables")


def emit_json(args: argparse.Namespace, result: dict[str, Any]) -> None:
    """Write ``result`` where ``--json`` says (atomically), or to stdout for ``--json -``."""
    if args.json is None:
        return
    if str(args.json) == "-":
        json.dump(to_jsonable(result), sys.stdout, indent=2)
        sys.stdout.write("\n")
    else:
        atomic_write_json(args.json, result)


def say(args: argparse.Namespace, *lines: str) -> None:
    """Print human-readable lines unless ``--quiet`` (or ``--json -`` owns stdout)."""
    if getattr(args, "quiet", False) or str(getattr(args, "json", "")) == "-":
        return
    for line in lines:
        print(line)


def float_list(text: str) -> list[float]:
    """Parse ``"1.1,1.5,1.9"`` into floats (argparse ``type=``)."""
    try:
        return [float(x) for x in str(text).split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None


def int_list(text: str) -> list[int]:
    """Parse ``"100,500,1000"`` into ints (argparse ``type=``)."""
    try:
        return [int(float(x)) for x in str(text).split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}") from None


def str_list(text: str) -> list[str]:
    return [x.strip() for x in str(text).split(",") if x.strip()]


def out_dir(args: argparse.Namespace, default: str | None = None) -> Path | None:
    """The ``--out`` folder (created), or ``default`` if given, else None."""
    d = args.out if args.out is not None else (Path(default) if default else None)
    if d is not None:
        if d.exists() and not d.is_dir():
            raise ParameterError(f"--out {d} exists and is not a folder")
        d.mkdir(parents=True, exist_ok=True)
    return d


def add_map_arguments(p: argparse.ArgumentParser, *, optional: bool = True, many: bool = False) -> None:
    """The MAP positional and the loading options shared by every command that reads a map."""
    nargs = "*" if many else ("?" if optional else None)
    p.add_argument("map", metavar="MAP", nargs=nargs, default=None,
                   help="lat-long HDR map (EXR, HDR, PNG, … anything OpenImageIO reads)"
                        + ("; without it, the built-in synthesized default map" if optional else ""))
    g = p.add_argument_group("map loading")
    g.add_argument("--up", choices=("y", "z", "x"), default="y",
                   help="which world axis is the map's top row (default: y, as OpenEXR)")
    g.add_argument("--max-height", type=int, default=None, metavar="H",
                   help="downscale the map (scikit-image, anti-aliased) to at most H rows")
    g.add_argument("--fix-nonfinite", action="store_true",
                   help="replace NaN/Inf pixels instead of refusing the map (reported)")
    g.add_argument("--allow-negative", action="store_true",
                   help="keep negative pixel values instead of clamping them to 0 (reported)")


def load_map_from_args(args: argparse.Namespace, path=None):
    """Load ``path`` (default ``args.map``) with the loading options, or the built-in map."""
    from ..default_map import default_envmap
    from ..envmap import load_envmap
    path = args.map if path is None else path
    if path is None:
        env = default_envmap(up=args.up)
        if args.max_height:
            env = env.resized(args.max_height)
        return env
    return load_envmap(path, up=args.up, allow_negative=args.allow_negative,
                       fix_nonfinite=args.fix_nonfinite, max_height=args.max_height)


def add_executor_arguments(p: argparse.ArgumentParser) -> None:
    """``--executor``, ``--scheduler``, ``--workers``: where a library sweep runs."""
    g = p.add_argument_group("execution (several maps: one factorisation per s serves them all)")
    g.add_argument("--executor", choices=("local", "dask"), default=None,
                   help="local: this machine's cores (a process pool, BLAS threads pinned per "
                        "worker; the default); dask: a dask.distributed cluster "
                        '(pip install "envfit[dask]")')
    g.add_argument("--scheduler", metavar="tcp://HOST:PORT", default=None,
                   help="address of a running dask scheduler (default with --executor dask: "
                        "a LocalCluster on this machine)")
    g.add_argument("--workers", type=int, default=None, metavar="K",
                   help="worker processes for local/LocalCluster (default: as many as useful, "
                        "at most the cores, within the memory budget)")


def library_mode(args: argparse.Namespace) -> bool:
    """Several maps, a folder or a pattern, or executor options: the library engine.

    One existing file without executor options keeps the single-map behaviour and output.
    """
    maps = args.map or []
    if args.executor is not None or args.scheduler is not None or args.workers is not None:
        return True
    return len(maps) > 1 or (len(maps) == 1 and not Path(maps[0]).is_file()
                             and (Path(maps[0]).is_dir() or any(c in str(maps[0]) for c in "*?[")))


def library_maps(args: argparse.Namespace) -> list:
    """What the library engine runs on: the MAP arguments, or the built-in map if none."""
    if args.map:
        return list(args.map)
    args.map = None
    return [load_map_from_args(args)]


def load_options_from_args(args: argparse.Namespace):
    """The map-loading options of ``args`` as :class:`envfit.mapsource.LoadOptions`."""
    from ..mapsource import LoadOptions
    return LoadOptions(up=args.up, max_height=args.max_height, fix_nonfinite=args.fix_nonfinite,
                       allow_negative=args.allow_negative)


def executor_kwargs(args: argparse.Namespace) -> dict:
    """``executor``, ``workers``, ``scheduler`` for the library functions."""
    kind = args.executor or ("dask" if args.scheduler else "local")
    return {"executor": kind, "workers": args.workers, "scheduler": args.scheduler}
