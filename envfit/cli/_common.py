"""Options every subcommand shares (``--json``, ``--out``, ``--seed``, ``--quiet``), strict
argument types, the preflight of outputs and the output helpers.

Parsing is strict (argparse ``type=`` functions, so a bad value is one error line, exit 2:
``envfit CMD: error: argument --n: 100.5 is not a whole number (see 'envfit CMD --help')``): an integer option takes a whole number only — written ``100``, or in decimal
or scientific notation when its value is exactly whole (``1e3`` and ``100.0`` are 1000 and
100; ``100.5``, ``1e-3``, ``nan``, ``inf`` are refused) — within its range (``--n`` ≥ 1,
``--seed`` ≥ 0, …); a list (``--s 1.1,1.5``, ``--n 100,500``) must be non-empty, without an
empty entry, NaN/inf or a repeated value.

Outputs are checked before any work (:func:`preflight_outputs`, called by ``main`` for every
subcommand); a write that fails after the work is recorded by the run's
:class:`~envfit.cli._output.CommandOutput` (``guarded_write``, ``emit_json``) instead of
raised, so the results are still printed, and ``main`` then names what could not be
written and exits 2.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from envfit.base import check_writable_dir, check_writable_file
from envfit.base import NoteKind
from envfit.defaults import EXECUTORS, UPS
from envfit.cli._output import CommandOutput
from envfit.cli._overlap import check_no_overlap
from envfit.cli._parse import check_unique, nonneg_int, parse_finite, positive_int, split_items

#: ``--help`` of ``--convention`` (the names are those of envfit.maps._conventions.CONVENTIONS)
CONVENTION_HELP = (
    "the renderer whose lat-long layout the MAP file has: envfit (= --up y), openexr "
    "(ImfEnvmap LatLongMap: +y up, first/last row on the poles, first/last column on "
    "longitude +-pi), usd (DomeLight: = openexr), mitsuba3 (+y up, rows on the poles, "
    "theta = pi i/(H-1)), pbrt3 (+z up, = --up z), blender (+z up, mirrored: "
    "u = 1/2 - atan2(y,x)/2pi); pbrt4 is refused (equal-area square maps). The map is "
    "converted to envfit's grid (exactly where only pixels move, else bilinear). Not with "
    "--up; one map at a time")


# ------------------------------------------------------------------ strict argument types
def float_list(text: str) -> list[float]:
    """Parse ``"1.1,1.5,1.9"`` into distinct finite floats (argparse ``type=``); an empty
    list, an empty entry, NaN/inf or a repeated value is an error.

    >>> float_list("1.1, 1.5")
    [1.1, 1.5]
    """
    items = split_items(text)
    return check_unique([parse_finite(x) for x in items], items, str(text))


def colour_list(text: str) -> list[float]:
    """Parse a colour ``"1"`` or ``"0.2,0.2,0.9"`` into finite floats (repeats allowed)."""
    return [parse_finite(x) for x in split_items(text)]


def int_list(text: str) -> list[int]:
    """Parse ``"100,500,1000"`` into distinct positive whole numbers (argparse ``type=``);
    ``1e3`` is 1000; ``100.5``, an empty list, an empty entry or a repeat is an error.

    >>> int_list("100,1e3")
    [100, 1000]
    """
    items = split_items(text)
    return check_unique([positive_int(x) for x in items], items, str(text))


def nonneg_int_list(text: str) -> list[int]:
    """As :func:`int_list`, with 0 allowed (cut-off degrees ``--sh-L 0,1,2``)."""
    items = split_items(text)
    return check_unique([nonneg_int(x) for x in items], items, str(text))


def str_list(text: str) -> list[str]:
    """Parse ``"sf,sobol"`` into names; an empty list is an error (repeats are merged by the
    pipelines' checks)."""
    items = [x.strip() for x in str(text).split(",") if x.strip()]
    if not items:
        raise argparse.ArgumentTypeError("empty list; give comma-separated names")
    return items


# ------------------------------------------------------------------ shared options
def add_common_arguments(p: argparse.ArgumentParser, *, seed: bool = True) -> None:
    """Add ``--json FILE``, ``--out DIR``, ``--seed``, ``--quiet`` to a subcommand parser."""
    g = p.add_argument_group("output")
    g.add_argument("--json", metavar="FILE", type=Path, default=None,
                   help="write the machine-readable result to FILE ('-' for stdout)")
    g.add_argument("--out", metavar="DIR", type=Path, default=None,
                   help="folder for plots, CSV and images")
    if seed:
        g.add_argument("--seed", type=nonneg_int, default=0, help="random seed (default: 0)")
    g.add_argument("--quiet", "-q", action="store_true",
                   help="no progress bars, tables or notes: only advise's answer line, nothing "
                        "from the other commands (their results: --json, --out)")


# ------------------------------------------------------------------ preflight of outputs
def preflight_outputs(args: argparse.Namespace, output: CommandOutput) -> None:
    """Check every output of the command *before* any work; ``main`` calls it for every
    subcommand. Raises :class:`envfit.base._errors.OutputError` (one line, exit 2) for:

    * an output that names an input (resolved: symlinks and hard links included), lies where
      it would be read as one, or two outputs naming one file
      (:func:`envfit.cli._overlap.check_no_overlap`; checked first, before anything is made);
    * ``--out`` (or the command's default folder ``out_default``): created if missing, and a
      temporary file created and removed inside;
    * ``--json FILE`` (``-`` = stdout passes) and synth's ``OUT.exr`` (``args.output``): not a
      folder, nearest existing parent folder writable;

    raises :class:`envfit.base._errors.ParameterError` for a bad ``--convention``
    (:func:`map_convention`), and says a note of kind ``NoteKind.CACHE_OFF`` on stderr
    (:meth:`CommandOutput.note`) if the advisor cache (``--cache-dir`` or the default; not
    with ``--no-cache``) cannot be written: the results are then not cached, which is no
    error.
    """
    map_convention(args)                # --convention: a known name, not with --up
    out = getattr(args, "out", None)
    if out is None:
        out = getattr(args, "out_default", None)
    check_no_overlap(args, out, advisor_cache_dir(args))   # no output names an input
    if out is not None:
        check_writable_dir(out, "--out")
    if getattr(args, "json", None) is not None:
        check_writable_file(args.json, "--json")
    if getattr(args, "output", None) is not None:
        check_writable_file(args.output, getattr(args, "output_metavar", "output"))
    if hasattr(args, "cache_dir") and not getattr(args, "no_cache", False):
        from envfit.advisor import cache_write_problem
        problem = cache_write_problem(args.cache_dir)
        if problem:  # "the advisor cache … is not writable (…); advise works without it …"
            output.note(NoteKind.CACHE_OFF, problem)


def advisor_cache_dir(args: argparse.Namespace):
    """The advisor cache folder the command writes (``--cache-dir`` or the default), or None
    (no cache option, or ``--no-cache``)."""
    if not hasattr(args, "cache_dir") or getattr(args, "no_cache", False):
        return None
    if args.cache_dir is not None:
        return args.cache_dir
    from envfit.advisor import default_cache_dir
    return default_cache_dir()


# ------------------------------------------------------------------ folders and maps
def out_dir(args: argparse.Namespace, default: str | None = None) -> Path | None:
    """The ``--out`` folder (created and checked writable), or ``default`` if given, else None."""
    d = args.out if args.out is not None else (Path(default) if default else None)
    if d is not None:
        check_writable_dir(d, "--out")
    return d


def add_map_arguments(p: argparse.ArgumentParser, *, optional: bool = True, many: bool = False) -> None:
    """The MAP positional and the loading options shared by every command that reads a map."""
    nargs = "*" if many else ("?" if optional else None)
    p.add_argument("map", metavar="MAP", nargs=nargs, default=None,
                   help="lat-long HDR map (EXR, HDR, PNG, … anything OpenImageIO reads)"
                        + ("; without it, the built-in synthesized default map" if optional else ""))
    g = p.add_argument_group("map loading")
    g.add_argument("--up", choices=UPS, default=None,
                   help="which world axis is the map's top row, on envfit's pixel grid "
                        "(centres at theta = pi(i+1/2)/H, phi = 2pi(j+1/2)/W; default: y, "
                        "OpenEXR's orientation); not with --convention")
    g.add_argument("--convention", metavar="NAME", default=None,
                   help=CONVENTION_HELP)
    g.add_argument("--max-height", type=positive_int, default=None, metavar="H",
                   help="downscale the map (scikit-image, anti-aliased) to at most H rows")
    g.add_argument("--fix-nonfinite", action="store_true",
                   help="replace NaN/Inf pixels instead of refusing the map (reported)")
    g.add_argument("--allow-negative", action="store_true",
                   help="keep negative pixel values instead of clamping them to 0 (reported)")


def map_convention(args: argparse.Namespace):
    """The :mod:`envfit.maps._conventions` entry ``--convention`` names, or None.

    :class:`ParameterError` (one line, exit 2) for an unknown name, for ``--convention``
    together with ``--up`` (the convention fixes the up axis), and for a layout that is not
    lat-long (:class:`~envfit.maps._conventions.NotLatLong`). ``main`` runs it before any work (:func:`preflight_outputs`).
    """
    from envfit.base import ParameterError
    from envfit.maps import NotLatLong, convention
    name = getattr(args, "convention", None)
    if name is None:
        return None
    conv = convention(name)
    if getattr(args, "up", None) is not None:
        raise ParameterError(f"--up {args.up} and --convention {conv.name} exclude each other: "
                             f"the convention fixes the up axis (+{getattr(conv, 'up', '?')}); "
                             "--up is envfit's own grid with that axis up")
    if isinstance(conv, NotLatLong):
        conv.to_internal(None)          # raises its one-line reason
    return conv


def map_up(args: argparse.Namespace) -> str:
    """The up axis of the maps the command reads: ``--up``, the convention's, or ``"y"``."""
    conv = map_convention(args)
    if conv is not None:
        return conv.up
    return getattr(args, "up", None) or "y"


def max_height_of(args: argparse.Namespace, quick_height: int | None = None) -> int | None:
    """``--max-height``, or ``quick_height`` when it is not given and ``--quick`` is (the
    command's quick default: table2 128 rows, validate 256)."""
    if args.max_height is None and getattr(args, "quick", False):
        return quick_height
    return args.max_height


def load_map_from_args(args: argparse.Namespace, path=None, *, quick_height: int | None = None):
    """Load ``path`` (default ``args.map``; fit and table2's one-element MAP list is its
    element) with the loading options, or the built-in map if there is none.

    :func:`envfit.maps._io.load_envmap` with ``convention`` and ``max_height``
    (:func:`max_height_of`): with ``--convention C`` the file's pixels are read in C's layout
    and converted to envfit's convention (exact where only pixels move, else bilinear),
    *before* ``--max-height``; the built-in map is synthesized with C's up axis.
    """
    from envfit.maps import default_envmap
    from envfit.maps import load_envmap
    conv = map_convention(args)
    height = max_height_of(args, quick_height)
    path = args.map if path is None else path
    if isinstance(path, list):
        path = path[0] if path else None
    if path is not None:
        return load_envmap(path, up=None if conv is not None else map_up(args), convention=conv,
                           allow_negative=args.allow_negative,
                           fix_nonfinite=args.fix_nonfinite, max_height=height)
    env = default_envmap(up=map_up(args))
    if height:
        env = env.resized(height)
    return env


def add_executor_arguments(p: argparse.ArgumentParser) -> None:
    """``--executor``, ``--scheduler``, ``--workers``: where a library sweep runs."""
    g = p.add_argument_group("execution (several maps: one factorisation per s serves them all)")
    g.add_argument("--executor", choices=EXECUTORS, default=None,
                   help="local: this machine's cores (a process pool, BLAS threads pinned per "
                        "worker; the default); dask: a dask.distributed cluster "
                        '(pip install "envfit[dask]")')
    g.add_argument("--scheduler", metavar="tcp://HOST:PORT", default=None,
                   help="address of a running dask scheduler (default with --executor dask: "
                        "a LocalCluster on this machine); each handshake with it waits at "
                        "most ENVFIT_DASK_TIMEOUT seconds (default 10)")
    from envfit.cli._ranges import workers_range
    workers = workers_range()
    g.add_argument("--workers", type=workers, default=None, metavar="K",
                   help=f"worker processes for local/LocalCluster, {workers} (this machine's "
                        "cores: more would only share them); default: as many as useful, at "
                        "most the cores; fewer where the tasks' memory does not fit the budget "
                        "(said in a note)")


def library_mode(args: argparse.Namespace) -> bool:
    """Several maps, a folder or a pattern, or executor options: the library engine.

    One existing file without executor options keeps the single-map behaviour and output.
    """
    maps = args.map or []
    if args.executor is not None or args.scheduler is not None or args.workers is not None:
        return True
    return len(maps) > 1 or (len(maps) == 1 and not Path(maps[0]).is_file()
                             and (Path(maps[0]).is_dir() or any(c in str(maps[0]) for c in "*?[")))


def library_maps(args: argparse.Namespace, *, quick_height: int | None = None) -> list:
    """What the library engine runs on: the MAP arguments, or the built-in map if none."""
    if args.map:
        return list(args.map)
    return [load_map_from_args(args, quick_height=quick_height)]


def load_options_from_args(args: argparse.Namespace, *, quick_height: int | None = None):
    """The map-loading options of ``args`` as :class:`envfit.maps._lazy_maps.LoadOptions`
    (``max_height``: :func:`max_height_of`)."""
    from envfit.base import ParameterError
    from envfit.maps import LoadOptions
    conv = map_convention(args)
    if conv is not None and not conv.is_envfit_grid:
        raise ParameterError(f"--convention {conv.name} reads one map at a time; several maps "
                             "(a folder, a pattern, --executor) are read on envfit's grid: "
                             "convert them first, or run the command once per map")
    return LoadOptions(up=map_up(args), max_height=max_height_of(args, quick_height),
                       fix_nonfinite=args.fix_nonfinite, allow_negative=args.allow_negative)


def executor_kwargs(args: argparse.Namespace) -> dict:
    """``executor``, ``workers``, ``scheduler`` for the library functions."""
    from envfit.batch import check_executor_choice
    kind = args.executor or ("dask" if args.scheduler else "local")
    check_executor_choice(kind, args.workers, args.scheduler)       # before any map is read
    return {"executor": kind, "workers": args.workers, "scheduler": args.scheduler}
