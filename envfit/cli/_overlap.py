"""No output may name an input: the check :func:`envfit.cli._common.preflight_outputs` runs for
every command before any work (issue 22, item 4).

Inputs are the MAP arguments as the commands read them: a file, the map files directly inside
a folder (:data:`envfit.maps._lazy_maps.MAP_EXTENSIONS`), the files a glob pattern matches.
Outputs are ``--json FILE``, synth's ``OUT.exr``, the ``--out`` folder (or the command's
default folder) with the files the command writes there (:data:`OUT_FILES`), and the advisor
cache folder. Two paths are the same file when their resolved paths (``os.path.realpath``:
symlinks followed) are equal or, for files that exist, their ``(st_dev, st_ino)`` are
(hard links). Refused, each as one line (:class:`envfit.base._errors.OutputError`):

* an output file that is an input file (``envfit info map.exr --json map.exr``);
* an output folder that is an input file, or that is a folder given as MAP (what is written
  there, e.g. a library's PNG summary, would be read as a map by the next run);
* an output file with a map extension directly inside a folder given as MAP, or one a MAP
  glob pattern would list (the same);
* an input file inside the ``--out`` folder under a name the command writes there
  (``envfit sh sh.png --out .`` would replace the map by the plot);
* two outputs naming one file (``envfit synth OUT.exr --json OUT.exr``, or ``--json`` naming a
  file the command writes into ``--out``).
"""
from __future__ import annotations

import argparse
import fnmatch
import glob
import os
from pathlib import Path

from envfit.base import OutputError

#: files a run of a store-backed command (resumable cells) writes into its folders
_STORE = (".envfit.lock*", "*/.envfit.lock*", "*_config.json", "cells/*", "*/cells/*")

#: command -> patterns (``fnmatch``, ``*`` spans folders) of the files it writes under --out,
#: relative to that folder; a callable takes the parsed arguments
OUT_FILES = {
    "info": lambda a: (f"{_stem(getattr(a, 'map', None), 'builtin')}_preview.png",
                       f"{_stem(getattr(a, 'map', None), 'builtin')}_info.json"),
    "synth": lambda a: (f"{_stem(a.output, 'synth')}_preview.png",),
    "sh": ("sh.png", "sh.json", "sh.csv", "sh.glsl", "ringing.csv"),
    "advise": ("advise.png", "advise_rules.png", "advise.csv", "advise.json"),
    "fit": _STORE + ("fit_*.png", "library_fit.csv", "library_fit.json", "library_fit_s.png"),
    "table2": _STORE + ("table2.csv", "table2_rmse.png", "reconstruction_s*.exr",
                        "reconstruction_s*.png", "library_table2.csv", "library_table2.json",
                        "library_summary.csv", "library_s_best.png", "*/table2.csv",
                        "*/reconstruction_s*.exr", "*/reconstruction_s*.png"),
    "validate": _STORE + ("validate.json", "validate_*.png", "report.md", "renderer.png"),
    "theory wce": ("wce_spectrum.csv", "wce_spectrum.png"),
    "theory table1": ("table1.csv", "table1.png", "table1_wce_by_L.csv"),
    "theory figures": ("fig[1-5]_*.png", "fig[1-5]_*.csv", "bnot_spectrum.png",
                       "bnot_spectrum.csv"),
}


def _stem(path, default: str) -> str:
    if isinstance(path, (list, tuple)):
        path = path[0] if len(path) == 1 else None
    return Path(str(path)).stem if path else default


class _Entry:
    """A path with its resolved form and, if it exists, its (st_dev, st_ino)."""

    def __init__(self, label: str, path) -> None:
        self.label, self.path = label, str(path)
        self.real = os.path.realpath(self.path)
        try:
            st = os.stat(self.path)
            self.inode = (st.st_dev, st.st_ino)
            self.is_dir = os.path.isdir(self.path)
        except (OSError, ValueError):
            self.inode, self.is_dir = None, False

    def same(self, other: "_Entry") -> bool:
        return self.real == other.real or (self.inode is not None and self.inode == other.inode)

    def __str__(self) -> str:
        return f"{self.label} {self.path}" if self.label else self.path


def _input_entries(args: argparse.Namespace) -> tuple[list[_Entry], list[_Entry]]:
    """(input files, input folders) of the MAP argument(s); missing ones are left to the
    command (which reports them in one line)."""
    from envfit.maps import MAP_EXTENSIONS
    maps = getattr(args, "map", None)
    items = [] if maps is None else ([maps] if isinstance(maps, (str, os.PathLike)) else maps)
    files, folders = [], []
    for item in map(str, items):
        if os.path.isdir(item):
            folders.append(_Entry("MAP", item))
            try:
                names = sorted(os.listdir(item))
            except OSError:
                continue
            files += [_Entry("MAP", os.path.join(item, n)) for n in names
                      if Path(n).suffix.lower() in MAP_EXTENSIONS
                      and os.path.isfile(os.path.join(item, n))]
        elif os.path.exists(item):
            files.append(_Entry("MAP", item))
        elif any(c in item for c in "*?["):
            files += [_Entry("MAP", f) for f in sorted(glob.glob(item)) if os.path.isfile(f)]
    return files, folders


def _patterns(args: argparse.Namespace) -> list[str]:
    """The MAP arguments that are glob patterns (not existing paths)."""
    maps = getattr(args, "map", None)
    items = [] if maps is None else ([maps] if isinstance(maps, (str, os.PathLike)) else maps)
    return [str(i) for i in items if not os.path.exists(str(i)) and any(c in str(i)
                                                                         for c in "*?[")]


def _matches_pattern(path: _Entry, pattern: str) -> bool:
    """Whether ``glob.glob(pattern)`` would list ``path`` once it exists (same folder, the
    name matching the pattern's last part)."""
    folder, name = os.path.split(os.path.abspath(pattern))
    return (not any(c in folder for c in "*?[")
            and os.path.realpath(folder) == os.path.dirname(path.real)
            and fnmatch.fnmatch(os.path.basename(path.real), name))


def _command_key(args: argparse.Namespace) -> str:
    sub = getattr(args, "theory_command", None)
    return f"{args.command} {sub}" if sub else str(getattr(args, "command", ""))


def _out_patterns(args: argparse.Namespace) -> tuple[str, ...]:
    pats = OUT_FILES.get(_command_key(args), ())
    return tuple(pats(args) if callable(pats) else pats)


def _written_under(out: _Entry, path: _Entry, patterns) -> str | None:
    """The name (relative to ``out``) under which the command writes ``path``, or None."""
    base = out.real.rstrip(os.sep) + os.sep
    if not path.real.startswith(base):
        return None
    rel = Path(path.real[len(base):]).as_posix()
    return rel if any(fnmatch.fnmatchcase(rel, p) for p in patterns) else None


def output_entries(args: argparse.Namespace, out, cache) -> tuple[list[_Entry], list[_Entry]]:
    """(output files, output folders) of the command: --json, synth's file; --out (or the
    default folder), the advisor cache folder (``cache``, None without one)."""
    files = []
    if getattr(args, "json", None) is not None and str(args.json) != "-":
        files.append(_Entry("--json", args.json))
    if getattr(args, "output", None) is not None:
        files.append(_Entry(getattr(args, "output_metavar", "output") or "the map", args.output))
    folders = [] if out is None else [_Entry("--out", out)]
    if cache is not None:
        folders.append(_Entry("--cache-dir" if getattr(args, "cache_dir", None) is not None
                              else "the advisor cache", cache))
    return files, folders


def check_no_overlap(args: argparse.Namespace, out=None, cache=None) -> None:
    """Raise :class:`OutputError` (one line) where an output names an input, lies where it
    would be read as one, or two outputs name one file (module docstring)."""
    inputs, in_folders = _input_entries(args)
    files, folders = output_entries(args, out, cache)
    for o in files + folders:
        for i in inputs:
            if o.same(i):
                what = "folder" if o in folders else "file"
                raise OutputError(f"{o} is the input map {i.path}: an output {what} may not "
                                  "replace an input; choose another path")
        for d in in_folders:
            if o in folders and o.same(d):
                raise OutputError(f"{o} is the folder of input maps {d.path}: files written "
                                  "there would be read as maps by the next run; choose another "
                                  "folder")
            if (o in files and Path(o.path).suffix.lower() in _map_extensions()
                    and os.path.realpath(os.path.dirname(o.real)) == d.real):
                raise OutputError(f"{o} lies in the folder of input maps {d.path} and would be "
                                  "read as a map by the next run; choose another folder")
    for o in files:
        for pat in _patterns(args):
            if _matches_pattern(o, pat):
                raise OutputError(f"{o} matches the input pattern {pat} and would be read as a "
                                  "map by the next run; choose another path")
    _check_out_folder(args, inputs, files, folders)
    for k, a in enumerate(files):
        for b in files[k + 1:]:
            if a.same(b):
                raise OutputError(f"{a} and {b} name the same file: each output needs its own "
                                  "path")


def _check_out_folder(args, inputs, files, folders) -> None:
    """Inputs and --json against the files the command writes into --out."""
    outs = [f for f in folders if f.label == "--out"]
    if not outs:
        return
    pats = _out_patterns(args)
    for i in inputs:
        rel = _written_under(outs[0], i, pats)
        if rel is not None:
            raise OutputError(f"{outs[0]} holds the input map {i.path}, which the command "
                              f"writes there ({rel}); choose another --out folder or move "
                              "the map")
    for f in files:
        rel = _written_under(outs[0], f, pats)
        if rel is not None:
            raise OutputError(f"{f} is also written by {outs[0]} ({rel}): each output needs its "
                              "own path")


def _map_extensions() -> tuple[str, ...]:
    from envfit.maps import MAP_EXTENSIONS
    return MAP_EXTENSIONS
