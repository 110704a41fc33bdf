"""``envfit advise DIR | GLOB | FILE… --renderer NAME``: a library of maps advised in the
renderer's terms (:func:`envfit.batch._library_advise.advise_library`): one row per map, the spp
that meets the target on 50/90/100 % of the maps, and with ``--out`` the table as CSV and
JSON, a PNG and the resumable store of finished maps.

Library mode is taken for several maps, a folder, a glob pattern or an executor option
(``--executor``, ``--scheduler``, ``--workers``), as for ``table2`` and ``fit``
(:func:`envfit.cli._common.library_mode`). The options that describe one map's answer are
refused with it in one line, before any map is read: ``--snippet`` (a scene names one map
file), ``--rules`` and ``--check`` (envfit's rule tables), and no ``--renderer``.
"""
from __future__ import annotations

import argparse

from envfit.base import ParameterError
from envfit.cli._common import executor_kwargs, load_options_from_args, out_dir
from envfit.cli._output import CommandOutput

__all__ = ["run_library", "check_library", "LIBRARY_REFUSED"]

#: one map's options (dest → flag) that a library run refuses, and why
LIBRARY_REFUSED = {"snippet": ("--snippet", "a scene names one map file: run advise on that "
                               "map with --snippet"),
                   "rules": ("--rules", "envfit's rule tables are for one map"),
                   "check": ("--check", "envfit's rule tables are for one map")}


def check_library(args: argparse.Namespace) -> None:
    """One line (:class:`ParameterError`) for a library run's refused options, before any map
    is read."""
    if args.renderer is None:
        from envfit.renderers import RENDERERS
        raise ParameterError(f"several maps (a folder, a pattern, --executor/--workers) are "
                             f"advised in a renderer's terms: give --renderer "
                             f"({', '.join(RENDERERS)}); envfit's rule tables take one map")
    for dest, (flag, why) in LIBRARY_REFUSED.items():
        if getattr(args, dest, False):
            raise ParameterError(f"{flag} is not taken with several maps: {why}")


def run_library(args: argparse.Namespace, output: CommandOutput, popts) -> int:
    """The library run of ``envfit advise``: checked options → maps → rows → files."""
    from envfit.batch import advise_library
    from envfit.base import atomic_write_csv, atomic_write_json
    from envfit.batch import LibraryOptions
    check_library(args)
    out = out_dir(args)
    library = LibraryOptions(load_options=load_options_from_args(args), quiet=args.quiet,
                             **executor_kwargs(args))

    def on_map(row):
        if row.resumed:
            output.say(f"  {row.label}: resumed from {out}")

    lib = advise_library(args.map, popts, target_rmse=args.target_rmse,
                         target_relative=args.target_relative, library=library, out=out,
                         cache=not args.no_cache, cache_dir=args.cache_dir, on_map=on_map)
    output.say(*(f"note: {n}" for n in lib.notes), *lib.table_lines(),
               f"({lib.seconds:.1f} s: {lib.computed} map(s) computed, {lib.resumed} resumed"
               + (f", on {lib.executor})" if lib.executor else ")"))
    output.answer(*lib.table_lines()[-len(lib.coverage):])     # --quiet: the coverage lines
    d = lib.to_dict()
    if out is not None:
        from envfit.plots import plot_advise_library
        cols, rows = lib.csv_rows()
        written = [output.guarded_write(out / "advise_library.csv", atomic_write_csv,
                                        out / "advise_library.csv", cols, rows),
                   output.guarded_write(out / "advise_library.json", atomic_write_json,
                                        out / "advise_library.json", d),
                   output.guarded_write(out / "advise_library.png", plot_advise_library, d,
                                        out / "advise_library.png")]
        d["files"] = lib.files = [str(p) for p in written if p is not None]
        if d["files"]:
            output.say("wrote " + ", ".join(d["files"]))
    output.emit_json(d)
    return 0
